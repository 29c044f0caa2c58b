// Textured models on both backends: the Cesium box (a PNG colour map under a mirrored-repeat and
// clamped sampler) and the spider (five JPEG maps of an OBJ model) render alike on the CPU and the
// GPU with the same seed, and unlike their untextured selves; so does the DamagedHelmet, whose
// emission map shapes what it emits, with its point lights and lit by its own glow alone; and
// sheets cut out by a mask or blended.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "renderer/engine.h"
#include "renderer/parallel/cuda/cuda_backend.h"
#include "renderer/scene/load_scene.h"
#include "tests/renderer/gpu/render_image.h"

namespace caustica {
namespace {

std::vector<float> render_on(DeviceKind kind, const Scene& scene, uint32_t passes) {
  absl::StatusOr<std::shared_ptr<Backend>> backend = make_backend(kind, size_t{4} << 30, 0);
  EXPECT_TRUE(backend.ok()) << backend.status();
  if (!backend.ok()) return {};
  absl::StatusOr<std::unique_ptr<Engine>> engine = Engine::create({.backends = {*backend}});
  EXPECT_TRUE(engine.ok()) << engine.status();
  if (!engine.ok()) return {};
  const absl::StatusOr<RebuildReport> loaded = (*engine)->load(scene);
  EXPECT_TRUE(loaded.ok()) << loaded.status();
  if (!loaded.ok() || !(*engine)->render(passes).ok()) return {};
  const std::span<const float> image = (*engine)->image_linear();
  expect_finite(image, scene.camera.width, kind == DeviceKind::kCpu ? "CPU" : "GPU");
  return {image.begin(), image.end()};
}

// The RMS difference of two linear RGBA images over the RMS of the first, alpha left out.
double relative_rmse(const std::vector<float>& reference, const std::vector<float>& other) {
  double difference = 0, sum = 0;
  for (size_t i = 0; i < reference.size(); ++i) {
    if (i % 4 == 3) continue;
    const double d = double(other[i]) - reference[i];
    difference += d * d;
    sum += double(reference[i]) * reference[i];
  }
  return sum > 0 ? std::sqrt(difference / sum) : -1;
}

TEST(GpuTextures, TexturedModelsRenderAlikeOnBothBackends) {
  if (!cuda_device_available()) GTEST_SKIP() << "no CUDA device: GPU tests skipped";
  for (const char* model : {"gltf2/BoxTextured/BoxTextured.gltf", "obj/spider/spider.obj"}) {
    SCOPED_TRACE(model);
    absl::StatusOr<Scene> scene =
        load_scene(std::filesystem::path(CAUSTICA_TEST_DATA) / "scene/thirdparty" / model);
    ASSERT_TRUE(scene.ok()) << scene.status();
    ASSERT_FALSE(scene->textures.empty());
    scene->camera.width = 128;
    scene->camera.height = 96;
    scene->settings.photons_per_pass = 100000;
    scene->settings.seed = 5;
    const std::vector<float> cpu = render_on(DeviceKind::kCpu, *scene, 4);
    const std::vector<float> gpu = render_on(DeviceKind::kCuda, *scene, 4);
    ASSERT_FALSE(cpu.empty());
    ASSERT_EQ(cpu.size(), gpu.size());
    Scene plain = *scene;
    for (Material& m : plain.materials) m.color_map = TextureRef{};
    const std::vector<float> untextured = render_on(DeviceKind::kCuda, plain, 4);
    const double rmse = relative_rmse(cpu, gpu), change = relative_rmse(untextured, gpu);
    std::printf("%s: relative RMSE GPU vs CPU %.5f; textured vs untextured %.3f\n", model, rmse,
                change);
    EXPECT_LT(rmse, 0.02);
    EXPECT_GT(change, 0.1);
  }
}

TEST(GpuTextures, AnEmissionMapShapesTheHelmetAlikeOnBothBackends) {
  if (!cuda_device_available()) GTEST_SKIP() << "no CUDA device: GPU tests skipped";
  absl::StatusOr<Scene> scene =
      load_scene(std::filesystem::path(CAUSTICA_SCENES_DIR) / "damaged-helmet" / "scene.json");
  ASSERT_TRUE(scene.ok()) << scene.status();
  scene->camera.width = scene->camera.height = 128;
  scene->settings.photons_per_pass = 200000;
  scene->settings.seed = 5;
  for (const bool lit : {true, false}) {
    SCOPED_TRACE(lit ? "the sky and glow" : "glow alone");
    Scene s = *scene;
    if (!lit) {
      s.lights.clear();
      s.environment.present = false;
    }
    const std::vector<float> cpu = render_on(DeviceKind::kCpu, s, 4);
    const std::vector<float> gpu = render_on(DeviceKind::kCuda, s, 4);
    ASSERT_FALSE(cpu.empty());
    ASSERT_EQ(cpu.size(), gpu.size());
    const double rmse = relative_rmse(cpu, gpu);
    std::printf("DamagedHelmet (%s): relative RMSE GPU vs CPU %.5f\n", lit ? "lit" : "glow alone",
                rmse);
    EXPECT_LT(rmse, 0.02);
  }
}

// The mean of the bottom quarter of an RGBA image `width` wide: the Cornell box's floor.
double floor_mean(const std::vector<float>& image, uint32_t width) {
  const size_t rows = image.size() / 4 / width, first = size_t(width) * (rows - rows / 4);
  double sum = 0;
  for (size_t p = first; p < image.size() / 4; ++p)
    sum += double(image[4 * p]) + image[4 * p + 1] + image[4 * p + 2];
  return sum / double(image.size() / 4 - first);
}

// A white sheet across the Cornell box between its light and its floor, cut away on one half by a
// mask of two texels (alpha 0 and 1) or blended at opacity 1/2: per ray and in batches (dacrt),
// the GPU's image is the CPU's, and its floor darker than the box's without the sheet.
TEST(GpuTextures, CutOutAndBlendedSheetsRenderAlikeOnBothBackendsPerRayAndInBatches) {
  if (!cuda_device_available()) GTEST_SKIP() << "no CUDA device: GPU tests skipped";
  absl::StatusOr<Scene> box =
      load_scene(std::filesystem::path(CAUSTICA_SCENES_DIR) / "cornell-box" / "scene.json");
  ASSERT_TRUE(box.ok()) << box.status();
  box->camera.width = 128;
  box->camera.height = 96;
  box->settings.photons_per_pass = 100000;
  box->settings.seed = 5;
  auto mask = std::make_shared<DecodedImage>();
  mask->width = 2;
  mask->height = 1;
  mask->rgba8 = {255, 255, 255, 0, 255, 255, 255, 255};
  mask->has_alpha = true;
  for (const AlphaMode mode : {AlphaMode::kMask, AlphaMode::kBlend})
    for (const StructureKind structure : {kDefaultStructure, StructureKind::kDacrt}) {
      const char* mode_name = mode == AlphaMode::kMask ? "mask" : "blend";
      SCOPED_TRACE(mode_name);
      SCOPED_TRACE(structure_kind_name(structure));
      Scene plain = *box;
      plain.settings.structure = structure;
      Scene sheeted = plain;
      Material sheet;
      sheet.name = "sheet";
      sheet.color = Vec3f(0.8f);
      sheet.alpha_mode = mode;
      if (mode == AlphaMode::kMask) {
        sheeted.textures.push_back({"half-clear", nullptr, mask});
        sheet.opacity_map.texture = uint32_t(sheeted.textures.size() - 1);
        sheet.opacity_map.wrap_u = sheet.opacity_map.wrap_v = TextureWrap::kClampToEdge;
      } else {
        sheet.opacity = 0.5f;
      }
      sheeted.materials.push_back(sheet);
      Mesh across;
      across.name = "sheet";
      across.positions = {{0, 300, 0}, {556, 300, 0}, {556, 300, 559.2f}, {0, 300, 559.2f}};
      across.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
      across.indices = {0, 1, 2, 0, 2, 3};
      across.material_ids.assign(2, uint32_t(sheeted.materials.size() - 1));
      sheeted.meshes.push_back(across);
      const std::vector<float> cpu = render_on(DeviceKind::kCpu, sheeted, 4);
      const std::vector<float> gpu = render_on(DeviceKind::kCuda, sheeted, 4);
      ASSERT_FALSE(cpu.empty());
      ASSERT_EQ(cpu.size(), gpu.size());
      const std::vector<float> without = render_on(DeviceKind::kCuda, plain, 4);
      const double rmse = relative_rmse(cpu, gpu);
      const double darker = floor_mean(gpu, box->camera.width) / floor_mean(without, box->camera.width);
      std::printf("Cornell box, %s sheet, %s: relative RMSE GPU vs CPU %.5f; floor %.3f of the "
                  "box's without it\n",
                  mode_name, structure_kind_name(structure), rmse, darker);
      EXPECT_LT(rmse, 0.02);
      EXPECT_LT(darker, 0.8);
      EXPECT_GT(darker, 0.2);
    }
}

}  // namespace
}  // namespace caustica
