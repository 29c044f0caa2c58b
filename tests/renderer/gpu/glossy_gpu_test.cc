// Metallic-roughness, Phong and rough glass on both backends: the bundled glossy Cornell box
// renders alike on the CPU and the GPU with the same seed, with each photon estimator and the
// path tracer.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <vector>

#include "renderer/parallel/cuda/cuda_backend.h"
#include "renderer/render/image_error.h"
#include "renderer/scene/load_scene.h"
#include "tests/renderer/gpu/render_image.h"

namespace caustica {
namespace {

TEST(GpuGlossy, TheGlossyCornellBoxRendersAlikeOnBothBackends) {
  if (!cuda_device_available()) GTEST_SKIP() << "no CUDA device: GPU tests skipped";
  absl::StatusOr<Scene> scene =
      load_scene(std::filesystem::path(CAUSTICA_SCENES_DIR) / "cornell-glossy" / "scene.json");
  ASSERT_TRUE(scene.ok()) << scene.status();
  scene->camera.width = scene->camera.height = 96;
  scene->settings.photons_per_pass = 200000;
  scene->settings.seed = 5;
  struct Case {
    const char* name;
    Integrator integrator;
    EstimatorKind estimator;
    uint32_t passes;
  };
  for (const Case& c : {Case{"knn", Integrator::kPhoton, EstimatorKind::kKnn, 16},
                        Case{"sppm", Integrator::kPhoton, EstimatorKind::kSppm, 16},
                        Case{"vkde", Integrator::kPhoton, EstimatorKind::kVkde, 16},
                        Case{"path", Integrator::kPath, EstimatorKind::kKnn, 1024}}) {
    SCOPED_TRACE(c.name);
    Scene s = *scene;
    s.settings.integrator = c.integrator;
    s.settings.estimator = c.estimator;
    const ImageError e = backend_difference(s, c.passes);
    std::printf(
        "glossy Cornell box, %s: relative RMSE GPU vs CPU %.5f, mean %.5f, worst region "
        "%.2f%%\n",
        c.name, e.relative_rmse, e.mean_ratio, 100 * e.worst_region);
    // The backends' paths part at their first rounding difference: the path tracer's images are
    // two estimates whose noise the bound allows for, the photon estimators' nearly one.
    EXPECT_NEAR(e.mean_ratio, 1.0, 0.01);
    EXPECT_LT(e.worst_region, c.integrator == Integrator::kPath ? 0.08 : 0.05);
  }
}

}  // namespace
}  // namespace caustica
