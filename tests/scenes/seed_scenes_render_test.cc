// The seeds' benchmark scenes in scenes/ (Sponza, Sibenik, Conference, and the bunny on its floor)
// load through load_scene as `caustica render` loads them and render, small and on the CPU, as
// interiors seen and lit from inside: textured where their files name textures, lit by their scene
// file's point light alone, and neither black nor a silhouette.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <span>
#include <string>

#include "renderer/engine.h"
#include "renderer/scene/load_scene.h"

namespace caustica {
namespace {

// Measured at 64 x 48 with 20,000 photons and one pass: mean luminance 0.18 (Sponza), 0.30
// (Sibenik), 0.34 (Conference) and 0.19 (bunny); 96.3%, 99.6%, 100% and 99.3% of pixels lit
// (Sponza's open sky is black). A pixel counts as lit above a twentieth of the darkest scene's mean
// luminance.
constexpr double kLitLuminance = 0.01;
// A quarter of the darkest mean, so that a black or nearly black frame fails while exposure and
// noise may move each scene's mean by a factor of three.
constexpr double kMinMeanLuminance = 0.05;
// A view from inside sees walls, floor and ceiling in nearly every pixel; a model seen from
// outside against the black background, or lit only around its light, covers far less.
constexpr double kMinCoverage = 0.75;

struct SeedScene {
  const char* name;
  size_t textures;  // the images the 3DS file's materials name
};

class SeedScenes : public ::testing::TestWithParam<SeedScene> {};

TEST_P(SeedScenes, RenderLitFromInside) {
  const SeedScene& seed = GetParam();
  const std::filesystem::path path =
      std::filesystem::path(CAUSTICA_SCENES_DIR) / seed.name / "scene.json";
  absl::StatusOr<Scene> scene = load_scene(path);
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_EQ(scene->textures.size(), seed.textures);
  ASSERT_EQ(scene->lights.size(), 1u);
  EXPECT_EQ(scene->lights[0].type, LightType::kPoint);
  for (const Material& m : scene->materials) {
    EXPECT_TRUE(is_black(m.radiance)) << m.name << " emits: the scene's light is its point light";
  }

  scene->camera.width = 64;
  scene->camera.height = 48;
  scene->settings.photons_per_pass = 20000;
  absl::StatusOr<std::unique_ptr<Engine>> engine = Engine::create({});
  ASSERT_TRUE(engine.ok()) << engine.status();
  ASSERT_TRUE((*engine)->load(*scene).ok());
  ASSERT_TRUE((*engine)->render(1).ok());
  const std::span<const float> rgba = (*engine)->image_linear();
  ASSERT_EQ(rgba.size(), 64u * 48u * 4u);
  double sum = 0;
  size_t lit = 0;
  for (size_t i = 0; i < rgba.size(); i += 4) {
    ASSERT_TRUE(std::isfinite(rgba[i]) && std::isfinite(rgba[i + 1]) && std::isfinite(rgba[i + 2]));
    const double luminance = 0.2126 * rgba[i] + 0.7152 * rgba[i + 1] + 0.0722 * rgba[i + 2];
    sum += luminance;
    lit += luminance > kLitLuminance ? 1 : 0;
  }
  const double mean = sum / (64 * 48);
  const double coverage = double(lit) / (64 * 48);
  std::printf("%s: mean luminance %.4f, %.1f%% of pixels lit\n", seed.name, mean, 100 * coverage);
  EXPECT_GT(mean, kMinMeanLuminance) << "black";
  EXPECT_GT(coverage, kMinCoverage) << "a silhouette: only part of the view is lit";
}

INSTANTIATE_TEST_SUITE_P(Bundled, SeedScenes,
                         ::testing::Values(SeedScene{"sponza", 15}, SeedScene{"sibenik", 3},
                                           SeedScene{"conference", 0}, SeedScene{"bunny", 0}),
                         [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace caustica
