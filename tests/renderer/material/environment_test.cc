// Environment light and its sampling: piecewise-constant distributions drawn as tabulated, a
// constant environment's irradiance equal to pi L, importance and uniform sampling agreeing on a
// sky with a sun, and the sampled directions distributed as pdf() says (chi-square).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "renderer/material/environment_map.h"
#include "tests/renderer/material/chi_square.h"

namespace caustica {
namespace {

TEST(PiecewiseConstant, DrawsEachPieceInProportionToItsValue) {
  const std::vector<float> f = {1.0f, 0.0f, 3.0f, 4.0f};
  std::vector<float> cdf(5);
  float integral = 0.0f;
  cumulative(f.data(), 4, cdf.data(), &integral);
  EXPECT_FLOAT_EQ(integral, 2.0f);  // the mean of the values
  EXPECT_FLOAT_EQ(cdf[1], 0.125f);
  EXPECT_FLOAT_EQ(cdf[2], 0.125f);
  EXPECT_FLOAT_EQ(cdf[3], 0.5f);
  const PiecewiseConstant1D d{f.data(), cdf.data(), 4, integral};
  std::vector<int> count(4);
  for (int i = 0; i < 80000; ++i) {
    float pdf;
    uint32_t piece;
    const float x = d.sample((i + 0.5f) / 80000, &pdf, &piece);
    ASSERT_EQ(piece, uint32_t(x * 4)) << x;
    ASSERT_FLOAT_EQ(pdf, f[piece] / 2.0f);
    ++count[piece];
  }
  // Stratified: the counts are the probabilities to within one sample.
  EXPECT_NEAR(count[0], 10000, 1);
  EXPECT_EQ(count[1], 0);
  EXPECT_NEAR(count[2], 30000, 1);
  EXPECT_NEAR(count[3], 40000, 1);
}

TEST(PiecewiseConstant, TwoDimensionalDensityIntegratesToOne) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> f(16 * 8);
  for (float& v : f) v = u(rng) < 0.2f ? 0.0f : u(rng);
  const PiecewiseConstant2DData data = build_piecewise_constant_2d(f, 16, 8);
  const PiecewiseConstant2D d = data.view();
  double total = 0.0;
  for (uint32_t y = 0; y < 8; ++y)
    for (uint32_t x = 0; x < 16; ++x) total += d.pdf({(x + 0.5f) / 16, (y + 0.5f) / 8}) / 128.0;
  EXPECT_NEAR(total, 1.0, 1e-5);
  for (int i = 0; i < 10000; ++i) {
    float pdf;
    const Vec2f p = d.sample(u(rng), u(rng), &pdf);
    ASSERT_GT(pdf, 0.0f);
    ASSERT_FLOAT_EQ(pdf, d.pdf(p));
  }
}

// An environment of its own image and distribution.
struct Environment {
  std::vector<Texel> texels;
  MipChain chain;
  PiecewiseConstant2DData distribution;
  EnvironmentMap map;
  Environment(uint32_t width, uint32_t height, std::vector<Texel> image, float rotation = 0.0f)
      : texels(std::move(image)),
        chain(build_mip_chain(width, height, texels)),
        distribution(environment_distribution(width, height, texels)) {
    map.image = {chain.texels.data(), chain.levels.data(), uint32_t(chain.levels.size()),
                 TextureWrap::kRepeat, TextureWrap::kClampToEdge};
    map.distribution = distribution.view();
    map.rotation = rotation;
  }
  // The map points into this object's own arrays.
  Environment(const Environment&) = delete;
  Environment& operator=(const Environment&) = delete;
};

// A 64 x 32 sky of 0.2 with a sun of `sun` in four texels about 40 degrees from the zenith.
std::vector<Texel> sky_with_sun_texels(float sun = 2000.0f) {
  std::vector<Texel> image(64 * 32, Texel{0.2f, 0.3f, 0.5f, 1.0f});
  for (uint32_t y = 6; y < 8; ++y)
    for (uint32_t x = 20; x < 22; ++x) image[y * 64 + x] = {sun, 0.95f * sun, 0.85f * sun, 1.0f};
  return image;
}
Environment sky_with_sun(float rotation = 0.0f) {
  return Environment(64, 32, sky_with_sun_texels(), rotation);
}

TEST(Environment, DirectionsAndCoordinatesAreInverse) {
  const Environment e = sky_with_sun(0.7f);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 1000; ++i) {
    const Vec2f uv{u(rng), 0.01f + 0.98f * u(rng)};
    const Vec2f back = e.map.uv_of(e.map.direction_of(uv));
    ASSERT_NEAR(std::fmod(back.x - uv.x + 1.5f, 1.0f) - 0.5f, 0.0f, 1e-5f);
    ASSERT_NEAR(back.y, uv.y, 1e-5f);
  }
  EXPECT_NEAR(e.map.direction_of({0.3f, 0.0f}).y, 1.0f, 1e-6f);  // row 0 is the zenith
}

