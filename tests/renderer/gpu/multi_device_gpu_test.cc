// The multi-device engine on CUDA backends where a host has one GPU: two backends on GPU 0 (two
// streams and pools, photon shares copied device to device) against one, and a CPU backend with a
// GPU backend in one engine (shares copied through the host) against the GPU alone, which also
// proves every visible GPU (each one, then all of them together) where a host has several. Host
// code over the engine; skips where the CUDA runtime finds no device.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "renderer/engine.h"
#include "renderer/parallel/cuda/cuda_backend.h"
#include "renderer/render/image_error.h"
#include "renderer/scene/load_scene.h"

namespace caustica {
namespace {

Scene scene_at(const std::string& name, int size, uint32_t photons,
               Integrator integrator = Integrator::kPhoton) {
  absl::StatusOr<Scene> scene =
      load_scene(std::filesystem::path(CAUSTICA_SCENES_DIR) / name / "scene.json");
  EXPECT_TRUE(scene.ok()) << scene.status();
  if (!scene.ok()) return {};
  scene->camera.width = scene->camera.height = size;
  scene->settings.photons_per_pass = photons;
  scene->settings.integrator = integrator;
  return *std::move(scene);
}

std::shared_ptr<Backend> backend_for(DeviceKind kind, int ordinal) {
  absl::StatusOr<std::shared_ptr<Backend>> backend = make_backend(kind, size_t{4} << 30, ordinal);
  EXPECT_TRUE(backend.ok()) << backend.status();
  return backend.ok() ? *backend : nullptr;
}

// `scene` rendered for `passes` passes by one engine over `backends`.
std::vector<float> render_over(const std::vector<std::shared_ptr<Backend>>& backends,
                               const Scene& scene, uint32_t passes) {
  absl::StatusOr<std::unique_ptr<Engine>> engine = Engine::create({.backends = backends});
  EXPECT_TRUE(engine.ok()) << engine.status();
  if (!engine.ok()) return {};
  EXPECT_TRUE((*engine)->load(scene).ok());
  absl::StatusOr<PassReport> rendered = (*engine)->render(passes);
  EXPECT_TRUE(rendered.ok()) << rendered.status();
  if (!rendered.ok()) return {};
  const std::span<const float> image = (*engine)->image_linear();
  return {image.begin(), image.end()};
}

// The largest difference relative to the larger value; -1 when the sizes differ or the
// reference is black.
double worst_relative_difference(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size() || a.empty()) return -1;
  double worst = 0, sum = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    sum += b[i];
    if (a[i] == b[i]) continue;
    const double scale = std::max(std::fabs(double(a[i])), std::fabs(double(b[i])));
    worst = std::max(worst, std::fabs(double(a[i]) - b[i]) / scale);
  }
  return sum > 0 ? worst : -1;
}

// Two backends on GPU 0 render one backend's image: bit for bit with the path integrator, and
// to the last bits of a few gathers with knn (docs/multi-device.md).
TEST(GpuMultiDevice, TwoBackendsOnOneGpuRenderOneBackendsImage) {
  if (!cuda_device_available()) GTEST_SKIP() << "no CUDA device: GPU tests skipped";
  for (auto [integrator, tolerance] :
       {std::pair{Integrator::kPath, 0.0}, std::pair{Integrator::kPhoton, 1e-5}}) {
    const Scene scene = scene_at("cornell-caustics", 256, 200000, integrator);
    const std::vector<float> one = render_over({backend_for(DeviceKind::kCuda, 0)}, scene, 3);
    const std::vector<float> two = render_over(
        {backend_for(DeviceKind::kCuda, 0), backend_for(DeviceKind::kCuda, 0)}, scene, 3);
    const double worst = worst_relative_difference(two, one);
    std::printf("%s on 2 backends of GPU 0: largest relative difference %.3g\n",
                integrator == Integrator::kPath ? "path" : "knn", worst);
    EXPECT_GE(worst, 0.0);
    EXPECT_LE(worst, tolerance);
  }
}

// Every visible GPU on its own, then all together, against GPU 0 alone; a host with one GPU
// checks it against itself twice over (0 and 0,0 already covered above).
TEST(GpuMultiDevice, EveryGpuAndAllTogetherRenderTheSameImage) {
  if (!cuda_device_available()) GTEST_SKIP() << "no CUDA device: GPU tests skipped";
  const Scene scene = scene_at("cornell-caustics", 256, 200000);
  const std::vector<float> reference = render_over({backend_for(DeviceKind::kCuda, 0)}, scene, 2);
  std::vector<std::shared_ptr<Backend>> all;
  for (int gpu = 0; gpu < device_count(DeviceKind::kCuda); ++gpu) {
    all.push_back(backend_for(DeviceKind::kCuda, gpu));
    EXPECT_LE(worst_relative_difference(render_over({all.back()}, scene, 2), reference), 1e-5)
        << "GPU " << gpu;
    EXPECT_EQ(all.back()->info().ordinal, gpu);
  }
  const double worst = worst_relative_difference(render_over(all, scene, 2), reference);
  std::printf("all %zu GPUs together: largest relative difference %.3g\n", all.size(), worst);
  EXPECT_GE(worst, 0.0);
  EXPECT_LE(worst, 1e-5);
}

// A CPU backend and a GPU backend in one engine: the shares cross through the host, and the
// image agrees with the GPU's as closely as a CPU's image does: the two backends' photon paths
// part in their last bits, so the whole image, not each small region, is what agrees.
TEST(GpuMultiDevice, ACpuAndAGpuInOneEngineAgreeWithTheGpu) {
  if (!cuda_device_available()) GTEST_SKIP() << "no CUDA device: GPU tests skipped";
  const Scene scene = scene_at("cornell-caustics", 128, 100000);
  const std::vector<float> gpu = render_over({backend_for(DeviceKind::kCuda, 0)}, scene, 2);
  const std::vector<float> mixed =
      render_over({backend_for(DeviceKind::kCuda, 0), backend_for(DeviceKind::kCpu, 0)}, scene, 2);
  ASSERT_EQ(gpu.size(), mixed.size());
  const ImageError e = image_error(mixed, gpu, 128, 128);
  std::printf("CPU + GPU against GPU: relative RMSE %.3g, mean ratio %.5f\n", e.relative_rmse,
              e.mean_ratio);
  EXPECT_NEAR(e.mean_ratio, 1.0, 0.005);
  EXPECT_LT(e.relative_rmse, 0.03);
}

}  // namespace
}  // namespace caustica
