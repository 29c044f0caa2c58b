// Area lights changed after load (Engine::set_lights with emitter changes): the image follows the
// radiance linearly, off darkens exactly what the emitter lit, on restores the first image, a
// scene loaded with the emitter off matches one switched off, and refusals change nothing.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <vector>

#include "renderer/engine.h"
#include "renderer/scene/load_scene.h"
#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

Scene small_cornell_box() {
  absl::StatusOr<Scene> scene =
      load_scene(std::filesystem::path(CAUSTICA_SCENES_DIR) / "cornell-box" / "scene.json");
  EXPECT_TRUE(scene.ok()) << scene.status();
  scene->camera.width = scene->camera.height = 16;
  scene->settings.photons_per_pass = 3000;
  return *scene;
}

std::vector<float> render_image(Engine& engine, uint32_t passes) {
  EXPECT_TRUE(engine.render(passes).ok());
  const std::span<const float> image = engine.image_linear();
  return {image.begin(), image.end()};
}

const Material& material_named(const Engine& engine, const std::string& name) {
  for (const Material& m : engine.scene().materials)
    if (m.name == name) return m;
  ADD_FAILURE() << "no material " << name;
  return engine.scene().materials.front();
}

TEST(Emitters, RadianceScalesTheImageLinearly) {
  const Scene scene = small_cornell_box();
  auto engine = engine_with(scene);
  const std::vector<float> before = render_image(*engine, 2);
  const uint64_t epoch = engine->epochs().lights;
  auto report = engine->set_lights({}, {{"light", Vec3f(34, 24, 8), std::nullopt}});
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_EQ(engine->epochs().lights, epoch + 1);
  EXPECT_EQ(material_named(*engine, "light").radiance, Vec3f(34, 24, 8));
  const std::vector<float> doubled = render_image(*engine, 2);
  ASSERT_EQ(doubled.size(), before.size());
  double lit = 0;
  for (size_t i = 0; i < before.size(); ++i) {
    if (i % 4 == 3) continue;
    // The only light doubled: every photon's power and every emitted radiance doubles, and the
    // random choices do not depend on power.
    EXPECT_NEAR(doubled[i], 2 * before[i], 1e-4 * std::abs(before[i]) + 1e-7) << "value " << i;
    lit += before[i];
  }
  EXPECT_GT(lit, 0);
}

TEST(Emitters, OffDarkensAndOnRestoresTheFirstImage) {
  const Scene scene = small_cornell_box();
  auto engine = engine_with(scene);
  const std::vector<float> first = render_image(*engine, 2);
  ASSERT_TRUE(engine->set_lights({}, {{"light", std::nullopt, true}}).ok());
  EXPECT_TRUE(material_named(*engine, "light").off);
  EXPECT_EQ(material_named(*engine, "light").radiance, Vec3f(17, 12, 4));  // kept for later
  const std::vector<float> dark = render_image(*engine, 2);
  for (size_t i = 0; i < dark.size(); ++i) {
    if (i % 4 != 3) {
      ASSERT_EQ(dark[i], 0.0f) << "value " << i;
    }
  }
  ASSERT_TRUE(engine->set_lights({}, {{"light", std::nullopt, false}}).ok());
  EXPECT_EQ(render_image(*engine, 2), first);
}

// With a point light as well, switching the emitter off leaves the point light's image, the same
// as a scene loaded with the emitter already off.
TEST(Emitters, SwitchedOffMatchesLoadedOff) {
  Scene scene = small_cornell_box();
  scene.lights = {Light{"key", LightType::kPoint, Vec3f(278, 400, 279), Vec3f(0, -1, 0),
                        Vec3f(1e5f, 1e5f, 1e5f)}};
  auto switched = engine_with(scene);
  ASSERT_TRUE(switched->render(1).ok());
  ASSERT_TRUE(switched->set_lights(scene.lights, {{"light", std::nullopt, true}}).ok());
  const std::vector<float> a = render_image(*switched, 2);

  for (Material& m : scene.materials)
    if (m.name == "light") m.off = true;
  auto loaded = engine_with(scene);
  const std::vector<float> b = render_image(*loaded, 2);
  EXPECT_EQ(a, b);
  double lit = 0;
  for (float v : a) lit += v;
  EXPECT_GT(lit, 0);
}

TEST(Emitters, RefusalsNameTheEmitterAndChangeNothing) {
  const Scene scene = small_cornell_box();
  auto engine = engine_with(scene);
  const uint64_t epoch = engine->epochs().lights;
  auto unknown = engine->set_lights({}, {{"lamp", Vec3f(1, 1, 1), std::nullopt}});
  EXPECT_EQ(unknown.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(unknown.status().message()),
              testing::HasSubstr("emitters[0].material: the scene has no material 'lamp'"));
  auto diffuse = engine->set_lights(
      {}, {{"light", Vec3f(1, 1, 1), std::nullopt}, {"white", Vec3f(1, 1, 1), std::nullopt}});
  EXPECT_THAT(std::string(diffuse.status().message()),
              testing::HasSubstr("emitters[1].material: 'white' is diffuse and emits nothing"));
  auto negative = engine->set_lights({}, {{"light", Vec3f(1, -1, 1), std::nullopt}});
  EXPECT_THAT(std::string(negative.status().message()), testing::HasSubstr("emitters[0].radiance"));
  EXPECT_EQ(engine->epochs().lights, epoch);
  EXPECT_EQ(material_named(*engine, "light").radiance, Vec3f(17, 12, 4));
  EXPECT_FALSE(material_named(*engine, "light").off);
}

// A diffuse wall given an emission is a light that still reflects: the box lit by its lamp and the
// glowing back wall is the box lit by the lamp plus, over every pixel, the image of the glowing
// wall alone; its emission changes and switches off as the lamp's, and a black radiance, which
// would leave it no light, is refused.
TEST(Emitters, ADiffuseSurfaceMayEmitAndStillReflect) {
  Scene lamp_only = small_cornell_box();
  lamp_only.settings.integrator = Integrator::kPath;
  Scene both = lamp_only;
  const std::string wall = "white";
  for (Material& m : both.materials)
    if (m.name == wall) m.radiance = Vec3f(0.5f, 0.4f, 0.3f);
  auto engine = engine_with(both);
  const std::vector<float> lit = render_image(*engine, 4);
  double total = 0, lamp_total = 0;
  const std::vector<float> lamp = render_image(*engine_with(lamp_only), 4);
  for (size_t i = 0; i < lit.size(); ++i) {
    if (i % 4 == 3) continue;
    total += lit[i];
    lamp_total += lamp[i];
  }
  // The white walls' glow reaches most pixels, directly or reflected.
  EXPECT_GT(total, 1.1 * lamp_total);
  // Off, the wall is a light of no power: the lamp's image, up to the rounding of the longer
  // table the lights are chosen from.
  ASSERT_TRUE(engine->set_lights({}, {{wall, std::nullopt, true}}).ok());
  const std::vector<float> off = render_image(*engine, 4);
  ASSERT_EQ(off.size(), lamp.size());
  for (size_t i = 0; i < off.size(); ++i)
    EXPECT_NEAR(off[i], lamp[i], 1e-4 * std::abs(lamp[i]) + 1e-6) << "value " << i;
  auto black = engine->set_lights({}, {{wall, Vec3f(0, 0, 0), std::nullopt}});
  EXPECT_EQ(black.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(black.status().message()),
              testing::HasSubstr("emitters[0].radiance: (0, 0, 0) would make diffuse material "
                                 "'white' no light; turn it off instead"));
}

}  // namespace
}  // namespace caustica
