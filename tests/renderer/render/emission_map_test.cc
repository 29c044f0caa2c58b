// Emission on any surface, shaped by an emission map: what the camera sees of an emitting surface
// is its radiance times the map where its texture coordinates say, and the light a mapped lamp
// throws on a floor is the integral of what each point of it emits, computed here by brute force
// over the lamp, whether shadow rays aim at it (the photon integrator's direct light, the path
// tracer's next-event estimation) or paths happen upon it (the path tracer's other half of MIS).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "renderer/engine.h"
#include "renderer/render/camera.h"
#include "renderer/scene/load_scene.h"
#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

// A map of two texels, black then white, clamped at the edges: the bilinear lookup at u is
// clamp((u - 1/4) / (1/2), 0, 1) in every channel.
std::shared_ptr<DecodedImage> black_white() {
  auto image = std::make_shared<DecodedImage>();
  image->width = 2;
  image->height = 1;
  image->rgba8 = {0, 0, 0, 255, 255, 255, 255, 255};
  return image;
}
float black_white_at(float u) { return std::clamp((u - 0.25f) / 0.5f, 0.0f, 1.0f); }

TextureRef clamped(uint32_t texture) {
  TextureRef ref;
  ref.texture = texture;
  ref.wrap_u = ref.wrap_v = TextureWrap::kClampToEdge;
  return ref;
}

std::vector<float> render(const Scene& scene, uint32_t passes) {
  auto engine = engine_with(scene);
  const absl::StatusOr<PassReport> report = engine->render(passes);
  EXPECT_TRUE(report.ok()) << report.status();
  const std::span<const float> image = engine->image_linear();
  return std::vector<float>(image.begin(), image.end());
}

// PlaneUnderPointLight's square, diffuse, given an emission of 1 and, with `mapped`, the black and
// white map stretched over it: the image less the square's reflection alone is the map at each
// pixel's point. The square cannot light itself, so its reflection is the same either way.
void expect_emission_where_the_map_says(const std::string& settings) {
  SCOPED_TRACE(settings);
  const Scene plain = PlaneUnderPointLight{}.scene_with_uvs(settings);
  Scene emitting = plain;
  emitting.materials.at(0).radiance = Vec3f(1.0f);
  emitting.textures.push_back({"black-white", nullptr, black_white()});
  emitting.materials.at(0).emission_map = clamped(0);
  const std::vector<float> a = render(plain, 1), b = render(emitting, 1);
  ASSERT_EQ(a.size(), b.size());
  int dark = 0, bright = 0;
  const int checked =
      PlaneUnderPointLight::visit_square_pixels(plain, [&](size_t pixel, int x, int y, float u) {
        // The ray's jitter moves u by half a pixel, 1/128 of the square.
        const float share = black_white_at(u);
        for (int c = 0; c < 3; ++c) {
          EXPECT_NEAR(b[4 * pixel + c] - a[4 * pixel + c], share, 0.02f) << x << "," << y;
        }
        dark += share == 0.0f;
        bright += share == 1.0f;
      });
  EXPECT_GT(checked, 400);
  EXPECT_GT(dark, 100);
  EXPECT_GT(bright, 100);
}

TEST(EmissionMap, ShapesWhatThePhotonIntegratorsCameraSees) {
  expect_emission_where_the_map_says(R"({"photons": 2000})");
}

TEST(EmissionMap, ShapesWhatThePathTracerSees) {
  expect_emission_where_the_map_says(R"({"integrator": "path"})");
}

// A floor lit only by a square lamp above it, facing down, whose emission map is the black and
// white one along x: its two triangles emit different powers, which the lights' choice weighs.
struct FloorUnderMappedLamp {
  static constexpr float kRho = 0.5f, kRadiance = 3.0f, kHalf = 0.25f, kHeight = 0.6f;
  static constexpr int kSize = 40;

