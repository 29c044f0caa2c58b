#include "bench/convergence.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <span>
#include <vector>

#include "absl/strings/str_format.h"
#include "renderer/engine.h"
#include "renderer/scene/load_scene.h"

namespace caustica {
namespace {

// Regions per side of the image whose mean luminance is compared.
constexpr int kRegionsPerSide = 8;
// A region darker than this share of the reference's mean is left out of the worst region: its
// relative error says little.
constexpr double kDarkRegionShare = 0.02;

struct ImageError {
  double relative_rmse = 0;  // over every pixel and channel, relative to the reference's RMS
  double worst_region = 0;   // the largest |region mean / reference region mean - 1|
  double mean_ratio = 0;     // the image's mean luminance over the reference's
};

double luminance(const float* rgba) { return (double(rgba[0]) + rgba[1] + rgba[2]) / 3.0; }

ImageError compare(std::span<const float> image, const std::vector<float>& reference, int width,
                   int height) {
  ImageError e;
  double difference = 0, sum = 0, mean = 0, mean_reference = 0;
  std::vector<double> region(kRegionsPerSide * kRegionsPerSide, 0.0),
      region_reference(region.size(), 0.0);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const size_t i = 4 * (size_t(y) * width + x);
      for (int c = 0; c < 3; ++c) {
        const double d = double(image[i + c]) - reference[i + c];
        difference += d * d;
        sum += double(reference[i + c]) * reference[i + c];
      }
      const size_t r = size_t(y * kRegionsPerSide / height) * kRegionsPerSide +
                       size_t(x * kRegionsPerSide / width);
      region[r] += luminance(&image[i]);
      region_reference[r] += luminance(&reference[i]);
      mean += luminance(&image[i]);
      mean_reference += luminance(&reference[i]);
    }
  }
  e.relative_rmse = sum > 0 ? std::sqrt(difference / sum) : 0.0;
  e.mean_ratio = mean_reference > 0 ? mean / mean_reference : 0.0;
  const double dark = kDarkRegionShare * mean_reference / double(region.size());
  for (size_t r = 0; r < region.size(); ++r) {
    if (region_reference[r] <= dark) continue;
    e.worst_region = std::max(e.worst_region, std::fabs(region[r] / region_reference[r] - 1.0));
  }
  return e;
}

absl::StatusOr<std::unique_ptr<Engine>> loaded_engine(const Scene& scene, DeviceKind device) {
  absl::StatusOr<std::unique_ptr<Engine>> engine =
      Engine::create({.device = device, .memory_budget_bytes = size_t(16) << 30});
  if (!engine.ok()) return engine.status();
  if (auto loaded = (*engine)->load(scene); !loaded.ok()) return loaded.status();
  return engine;
}

const char* integrator_name(Integrator integrator) {
  return integrator == Integrator::kPath ? "path" : "photon";
}

}  // namespace

absl::Status convergence_benchmark(const BenchOptions& o, Reporter& report) {
  absl::StatusOr<Scene> loaded = load_scene(o.photon_scene);
  if (!loaded.ok()) return loaded.status();
  Scene scene = *std::move(loaded);
  scene.camera.width = o.width;
  scene.camera.height = o.height;
  scene.settings.photons_per_pass = o.photons;
  scene.settings.k_nearest = o.k;
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

  for (Integrator integrator : {Integrator::kPhoton, Integrator::kPath}) {
    Scene measured = scene;
    measured.settings.integrator = integrator;
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
      const ImageError e = compare((*engine)->image_linear(), reference, o.width, o.height);
      report.point("convergence", name,
                   absl::StrFormat(R"("integrator": "%s", "passes": %d, "ms": %.6g, )"
                                   R"("relative_rmse": %.6g, "worst_region": %.6g, )"
                                   R"("mean_ratio": %.6g, "reference_passes": %d)",
                                   integrator_name(integrator), passes, elapsed_ms, e.relative_rmse,
                                   e.worst_region, e.mean_ratio, o.reference_passes));
    }
  }
  return absl::OkStatus();
}

}  // namespace caustica
