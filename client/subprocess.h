// Child processes of the CLI: the embedded caustica-server (kept running in the background) and
// ffmpeg (run to completion). fork + exec rather than posix_spawn so that the child can ask the
// kernel to SIGTERM it should the CLI die without cleaning up (PR_SET_PDEATHSIG).
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace caustica::client {

// Starts argv[0] (a path, or a name looked up on PATH) with `argv`. stdout and stderr go to
// `log_path` when given (appended), else stay the CLI's own. `environment` ("NAME=value") is set
// in the child's environment over the CLI's own.
absl::StatusOr<pid_t> spawn_process(const std::vector<std::string>& argv,
                                    const std::optional<std::filesystem::path>& log_path,
                                    const std::vector<std::string>& environment = {});

// The exit status of `pid` once it ended, nullopt while it runs (non-blocking).
std::optional<int> poll_exit(pid_t pid);

// Waits for `pid`; returns its exit status (128 + signal when a signal ended it).
int wait_exit(pid_t pid);

// SIGTERM, then SIGKILL once `grace` passed without the process ending; reaps it.
void terminate_process(pid_t pid, std::chrono::milliseconds grace);

// The full path of `name` found on $PATH, or nullopt.
std::optional<std::filesystem::path> find_on_path(const std::string& name);

}  // namespace caustica::client
