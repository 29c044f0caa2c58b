#include "bench/convergence.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <span>
#include <vector>

#include "absl/strings/str_format.h"
#include "renderer/engine.h"
#include "renderer/render/image_error.h"
#include "renderer/scene/load_scene.h"

namespace caustica {
namespace {

absl::StatusOr<std::unique_ptr<Engine>> loaded_engine(const Scene& scene, DeviceKind device) {
  absl::StatusOr<std::unique_ptr<Engine>> engine =
      Engine::create({.device = device, .memory_budget_bytes = size_t(16) << 30});
  if (!engine.ok()) return engine.status();
  if (auto loaded = (*engine)->load(scene); !loaded.ok()) return loaded.status();
  return engine;
}

// The runs compared: the photon integrator with each estimator, and the path integrator.
struct ConvergenceRun {
  Integrator integrator;
  EstimatorKind estimator;
  bool final_gather;
  const char* name;
};
constexpr ConvergenceRun kConvergenceRuns[] = {
    {Integrator::kPhoton, EstimatorKind::kKnn, false, "photon knn"},
    {Integrator::kPhoton, EstimatorKind::kKnn, true, "photon knn final gather"},
    {Integrator::kPhoton, EstimatorKind::kSppm, false, "photon sppm"},
    {Integrator::kPhoton, EstimatorKind::kVkde, false, "photon vkde"},
    {Integrator::kPath, EstimatorKind::kKnn, false, "path"},
};

bool wanted_run(const BenchOptions& o, const ConvergenceRun& run) {
  return o.convergence_runs.empty() ||
         std::find(o.convergence_runs.begin(), o.convergence_runs.end(), run.name) !=
             o.convergence_runs.end();
}

}  // namespace

std::vector<std::string> convergence_run_names() {
  std::vector<std::string> names;
  for (const ConvergenceRun& run : kConvergenceRuns) names.push_back(run.name);
  return names;
}

absl::Status convergence_benchmark(const BenchOptions& o, Reporter& report) {
  absl::StatusOr<Scene> loaded = load_scene(o.photon_scene);
  if (!loaded.ok()) return loaded.status();
  Scene scene = *std::move(loaded);
  scene.camera.width = o.width;
  scene.camera.height = o.height;
  scene.settings.photons_per_pass = o.photons;
  scene.settings.k_nearest = o.k;
  apply_final_gather_options(o, scene.settings);
  absl::StatusOr<DeviceKind> device = parse_device_kind(o.device);
  if (!device.ok()) return device.status();
  const std::string name = o.photon_scene.parent_path().filename().string() +
                           absl::StrFormat(" %dx%d", o.width, o.height);

  // The reference: the path integrator converged, with a seed of its own.
  Scene reference_scene = scene;
  reference_scene.settings.integrator = Integrator::kPath;
  reference_scene.settings.seed = scene.settings.seed ^ 0x5eed1234u;
  absl::StatusOr<std::unique_ptr<Engine>> reference_engine =
      loaded_engine(reference_scene, *device);
  if (!reference_engine.ok()) return reference_engine.status();
  if (auto r = (*reference_engine)->render(o.reference_passes); !r.ok()) return r.status();
  const std::span<const float> reference_span = (*reference_engine)->image_linear();
  const std::vector<float> reference(reference_span.begin(), reference_span.end());
  reference_engine->reset();
  // Pixels that see a light directly (brighter than half the dimmest emitter's radiance), and their
  // neighbours, are left out of "worst_region_off_lights": at a light's edge a pixel's value is the
  // share of its jittered samples that hit the light, noise every integrator shares.
  double dimmest_emitter = INFINITY;
  for (const Material& m : scene.materials)
    if (m.type == MaterialType::kEmissive)
      dimmest_emitter =
          std::min(dimmest_emitter, (double(m.radiance.x) + m.radiance.y + m.radiance.z) / 3.0);

  for (const ConvergenceRun& run : kConvergenceRuns) {
    if (!wanted_run(o, run)) continue;
    Scene measured = scene;
    measured.settings.integrator = run.integrator;
    measured.settings.estimator = run.estimator;
    measured.settings.final_gather = run.final_gather;
    // Runs that do not render the scene's media are left out (media_support says which).
    if (!media_support(measured, measured.settings).ok()) continue;
    absl::StatusOr<std::unique_ptr<Engine>> engine = loaded_engine(measured, *device);
    if (!engine.ok()) return engine.status();
    // A pass first, so that the measured ones find the code loaded; a camera update empties the
    // film, and the passes start again from the first.
    if (auto r = (*engine)->render(1); !r.ok()) return r.status();
    if (auto r = (*engine)->set_camera(measured.camera); !r.ok()) return r.status();
    double elapsed_ms = 0;
    uint32_t done = 0;
    for (uint32_t passes = 1; passes <= o.convergence_passes; passes *= 2) {
      const auto start = std::chrono::steady_clock::now();
      if (auto r = (*engine)->render(passes - done); !r.ok()) return r.status();
      (*engine)->backend().synchronize();
      elapsed_ms +=
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();
      done = passes;
      const std::span<const float> image = (*engine)->image_linear();
      const ImageError e = image_error(image, reference, o.width, o.height);
      const ImageError off_lights =
          image_error(image, reference, o.width, o.height, 0.5 * dimmest_emitter);
      report.point("convergence", name,
                   absl::StrFormat(R"("integrator": "%s", "passes": %d, "ms": %.6g, )"
                                   R"("relative_rmse": %.6g, "worst_region": %.6g, )"
                                   R"("worst_region_off_lights": %.6g, )"
                                   R"("mean_ratio": %.6g, "reference_passes": %d)",
                                   run.name, passes, elapsed_ms, e.relative_rmse, e.worst_region,
                                   off_lights.worst_region, e.mean_ratio, o.reference_passes));
    }
  }
  return absl::OkStatus();
}

}  // namespace caustica
