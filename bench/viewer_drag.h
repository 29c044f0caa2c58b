// The browser viewer's drag-to-frame latency without a browser: a WebSocket client that speaks the
// page's protocol (docs/viewer.md) to a caustica-server started with --http-listen, moves a light
// as a drag does and times each move from sending it to the arrival of the first frame of the
// lights epoch it produced. For GPU hosts, where no browser runs.
#pragma once

#include "absl/status/status.h"
#include "bench/benchmarks.h"

namespace caustica {

class Reporter;

inline constexpr char kViewerDragBenchmark[] = "viewer_drag";

// Starts its own caustica-server (options.device, the viewer on a free loopback port), uploads
// options.photon_scene at options.width x options.height with options.photons, and reports
// `viewer_drag` (the latency), its server-side parts and `viewer_drag_bytes` as JSON lines.
absl::Status run_viewer_drag_benchmark(const BenchOptions& options, Reporter& report);

}  // namespace caustica