  Scene scene(const std::string& settings) const {
    Scene scene = parse_or_die(absl::StrFormat(
        R"({
      "camera": {"position": [0, -2.2, 2.2], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov": 50,
                 "width": %d, "height": %d},
      "settings": %s,
      "materials": {"floor": {"type": "diffuse", "albedo": [%f, %f, %f]},
                    "lamp": {"type": "emissive", "radiance": [%f, %f, %f]}},
      "shapes": [{"type": "quad", "material": "floor",
                  "vertices": [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]},
                 {"type": "quad", "material": "lamp",
                  "vertices": [[%f, %f, %f], [%f, %f, %f], [%f, %f, %f], [%f, %f, %f]]}]
    })",
        kSize, kSize, settings, kRho, kRho, kRho, kRadiance, kRadiance, kRadiance, -kHalf, -kHalf,
        kHeight, -kHalf, kHalf, kHeight, kHalf, kHalf, kHeight, kHalf, -kHalf, kHeight));
    Mesh& lamp = scene.meshes.at(1);
    lamp.uvs.clear();
    for (const Vec3f& p : lamp.positions)
      lamp.uvs.push_back({(p.x + kHalf) / (2 * kHalf), (p.y + kHalf) / (2 * kHalf)});
    scene.textures.push_back({"black-white", nullptr, black_white()});
    scene.materials.at(1).emission_map = clamped(0);
    return scene;
  }

  // The floor's radiance at p: rho / pi times the irradiance from the lamp, summed over a fine
  // grid of its points.
  static double expected(Vec3f p) {
    constexpr int kSteps = 160;
    const double cell = 2.0 * kHalf / kSteps;
    double irradiance = 0;
    for (int i = 0; i < kSteps; ++i) {
      for (int j = 0; j < kSteps; ++j) {
        const double x = -kHalf + (i + 0.5) * cell, y = -kHalf + (j + 0.5) * cell;
        const double dx = x - p.x, dy = y - p.y, dz = kHeight;
        const double r2 = dx * dx + dy * dy + dz * dz;
        const double cos2 = dz * dz / r2;  // the floor's cosine times the lamp's
        const float u = float((x + kHalf) / (2 * kHalf));
        irradiance += kRadiance * black_white_at(u) * cos2 / r2 * cell * cell;
      }
    }
    return kRho / kPi * irradiance;
  }

  // The rendered and the expected mean over the floor pixels the camera sees directly, on each
  // side of x = 0 (the lamp's dark and bright halves).
  struct Means {
    double got[2] = {0, 0}, want[2] = {0, 0};
    int count[2] = {0, 0};
  };
  Means measure(const std::string& settings, uint32_t passes) const {
    const Scene s = scene(settings);
    const std::vector<float> image = render(s, passes);
    const PinholeCamera camera = PinholeCamera::from(s.camera);
    Means m;
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        const Ray r = camera.ray_through(x + 0.5f, y + 0.5f);
        if (r.direction.z >= 0) continue;
        const Vec3f p = r.origin + r.direction * (-r.origin.z / r.direction.z);
        const Vec3f q = r.origin + r.direction * ((kHeight - r.origin.z) / r.direction.z);
        if (std::fabs(p.x) > 0.9f || std::fabs(p.y) > 0.9f) continue;
        // Not behind the lamp, nor at its edge, where the pixel sees both.
        if (std::fabs(q.x) < kHalf + 0.05f && std::fabs(q.y) < kHalf + 0.05f) continue;
        if (std::fabs(p.x) < 0.05f) continue;
        const int side = p.x > 0 ? 1 : 0;
        m.got[side] += image[4 * (size_t(y) * kSize + x)];
        m.want[side] += expected(p);
        ++m.count[side];
      }
    }
    return m;
  }
};

void expect_lamp_integral(const std::string& settings, uint32_t passes, double tolerance) {
  SCOPED_TRACE(settings);
  const FloorUnderMappedLamp::Means m = FloorUnderMappedLamp{}.measure(settings, passes);
  for (int side = 0; side < 2; ++side) {
    ASSERT_GT(m.count[side], 150) << side;
    EXPECT_NEAR(m.got[side] / m.want[side], 1.0, tolerance) << "side " << side;
  }
  // The map makes the bright side brighter: the test can tell a lamp that ignores it.
  EXPECT_GT(m.want[1] / m.count[1], 1.3 * m.want[0] / m.count[0]);
}

