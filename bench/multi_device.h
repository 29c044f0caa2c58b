// The frame and the light animation on one device and on several (EngineOptions::backends), in
// one process, so that their ratio is the multi-device speed-up (docs/multi-device.md).
#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "bench/benchmarks.h"
#include "bench/measure.h"

namespace caustica {

// frame_devices and animation_devices: run only when --only names them.
std::vector<std::string> multi_device_benchmark_names();

absl::Status multi_device_benchmarks(const BenchOptions& options, Reporter& report);

}  // namespace caustica
