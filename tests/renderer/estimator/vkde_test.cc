// VKDE (settings.estimator "vkde") against closed forms: a caustic from a flat mirror, whose
// light is that of the light's mirror image, and the interreflections inside a diffuse sphere.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <span>
#include <string>

#include "absl/strings/str_format.h"
#include "renderer/estimator/vkde_estimator.h"
#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

// A point light just above a flat mirror (reflectance 1) under a diffuse ceiling, the ceiling seen
// from below. With photon paths cut at two surfaces, the ceiling's radiance is its direct light
// plus the caustic of the light's mirror image: rho / pi I (cos / r^2 + cos' / r'^2).
struct CeilingOverMirror {
  float rho = 0.5f, intensity = 1.0f;
  Vec3f light{0.3f, -0.2f, 0.2f};
  int size = 48;

  Scene scene(const std::string& estimator) const {
    return parse_or_die(absl::StrFormat(R"({
      "camera": {"position": [0, 0, 0.5], "look_at": [0, 0, 2], "up": [0, 1, 0], "fov": 60,
                 "width": %d, "height": %d},
      "settings": {"photons": 200000, "k": 64, "max_photon_bounces": 2, "estimator": "%s"},
      "materials": {"mirror": {"type": "mirror", "reflectance": [1, 1, 1]},
                    "white": {"type": "diffuse", "albedo": [%f, %f, %f]}},
      "lights": [{"type": "point", "position": [%f, %f, %f], "intensity": [%f, %f, %f]}],
      "shapes": [
        {"type": "quad", "material": "mirror",
         "vertices": [[-6, -6, 0], [6, -6, 0], [6, 6, 0], [-6, 6, 0]]},
        {"type": "quad", "material": "white",
         "vertices": [[-6, -6, 2], [-6, 6, 2], [6, 6, 2], [6, -6, 2]]}]
    })",
                                        size, size, estimator, rho, rho, rho, light.x, light.y,
                                        light.z, intensity, intensity, intensity));
  }

  // rho / pi I cos / r^2 at ceiling point p from a light at `from`.
  double radiance_from(Vec3f from, Vec3f p) const {
    const Vec3f d = p - from;
    const double r2 = length_squared(d);
    return rho / kPi * intensity * (std::fabs(d.z) / std::sqrt(r2)) / r2;
  }

  // The image's mean against the closed form's, as a fraction of the caustic's mean: the
  // estimator's bias on the light it estimates. The image's borders, where the ceiling's edge
  // would matter, are left out.
  double caustic_error(std::span<const float> image, const Scene& s) const {
    const PinholeCamera cam = PinholeCamera::from(s.camera);
    const Vec3f image_light(light.x, light.y, -light.z);
    double got = 0, expected = 0, caustic = 0;
    for (int y = 2; y < size - 2; ++y) {
      for (int x = 2; x < size - 2; ++x) {
        const Ray r = cam.ray_through(x + 0.5f, y + 0.5f);
        const Vec3f p = r.origin + r.direction * ((2.0f - r.origin.z) / r.direction.z);
        got += image[4 * (y * size + x) + 1];
        caustic += radiance_from(image_light, p);
        expected += radiance_from(light, p) + radiance_from(image_light, p);
      }
    }
    return (got - expected) / caustic;
  }
};

class MirrorCaustic : public testing::TestWithParam<const char*> {};

TEST_P(MirrorCaustic, CeilingMatchesTheMirroredLight) {
  const CeilingOverMirror c;
  const Scene s = c.scene(GetParam());
  auto engine = engine_with(s);
  ASSERT_TRUE(engine->render(16).ok());
  const double error = c.caustic_error(engine->image_linear(), s);
  EXPECT_LT(std::fabs(error), 0.01);
  std::printf("%s, ceiling over a mirror: caustic off by %.3f%%\n", GetParam(), 100 * error);
}

INSTANTIATE_TEST_SUITE_P(Estimators, MirrorCaustic, testing::Values("knn", "sppm", "vkde"));

// Every interreflection comes from the global photons' kernels.
TEST(Vkde, InsideDiffuseSphereMatchesInterreflectionSeries) {
  const InsideDiffuseSphere sphere;
  auto engine = engine_with(sphere.scene(R"({"photons": 100000, "k": 64, "estimator": "vkde"})"));
  ASSERT_TRUE(engine->render(8).ok());
  const double mean = InsideDiffuseSphere::mean(engine->image_linear());
  const double error = std::fabs(mean - sphere.expected()) / sphere.expected();
  EXPECT_LT(error, 0.01) << "mean " << mean << " expected " << sphere.expected();
  std::printf("vkde inside diffuse sphere: relative error %.3f%%\n", 100 * error);
}

// The automatic spread makes each kernel about k / 2 footprints; a set spread is taken as given.
TEST(Vkde, SpreadAndDampeningFollowTheSettings) {
  EstimatorOptions options;
  options.k_nearest = 64;
  VkdeSettings s = vkde_settings(options, 2.0f);
  EXPECT_NEAR(s.spread * s.spread * kPi, 32.0f, 1e-3f);
  EXPECT_EQ(s.pivot, 2.0f);
  EXPECT_EQ(s.max_axis, 0.25f);
  options.vkde_spread = 7.0f;
  EXPECT_EQ(vkde_settings(options, 2.0f).spread, 7.0f);
}

}  // namespace
}  // namespace caustica
