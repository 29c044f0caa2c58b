// Runs commands (the caustica binary of the build among them) for the client and server tests.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace caustica::testing {

struct CommandRun {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

// Runs `command` through the shell.
inline CommandRun run_command(const std::string& command) {
  CommandRun run;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return run;
  char buffer[4096];
  for (size_t n; (n = fread(buffer, 1, sizeof(buffer), pipe)) > 0;) run.output.append(buffer, n);
  const int status = pclose(pipe);
  if (WIFEXITED(status)) run.exit_code = WEXITSTATUS(status);
  return run;
}

// Runs `caustica ARGS` (CAUSTICA_CLIENT_BIN); ARGS are passed to the shell as they are.
inline CommandRun run_client(const std::string& args) {
  return run_command(std::string("'") + CAUSTICA_CLIENT_BIN + "' " + args);
}

}  // namespace caustica::testing
