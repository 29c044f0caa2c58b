// The convergence benchmark (caustica-bench --only convergence): each integrator's error against a
// converged path-traced reference as its passes accumulate, with the time they took.
#pragma once

#include "absl/status/status.h"
#include "bench/benchmarks.h"
#include "bench/measure.h"

namespace caustica {

// Renders the scene of `o.photon_scene` at o.width x o.height with the path integrator for
// o.reference_passes passes (seed apart from the measured runs'), then, for the photon and the path
// integrator in turn, doubling runs of passes up to o.convergence_passes, and reports after each
// (one "convergence" line): the passes, the milliseconds the passes took together, the relative
// RMS error over the image, the worst of the 8 x 8 regions' mean luminance errors (also with the
// pixels that see a light directly left out) and the whole image's mean ratio to the reference.
absl::Status convergence_benchmark(const BenchOptions& o, Reporter& report);

}  // namespace caustica
