// Cut-outs and stochastic transparency in every integrator, per ray and in batches (dacrt answers
// batches only): a black sheet between the camera, a plane and a point light, cut away on one half
// by a mask, against rho / pi I cos / r^2 where the camera and the light both see the plane
// through the cut and 0 elsewhere; a blended sheet of opacity 1/2 lets a quarter of it through
// on average; and a sheet cut out everywhere changes no photon and no pixel of the Cornell box.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

const char* const kIntegrators[] = {
    R"({"photons": 20000})", R"({"photons": 20000, "structure": "dacrt"})",
    R"({"estimator": "sppm", "photons": 20000})",
    R"({"estimator": "sppm", "photons": 20000, "structure": "dacrt"})",
    R"({"integrator": "path"})"};

constexpr float kSheetHeight = 0.5f;

// PlaneUnderPointLight's scene with a black sheet over [-2, 2]^2 at kSheetHeight, between the
// camera (which it fills) and the plane, and between the plane and the light; its texture
// coordinates run u along x from 0 at x = -2 and v down y.
Scene with_black_sheet(const PlaneUnderPointLight& plane, const std::string& settings) {
  Scene scene = plane.scene_with_uvs(settings);
  Material black;
  black.name = "black sheet";
  black.color = Vec3f(0.0f);
  scene.materials.push_back(black);
  Mesh sheet;
  const float h = kSheetHeight;
  sheet.positions = {{-2, -2, h}, {2, -2, h}, {2, 2, h}, {-2, 2, h}};
  sheet.indices = {0, 1, 2, 0, 2, 3};
  for (const Vec3f& p : sheet.positions)
    sheet.uvs.push_back({0.25f * (p.x + 2), 0.25f * (2 - p.y)});
  sheet.material_ids.assign(2, uint32_t(scene.materials.size() - 1));
  scene.meshes.push_back(sheet);
  return scene;
}

// Where the segment from `a` to `b` crosses z = kSheetHeight.
Vec3f at_sheet(Vec3f a, Vec3f b) { return a + (b - a) * ((kSheetHeight - a.z) / (b.z - a.z)); }

// The sheet's left half (x < 0) cut out by a map of two texels, alpha 0 then 1, read bilinearly:
// alpha crosses the cutoff 1/2 at x = 0. Where the camera's ray meets the sheet's right half, or
// the plane's point sees the light through it, the pixel is black.
TEST(Cutouts, AMaskCutsTheSheetWhereItsAlphaFallsBelowTheCutoffForCameraAndShadowRays) {
  for (const char* settings : kIntegrators) {
    SCOPED_TRACE(settings);
    PlaneUnderPointLight plane;
    plane.size = 64;
    Scene scene = with_black_sheet(plane, settings);
    auto image = std::make_shared<DecodedImage>();
    image->width = 2;
    image->height = 1;
    image->rgba8 = {255, 255, 255, 0, 255, 255, 255, 255};
    image->has_alpha = true;
    scene.textures.push_back({"left-half-clear", nullptr, image});
    Material& sheet = scene.materials.back();
    sheet.alpha_mode = AlphaMode::kMask;
    sheet.opacity_map.texture = 0;
    sheet.opacity_map.wrap_u = sheet.opacity_map.wrap_v = TextureWrap::kClampToEdge;
    auto engine = engine_with(scene);
    ASSERT_TRUE(engine->render(8).ok());
    const std::span<const float> rendered = engine->image_linear();
    const PinholeCamera cam = PinholeCamera::from(scene.camera);
    int lit = 0, dark = 0;
    double worst = 0, darkest_sum = 0;
    const int checked =
        PlaneUnderPointLight::visit_square_pixels(scene, [&](size_t pixel, int x, int y, float) {
          Vec3f p;
          ASSERT_TRUE(plane_point(cam, x, y, p));
          const Vec3f seen_at = at_sheet(cam.ray_through(x + 0.5f, y + 0.5f).origin, p);
          const Vec3f shadow_at = at_sheet(p, plane.light);
          // Away from the cut's edge, where a pixel's footprint straddles it.
          if (std::fabs(seen_at.x) < 0.05f || std::fabs(shadow_at.x) < 0.05f) return;
          const double got = rendered[4 * pixel];
          if (seen_at.x > 0.0f || shadow_at.x > 0.0f) {
            ++dark;
            darkest_sum += got;
            return;
          }
          const Vec3f to_light = plane.light - p;
          const float dist2 = length_squared(to_light);
          const double expected =
              plane.rho / kPi * plane.intensity * (to_light.z / std::sqrt(dist2)) / dist2;
          worst = std::max(worst, std::fabs(got - expected) / expected);
          ++lit;
        });
    std::printf("mask, %s: %d pixels, %d lit (worst %.2f%%), %d dark (mean %.2e)\n", settings,
                checked, lit, 100 * worst, dark, dark > 0 ? darkest_sum / dark : 0.0);
    ASSERT_GT(lit, 40);
    ASSERT_GT(dark, 40);
    EXPECT_LT(worst, 0.05);
    EXPECT_LT(darkest_sum / dark, 1e-4);
  }
}

