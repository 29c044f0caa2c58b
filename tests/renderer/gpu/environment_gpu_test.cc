// The environment light on both backends: the DamagedHelmet under its sunset and a glass sphere on
// a floor under the same sky render alike on the CPU and the GPU with the same seed, with each
// photon estimator and the path tracer.
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

TEST(GpuEnvironment, ScenesUnderTheSunsetRenderAlikeOnBothBackends) {
  if (!cuda_device_available()) GTEST_SKIP() << "no CUDA device: GPU tests skipped";
  const std::filesystem::path helmet_dir =
      std::filesystem::path(CAUSTICA_SCENES_DIR) / "damaged-helmet";
  absl::StatusOr<Scene> helmet = load_scene(helmet_dir / "scene.json");
  ASSERT_TRUE(helmet.ok()) << helmet.status();
  absl::StatusOr<Scene> spheres = parse_scene(R"({
    "camera": {"position": [0, 2.2, 3.2], "look_at": [0, 0.3, 0], "fov": 45,
               "width": 8, "height": 8},
    "materials": {"floor": {"type": "diffuse", "albedo": [0.6, 0.6, 0.6]},
                  "white": {"type": "diffuse", "albedo": [0.8, 0.7, 0.6]},
                  "glass": {"type": "dielectric", "ior": 1.5}},
    "environment": {"map": "sunset.hdr", "rotation": 200},
    "shapes": [{"type": "quad", "material": "floor",
                "vertices": [[-3, 0, -3], [-3, 0, 3], [3, 0, 3], [3, 0, -3]]},
               {"type": "sphere", "material": "white", "center": [-0.6, 0.5, 0], "radius": 0.5},
               {"type": "sphere", "material": "glass", "center": [0.6, 0.5, 0.2], "radius": 0.45}]
  })",
                                              helmet_dir, "spheres.json");
  ASSERT_TRUE(spheres.ok()) << spheres.status();
  struct Case {
    const char* name;
    Integrator integrator;
    EstimatorKind estimator;
    uint32_t passes;
  };
  for (const auto& [scene_name, scene] : {std::pair{"helmet", &*helmet}, {"spheres", &*spheres}}) {
    for (const Case& c : {Case{"knn", Integrator::kPhoton, EstimatorKind::kKnn, 16},
                          Case{"sppm", Integrator::kPhoton, EstimatorKind::kSppm, 16},
                          Case{"vkde", Integrator::kPhoton, EstimatorKind::kVkde, 16},
                          Case{"path", Integrator::kPath, EstimatorKind::kKnn, 1024}}) {
      SCOPED_TRACE(std::string(scene_name) + " " + c.name);
      Scene s = *scene;
      s.camera.width = s.camera.height = 96;
      s.settings.photons_per_pass = 200000;
      s.settings.seed = 5;
      s.settings.integrator = c.integrator;
      s.settings.estimator = c.estimator;
      const ImageError e = backend_difference(s, c.passes);
      std::printf(
          "%s under the sunset, %s: relative RMSE GPU vs CPU %.5f, mean %.5f, worst region "
          "%.2f%%\n",
          scene_name, c.name, e.relative_rmse, e.mean_ratio, 100 * e.worst_region);
      EXPECT_NEAR(e.mean_ratio, 1.0, 0.01);
      EXPECT_LT(e.worst_region, c.integrator == Integrator::kPath ? 0.08 : 0.05);
    }
  }
}

}  // namespace
}  // namespace caustica