// A constant environment L: the irradiance on any surface is pi L, by importance sampling and by
// uniform sampling of the sphere alike.
TEST(Environment, ConstantSkyGivesPiLIrradiance) {
  const Environment e(16, 8, std::vector<Texel>(16 * 8, Texel{1.5f, 1.5f, 1.5f, 1.0f}));
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (const Vec3f n : {Vec3f(0, 1, 0), normalize(Vec3f(1, 1, 0.5f)), Vec3f(0, -1, 0)}) {
    double importance = 0.0, uniform = 0.0;
    constexpr int kSamples = 200000;
    for (int i = 0; i < kSamples; ++i) {
      const EnvironmentSample s = e.map.sample(u(rng), u(rng));
      if (s.pdf > 0.0f) importance += s.radiance.y * max_f(0.0f, dot(n, s.direction)) / s.pdf;
      const Vec3f d = sample_uniform_sphere(u(rng), u(rng));
      uniform += e.map.radiance(d).y * max_f(0.0f, dot(n, d)) * 4.0 * kPiD;
    }
    EXPECT_NEAR(importance / kSamples, kPiD * 1.5, 0.01 * kPiD * 1.5);
    EXPECT_NEAR(uniform / kSamples, kPiD * 1.5, 0.01 * kPiD * 1.5);
  }
}

// With a sun, both estimators agree within their errors, and importance sampling's error is far
// smaller: it spends its samples on the sun.
TEST(Environment, ImportanceAndUniformSamplingAgree) {
  const Environment e = sky_with_sun(0.4f);
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const Vec3f n = normalize(Vec3f(0.3f, 1.0f, -0.2f));
  constexpr int kSamples = 400000;
  double is = 0.0, is2 = 0.0, un = 0.0, un2 = 0.0;
  for (int i = 0; i < kSamples; ++i) {
    const EnvironmentSample s = e.map.sample(u(rng), u(rng));
    const double a = s.pdf > 0.0f ? s.radiance.y * max_f(0.0f, dot(n, s.direction)) / s.pdf : 0.0;
    is += a;
    is2 += a * a;
    const Vec3f d = sample_uniform_sphere(u(rng), u(rng));
    const double b = e.map.radiance(d).y * max_f(0.0f, dot(n, d)) * 4.0 * kPiD;
    un += b;
    un2 += b * b;
  }
  const double is_mean = is / kSamples, un_mean = un / kSamples;
  const double is_error = std::sqrt((is2 / kSamples - is_mean * is_mean) / kSamples);
  const double un_error = std::sqrt((un2 / kSamples - un_mean * un_mean) / kSamples);
  EXPECT_NEAR(is_mean, un_mean, 4.0 * std::hypot(is_error, un_error));
  EXPECT_LT(is_error, 0.2 * un_error);
}

// The sampled directions against pdf(), over the sphere, as the scattering models are tested.
TEST(Environment, SamplesFollowThePdf) {
  struct Sampler {
    const EnvironmentMap* map;
    BsdfSample sample(Vec3f, float, float u0, float u1) const {
      const EnvironmentSample s = map->sample(u0, u1);
      BsdfSample out;
      out.wi = s.direction;
      out.pdf = s.pdf;
      return out;
    }
    float pdf(Vec3f, Vec3f wi) const { return map->pdf(wi); }
    uint32_t flags() const { return kBsdfTransmission; }  // the whole sphere
  };
  for (float rotation : {0.0f, 1.3f}) {
    // A milder sun, so that cells away from it expect enough samples to test.
    const Environment mild(64, 32, sky_with_sun_texels(20.0f), rotation);
    EXPECT_GT(chi_square_p_value(Sampler{&mild.map}, Vec3f(0, 0, 1), 400000, 9), 1e-4) << rotation;
  }
}

}  // namespace
}  // namespace caustica
