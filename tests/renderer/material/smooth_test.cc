// The first material kinds as models of the seam: a Lambertian surface against the chi-square
// test and its albedo, the mirror's single direction, and the smooth dielectric's Fresnel split,
// Snell's law, total internal reflection and the index ratio's factor on radiance.
#include "renderer/material/smooth.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tests/renderer/material/chi_square.h"

namespace caustica {
namespace {

TEST(Lambertian, SamplesFollowThePdfAndWeighItsColour) {
  const LambertianBsdf white{Vec3f(0.7f, 0.5f, 0.2f)};
  EXPECT_GT(chi_square_p_value(white, direction_at(30.0), 400000, 21), 1e-4);
  std::mt19937 rng(22);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 10000; ++i) {
    const BsdfSample s = white.sample(direction_at(60.0), u(rng), u(rng), u(rng));
    if (!s.valid()) continue;
    ASSERT_NEAR(s.weight().x, 0.7f, 1e-5f);
    ASSERT_NEAR(s.weight().z, 0.2f, 1e-5f);
  }
}

TEST(Mirror, ReflectsIntoTheMirrorDirectionWithItsColour) {
  const MirrorBsdf mirror{Vec3f(0.9f, 0.8f, 0.7f)};
  const Vec3f wo = direction_at(40.0, 1.1);
  const BsdfSample s = mirror.sample(wo, 0.5f, 0.5f, 0.5f);
  ASSERT_TRUE(s.valid());
  EXPECT_FLOAT_EQ(s.wi.x, -wo.x);
  EXPECT_FLOAT_EQ(s.wi.y, -wo.y);
  EXPECT_FLOAT_EQ(s.wi.z, wo.z);
  EXPECT_NEAR(s.weight().y, 0.8f, 1e-6f);
  EXPECT_EQ(s.flags, uint32_t(kBsdfReflection | kBsdfSpecular));
  EXPECT_EQ(mirror.pdf(wo, s.wi), 0.0f);  // a delta lobe has no density to evaluate
}

// At normal incidence glass of index 1.5 reflects ((1.5 - 1) / (1.5 + 1))^2 = 0.04 of the light.
TEST(SmoothDielectric, ReflectsTheFresnelShareAtNormalIncidence) {
  const SmoothDielectricBsdf glass{1.5f, Transport::kImportance};
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  constexpr int kSamples = 200000;
  int reflected = 0;
  for (int i = 0; i < kSamples; ++i) {
    const BsdfSample s = glass.sample(direction_at(0.0), u(rng), 0.5f, 0.5f);
    ASSERT_TRUE(s.valid());
    ASSERT_NEAR(s.weight().x, 1.0f, 1e-5f);  // importance: every path keeps its weight
    reflected += s.wi.z > 0.0f;
  }
  EXPECT_NEAR(double(reflected) / kSamples, 0.04, 0.0025);
}

TEST(SmoothDielectric, RefractsBySnellsLawAndScalesRadianceByTheIndexRatio) {
  const SmoothDielectricBsdf radiance{1.5f, Transport::kRadiance};
  const Vec3f wo = direction_at(50.0, 0.4);
  // uc = 0.999: past any reflectance below 1, so the sample refracts.
  const BsdfSample s = radiance.sample(wo, 0.999f, 0.5f, 0.5f);
  ASSERT_TRUE(s.valid());
  ASSERT_LT(s.wi.z, 0.0f);
  const double sin_i = std::sin(50.0 * kPiD / 180.0);
  const double sin_t = std::sqrt(double(s.wi.x) * s.wi.x + double(s.wi.y) * s.wi.y);
  EXPECT_NEAR(sin_t, sin_i / 1.5, 1e-5);
  EXPECT_NEAR(s.wi.x * wo.y - s.wi.y * wo.x, 0.0f, 1e-6f);  // in the plane of incidence
  EXPECT_LT(s.wi.x * wo.x + s.wi.y * wo.y, 0.0f);           // on the far side of the normal
  EXPECT_NEAR(s.weight().x, 1.0f / (1.5f * 1.5f), 1e-5f);   // radiance compressed entering
  // From inside along the refracted ray, out along the incident one: radiance grows back by the
  // same factor.
  const BsdfSample back = radiance.sample(s.wi, 0.999f, 0.5f, 0.5f);
  ASSERT_TRUE(back.valid());
  EXPECT_NEAR(back.wi.x, wo.x, 1e-5f);
  EXPECT_NEAR(back.wi.z, wo.z, 1e-5f);
  EXPECT_NEAR(back.weight().x, 1.5f * 1.5f, 1e-4f);
}

// Inside glass of index 1.5, beyond the critical angle asin(1 / 1.5) = 41.8 degrees, all the light
// is reflected.
TEST(SmoothDielectric, ReflectsTotallyBeyondTheCriticalAngle) {
  const SmoothDielectricBsdf glass{1.5f, Transport::kRadiance};
  for (float uc : {0.0f, 0.5f, 0.999f}) {
    const BsdfSample s = glass.sample(direction_at(180.0 - 45.0), uc, 0.5f, 0.5f);
    ASSERT_TRUE(s.valid());
    EXPECT_LT(s.wi.z, 0.0f);
    EXPECT_NEAR(s.weight().x, 1.0f, 1e-6f);
  }
  const BsdfSample within = glass.sample(direction_at(180.0 - 40.0), 0.999f, 0.5f, 0.5f);
  ASSERT_TRUE(within.valid());
  EXPECT_GT(within.wi.z, 0.0f);  // 40 degrees: still refracted out
}

}  // namespace
}  // namespace caustica