// A blended sheet of opacity 1/2 lets half the camera's rays through to the plane and half the
// plane's shadow rays through to the light: a quarter of the unshadowed radiance on average.
TEST(Cutouts, ABlendOfOpacityAHalfPassesHalfOfTheCameraAndHalfOfTheShadowRays) {
  for (const char* settings : kIntegrators) {
    SCOPED_TRACE(settings);
    PlaneUnderPointLight plane;
    plane.size = 48;
    Scene scene = with_black_sheet(plane, settings);
    Material& sheet = scene.materials.back();
    sheet.alpha_mode = AlphaMode::kBlend;
    sheet.opacity = 0.5f;
    auto engine = engine_with(scene);
    ASSERT_TRUE(engine->render(64).ok());
    const std::span<const float> rendered = engine->image_linear();
    const PinholeCamera cam = PinholeCamera::from(scene.camera);
    double sum = 0, expected_sum = 0;
    const int checked =
        PlaneUnderPointLight::visit_square_pixels(scene, [&](size_t pixel, int x, int y, float) {
          Vec3f p;
          ASSERT_TRUE(plane_point(cam, x, y, p));
          const Vec3f to_light = plane.light - p;
          const float dist2 = length_squared(to_light);
          expected_sum +=
              plane.rho / kPi * plane.intensity * (to_light.z / std::sqrt(dist2)) / dist2 * 0.25;
          sum += rendered[4 * pixel];
        });
    std::printf("blend 1/2, %s: %d pixels, mean %.4f of a quarter\n", settings, checked,
                sum / expected_sum);
    ASSERT_GT(checked, 100);
    EXPECT_NEAR(sum / expected_sum, 1.0, 0.03);
  }
}

// A white sheet across the Cornell box, cut out everywhere (a mask of opacity 0, and a blend of
// opacity 0), stops no camera ray, shadow ray or photon and draws no sample: the image is the
// box's without it.
TEST(Cutouts, ASheetCutOutEverywhereChangesNoPixelOfTheCornellBox) {
  for (const char* settings : kIntegrators) {
    SCOPED_TRACE(settings);
    absl::StatusOr<Scene> box =
        load_scene(std::string(CAUSTICA_SCENES_DIR) + "/cornell-box/scene.json");
    ASSERT_TRUE(box.ok()) << box.status();
    Scene plain = *box;
    plain.camera.width = 48;
    plain.camera.height = 48;
    const Scene parsed = parse_or_die(absl::StrFormat(
        R"({"camera": {"position": [0, 0, 1], "look_at": [0, 0, 0], "fov": 30, "width": 8,
                       "height": 8},
            "settings": %s,
            "materials": {"m": {"type": "diffuse", "albedo": [1, 1, 1]}},
            "lights": [{"type": "point", "position": [0, 0, 1], "intensity": [1, 1, 1]}],
            "shapes": [{"type": "quad", "material": "m",
                        "vertices": [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]}]})",
        settings));
    plain.settings = parsed.settings;
    for (const AlphaMode mode : {AlphaMode::kMask, AlphaMode::kBlend}) {
      Scene cut = plain;
      Material sheet;
      sheet.name = "cut-out sheet";
      sheet.color = Vec3f(0.9f);
      sheet.alpha_mode = mode;
      sheet.opacity = 0.0f;
      cut.materials.push_back(sheet);
      Mesh across;
      across.positions = {{0, 300, 0}, {556, 300, 0}, {556, 300, 559.2f}, {0, 300, 559.2f}};
      across.indices = {0, 1, 2, 0, 2, 3};
      across.material_ids.assign(2, uint32_t(cut.materials.size() - 1));
      cut.meshes.push_back(across);
      auto a = engine_with(plain), b = engine_with(cut);
      ASSERT_TRUE(a->render(2).ok());
      ASSERT_TRUE(b->render(2).ok());
      const std::span<const float> x = a->image_linear(), y = b->image_linear();
      ASSERT_EQ(x.size(), y.size());
      double worst = 0, total = 0;
      for (size_t i = 0; i < x.size(); ++i) {
        worst = std::max(worst, double(std::fabs(y[i] - x[i])));
        total += x[i];
      }
      EXPECT_GT(total, 0.0);
      // The structure differs by two triangles; each hit is the same triangle at the same place.
      EXPECT_LT(worst, 1e-4 * total / double(x.size()))
          << (mode == AlphaMode::kMask ? "mask" : "blend");
    }
  }
}

}  // namespace
}  // namespace caustica
