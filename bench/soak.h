// The soak test (caustica-bench --soak): many clients cycle through a scene's whole life on one
// caustica-server over loopback for a fixed time, then a storm of streams is opened and cancelled
// at once. It reports per-call latency and errors, the server's resident and device memory at the
// start and the end, and whether the server stayed healthy, as one JSON line. Every frame is
// compared with one rendered at the start for the same lights.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>

#include "absl/status/statusor.h"

namespace caustica {

struct SoakOptions {
  int clients = 64;
  double minutes = 10;  // of cycling after the warm-up; fractions allowed
  // Of unmeasured cycling first, until the server's memory settled: at least this long, and at
  // least this many cycles a client (with --hostile, each followed by one hostile action).
  double warmup_minutes = 2;
  int warmup_cycles = 1;
  int storm = 256;  // streams opened and cancelled at once afterwards; 0 skips the storm
  std::filesystem::path scene;  // empty: the bundled Cornell box
  // Small, with few photons, so that a CPU server keeps up with every client.
  int width = 64, height = 64;
  uint32_t photons = 1000;
  std::string server;          // host:port of a running server; empty: start one
  pid_t server_pid = 0;        // with `server`: the process whose resident memory is read
  std::string device = "cpu";  // the started server's --device
  // The started server's --data-dir, so that every upload, change and delete is also stored;
  // empty: none.
  std::filesystem::path data_dir;
  double deadline_s = 60;  // of every call
  // Every client also attacks every port of the server between its cycles (hostile_client.h);
  // needs a started server, whose health, metrics and viewer ports are then open too.
  bool hostile = false;
};

// Runs the soak and writes its report. Returns whether it passed (no errors, memory flat, the
// server healthy after the storm and, when hostile, every hostile probe answered as promised), or
// an error when it could not run at all.
absl::StatusOr<bool> run_soak(const SoakOptions& options, std::ostream& out);

}  // namespace caustica
