// Participating media against the path-traced reference on the GPU: the fog and smoke boxes (an
// area light, so that the path tracer converges) rendered by the photon integrator's estimators
// and by the path tracer with a seed of its own, compared region by region as the convergence
// benchmark compares them (render/image_error.h). Host code over the engine; skips where the CUDA
// runtime finds no device.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "renderer/engine.h"
#include "renderer/parallel/cuda/cuda_backend.h"
#include "renderer/render/image_error.h"
#include "renderer/scene/load_scene.h"
#include "tests/renderer/gpu/render_image.h"

namespace caustica {
namespace {

// As the convergence benchmark measures them: a smaller image leaves each region fewer of the
// reference's samples, and its noise then outweighs the estimators' bias.
constexpr int kSize = 512;

std::vector<float> render_on_gpu(const Scene& scene, uint32_t passes) {
  return render_image(scene, DeviceKind::kCuda, passes, size_t{4} << 30);
}

struct Estimate {
  EstimatorKind estimator;
  double worst_region;  // the bound each 8 x 8 region's mean keeps to the reference's
};

// `name`'s bundled scene at 512x512: the path tracer's 2048 passes against 256 passes of 1M
// photons with each estimate.
void expect_near_reference(const std::string& name, std::initializer_list<Estimate> estimates) {
  absl::StatusOr<Scene> scene =
      load_scene(std::filesystem::path(CAUSTICA_SCENES_DIR) / name / "scene.json");
  ASSERT_TRUE(scene.ok()) << scene.status();
  scene->camera.width = scene->camera.height = kSize;
  Scene reference_scene = *scene;
  reference_scene.settings.integrator = Integrator::kPath;
  reference_scene.settings.seed = scene->settings.seed ^ 0x5eed1234u;
  const std::vector<float> reference = render_on_gpu(reference_scene, 2048);
  ASSERT_FALSE(reference.empty());
  for (const Estimate& e : estimates) {
    Scene photon_scene = *scene;
    photon_scene.settings.photons_per_pass = 1000000;
    photon_scene.settings.k_nearest = 64;
    photon_scene.settings.estimator = e.estimator;
    const std::vector<float> image = render_on_gpu(photon_scene, 256);
    ASSERT_EQ(image.size(), reference.size());
    const ImageError error = image_error(image, reference, kSize, kSize);
    std::printf("%s: %s, worst region %.4f, mean ratio %.4f\n", name.c_str(),
                kind_name(e.estimator), error.worst_region, error.mean_ratio);
    EXPECT_LT(error.worst_region, e.worst_region) << kind_name(e.estimator);
    EXPECT_NEAR(error.mean_ratio, 1.0, 0.01) << kind_name(e.estimator);
  }
}

// The vkde estimator keeps every region within 3%; the knn estimator's k-nearest blur at the
// walls and beam bandwidths leave it a little over (docs/media.md, "Checks").
TEST(GpuMedia, FogBoxMatchesThePathTracedReference) {
  if (!cuda_device_available()) GTEST_SKIP() << "no CUDA device: GPU tests skipped";
  expect_near_reference("fog-box", {{EstimatorKind::kVkde, 0.03}, {EstimatorKind::kKnn, 0.035}});
}

TEST(GpuMedia, SmokeBoxMatchesThePathTracedReference) {
  if (!cuda_device_available()) GTEST_SKIP() << "no CUDA device: GPU tests skipped";
  expect_near_reference("smoke-box", {{EstimatorKind::kVkde, 0.03}, {EstimatorKind::kKnn, 0.03}});
}

}  // namespace
}  // namespace caustica
