// caustica-render's work as a library function: load a scene file, apply overrides, render with
// the engine, write the image, and report timings and counts.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "renderer/accel/structure_kind.h"
#include "renderer/engine.h"

namespace caustica {

struct RenderJob {
  std::filesystem::path scene;
  std::filesystem::path output;
  std::optional<int> width, height;
  std::optional<uint32_t> photons, k, passes, seed;
  std::optional<StructureKind> structure;
  std::vector<std::string> structure_options;  // NAME=VALUE over the scene's settings.build
  std::optional<Integrator> integrator;
  std::optional<EstimatorKind> estimator;
  std::optional<bool> final_gather;
  float exposure_stops = 0.0f;
  bool show_progress = false;  // progress line on stderr
};

struct RenderSummary {
  PassReport report;
  SceneStats stats;
  double load_ms = 0;
};

// Runs the job and writes a human-readable report of the stages to `log`.
absl::StatusOr<RenderSummary> run_render_job(const RenderJob& job, std::ostream& log);

}  // namespace caustica
