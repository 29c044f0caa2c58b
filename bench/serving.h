// Serving benchmarks: what a client of caustica-server sees over loopback. Frames per second and
// MB/s delivered by StreamFrames when rendering costs nothing (the film is re-sent as is), upload
// throughput of a mesh, and the latency from UpdateLights to the first frame of the new epoch,
// split into rebuild, render and transport.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "bench/benchmarks.h"

namespace caustica {

class Reporter;

std::vector<std::string> serving_benchmark_names();

namespace client {
class Connection;
}
// `report` labelled with the device the connected server renders on (figures are the server's,
// not the benchmark's own CPU's).
absl::StatusOr<Reporter> server_device_reporter(client::Connection& connection,
                                                const Reporter& report);

// Starts a caustica-server on a free loopback port (found like the CLI's embedded default) on
// options.device and runs the serving benchmarks selected by options.only.
absl::Status run_serving_benchmarks(const BenchOptions& options, Reporter& report);

}  // namespace caustica