TEST(EmissionMap, ShadowRaysToAMappedLampIntegrateItsEmission) {
  expect_lamp_integral(R"({"photons": 1000, "area_light_samples": 8})", 32, 0.02);
}

TEST(EmissionMap, PathsAndShadowRaysToAMappedLampAgreeWithItsIntegral) {
  expect_lamp_integral(R"({"integrator": "path"})", 512, 0.02);
}

// The bundled DamagedHelmet's emissive factor is [1, 1, 1] with a texture that lights its lamps
// and screens: without other light, the helmet shows only those, where a factor taken for the
// whole surface would show a white silhouette. Its pixels are those a point light shows, without
// the sky.
TEST(EmissionMap, TheHelmetGlowsOnlyWhereItsEmissiveTextureDoes) {
  absl::StatusOr<Scene> scene =
      load_scene(std::filesystem::path(CAUSTICA_SCENES_DIR) / "damaged-helmet" / "scene.json");
  ASSERT_TRUE(scene.ok()) << scene.status();
  scene->camera.width = scene->camera.height = 64;
  scene->settings.photons_per_pass = 20000;
  scene->environment.present = false;
  scene->lights = {
      Light{"key", LightType::kPoint, Vec3f(2.5f, 2.5f, 3.0f), Vec3f(0, -1, 0), Vec3f(40.0f)},
      Light{"fill", LightType::kPoint, Vec3f(-3.0f, 0.5f, 1.5f), Vec3f(0, -1, 0), Vec3f(12.0f)}};
  const std::vector<float> lit = render(*scene, 1);
  scene->lights.clear();
  const std::vector<float> glow = render(*scene, 1);
  int helmet = 0, glowing = 0, white = 0;
  for (size_t pixel = 0; pixel < lit.size() / 4; ++pixel) {
    if (lit[4 * pixel] + lit[4 * pixel + 1] + lit[4 * pixel + 2] <= 0.0f) continue;
    ++helmet;
    const float brightest = std::max({glow[4 * pixel], glow[4 * pixel + 1], glow[4 * pixel + 2]});
    glowing += brightest > 0.25f;
    white += glow[4 * pixel] > 0.9f && glow[4 * pixel + 1] > 0.9f && glow[4 * pixel + 2] > 0.9f;
  }
  EXPECT_GT(helmet, 64 * 64 / 4);
  EXPECT_GT(glowing, helmet / 100);
  EXPECT_LT(glowing, helmet / 5);
  EXPECT_LT(white, helmet / 50);
}

// Every triangle of the helmet's material is an area light (its emission map decides where it
// glows): 46,000 lights that shadow rays reach by sampling, not one slot each. Final gathering's
// shadow rays, a slot per light and gather ray, once asked for 82 GB here; every shading point
// also looped over them all to find the two point lights.
TEST(EmissionMap, ManyAreaLightsCostNoShadowRaySlotsOfTheirOwn) {
  absl::StatusOr<Scene> scene =
      load_scene(std::string(CAUSTICA_SCENES_DIR) + "/damaged-helmet/scene.json");
  ASSERT_TRUE(scene.ok()) << scene.status();
  scene->camera.width = 96;
  scene->camera.height = 72;
  scene->settings.photons_per_pass = 50000;
  scene->settings.final_gather = true;
  scene->settings.final_gather_rays = 64;
  auto engine = Engine::create({.memory_budget_bytes = size_t{1} << 30});
  ASSERT_TRUE(engine.ok()) << engine.status();
  ASSERT_TRUE((*engine)->load(*scene).ok());
  const absl::StatusOr<PassReport> rendered = (*engine)->render(2);
  EXPECT_TRUE(rendered.ok()) << rendered.status();
}

}  // namespace
}  // namespace caustica
