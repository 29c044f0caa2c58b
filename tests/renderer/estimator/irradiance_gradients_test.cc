// A seed's irradiance and its gradients (estimator/irradiance_gradients.h) against a case with a
// closed form: a point on a dark floor facing a wall of height H at distance d that glows with
// radiance L. The wall's cross-section spans the floor's horizon up to the angle whose sine is
// d / sqrt(d^2 + H^2) from the zenith, so E = pi L (1 - d / sqrt(d^2 + H^2)) / 2 (the form factor
// of an infinite strip), and E grows towards the wall at pi L H^2 / (2 (d^2 + H^2)^(3/2)).
#include "renderer/estimator/irradiance_gradients.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

namespace caustica {
namespace {

constexpr float kHeight = 1.0f;
const Vec3f kWallRadiance(1.0f, 0.5f, 0.25f);

double wall_irradiance(double d) {
  return kPi * (1.0 - d / std::sqrt(d * d + kHeight * kHeight)) / 2.0;
}
double wall_gradient(double d) {
  return kPi * kHeight * kHeight / (2.0 * std::pow(d * d + kHeight * kHeight, 1.5));
}

// The wall at x = d, z in [0, H], all y; nothing else but the black floor below the horizon.
struct WallRays {
  std::vector<Vec3f> radiance;
  std::vector<float> distance;
};

// side x side stratified cosine rays from the origin with normal +z, laid out as the gather rays
// are (cell j of sin^2(theta), k of phi for ray j + k * side), each traced against the wall.
WallRays trace_wall(uint32_t side, float d) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const Frame frame = Frame::from_normal(Vec3f(0, 0, 1));
  WallRays out;
  for (uint32_t r = 0; r < side * side; ++r) {
    const float u1 = (float(r % side) + u(rng)) / float(side);
    const float u2 = (float(r / side) + u(rng)) / float(side);
    const Vec3f w = frame.to_world(sample_cosine_hemisphere(u1, u2));
    const float t = w.x > 0.0f ? d / w.x : INFINITY;
    const bool hits = t < INFINITY && t * w.z <= kHeight;
    out.radiance.push_back(hits ? kWallRadiance : Vec3f(0.0f));
    out.distance.push_back(hits ? t : INFINITY);
  }
  return out;
}

SeedRecord wall_record(const WallRays& rays, uint32_t side, float nearest = 1e-3f) {
  return seed_record(
      side * side, side, Vec3f(0, 0, 1), nearest, 100.0f,
      [&](uint32_t r) { return rays.radiance[r]; }, [&](uint32_t r) { return rays.distance[r]; });
}

// The rotational gradient's closed form is not as short; this is it by brute force: the integral
// of L (n x w) over the wall's directions, n = +z.
Vec3f wall_rotation_brute_force(float d) {
  const int steps = 2000;
  double y = 0.0;
  for (int i = 0; i < steps; ++i)
    for (int j = 0; j < steps; ++j) {
      const double theta = (i + 0.5) / steps * (kPi / 2), phi = (j + 0.5) / steps * 2 * kPi;
      const double wx = std::sin(theta) * std::cos(phi), wz = std::cos(theta);
      if (wx <= 0.0 || (d / wx) * wz > kHeight) continue;
      y += wx * std::sin(theta) * (kPi / 2 / steps) * (2 * kPi / steps);  // (n x w).y = w.x
    }
  return Vec3f(0.0f, float(y), 0.0f);
}

TEST(IrradianceGradients, MatchTheGlowingWall) {
  for (float d : {0.5f, 1.0f, 2.0f}) {
    const uint32_t side = 64;
    const SeedRecord rec = wall_record(trace_wall(side, d), side);
    const Vec3f rotation = wall_rotation_brute_force(d);
    for (int c = 0; c < 3; ++c) {
      const double l = kWallRadiance[c];
      EXPECT_NEAR(rec.irradiance[c], l * wall_irradiance(d), 0.03 * l * wall_irradiance(d))
          << "d " << d << " channel " << c;
      EXPECT_NEAR(rec.translation[0][c], l * wall_gradient(d), 0.1 * l * wall_gradient(d))
          << "d " << d << " channel " << c;
      EXPECT_NEAR(rec.translation[1][c], 0.0, 0.02 * l * wall_gradient(d)) << "d " << d;
      EXPECT_EQ(rec.translation[2][c], 0.0f);
      EXPECT_NEAR(rec.rotation[1][c], l * rotation.y, 0.03 * l * rotation.y) << "d " << d;
      EXPECT_NEAR(rec.rotation[0][c], 0.0, 0.04 * l * rotation.y) << "d " << d;
      EXPECT_EQ(rec.rotation[2][c], 0.0f);
    }
    std::printf(
        "wall at %.1f: E %.4f (exact %.4f), dE/dx %.4f (exact %.4f), rotation %.4f (%.4f)\n", d,
        rec.irradiance.x, wall_irradiance(d), rec.translation[0].x, wall_gradient(d),
        rec.rotation[1].x, rotation.y);
  }
}

// Carried a step towards the wall, the gradients' first-order irradiance is closer to the exact
// one than the seed's own; turned a little towards the wall, likewise. R never reaches past where
// the translation would take the irradiance to zero.
TEST(IrradianceGradients, CarryTheIrradianceBetterThanTheSeedAlone) {
  const uint32_t side = 32;
  const float d = 1.0f, step = 0.1f;
  const SeedRecord rec = wall_record(trace_wall(side, d), side);
  const double moved = wall_irradiance(d - step);
  const Vec3f carried =
      extrapolated(rec, Vec3f(0.0f), Vec3f(0, 0, 1), Vec3f(step, 0, 0), Vec3f(0, 0, 1));
  EXPECT_LT(std::fabs(carried.x - moved), 0.25 * std::fabs(rec.irradiance.x - moved));

  // Turned by a small angle a about y towards the wall, by brute force.
  const double a = 0.05;
  const Vec3f turned(float(std::sin(a)), 0.0f, float(std::cos(a)));
  double exact = 0.0;
  const int steps = 2000;
  for (int i = 0; i < steps; ++i)
    for (int j = 0; j < steps; ++j) {
      const double theta = (i + 0.5) / steps * (kPi / 2), phi = (j + 0.5) / steps * 2 * kPi;
      const double wx = std::sin(theta) * std::cos(phi), wy = std::sin(theta) * std::sin(phi),
                   wz = std::cos(theta);
      if (wx <= 0.0 || (d / wx) * wz > kHeight) continue;
      const double cosine = wx * turned.x + wy * turned.y + wz * turned.z;
      if (cosine > 0.0) exact += cosine * std::sin(theta) * (kPi / 2 / steps) * (2 * kPi / steps);
    }
  const Vec3f rotated = extrapolated(rec, Vec3f(0.0f), Vec3f(0, 0, 1), Vec3f(0.0f), turned);
  EXPECT_LT(std::fabs(rotated.x - exact), 0.25 * std::fabs(rec.irradiance.x - exact));

  for (int c = 0; c < 3; ++c)
    EXPECT_LE(rec.radius, rec.irradiance[c] / rec.translation[0][c] * 1.0001f);
}

// A ray that hits something much nearer than the nearest R allowed, as where a seed sits in a
// crack, makes its gradient no steeper than a hit at that R would; and no point is carried
// farther than R.
TEST(IrradianceGradients, StayBoundedNearHitsAndBeyondR) {
  const uint32_t side = 16;
  const float nearest = 1e-3f;
  WallRays rays = trace_wall(side, 1.0f);
  rays.radiance[3 + 5 * side] = Vec3f(100.0f);
  auto steepness = [&](float d) {
    rays.distance[3 + 5 * side] = d;
    const SeedRecord rec = wall_record(rays, side, nearest);
    return length(Vec3f(rec.translation[0].x, rec.translation[1].x, rec.translation[2].x));
  };
  const float at_nearest = steepness(nearest);
  EXPECT_GT(at_nearest, 1000.0f);  // the hit at R dominates the gradient
  EXPECT_LT(steepness(1e-7f), 1.01f * at_nearest);

  const SeedRecord rec = wall_record(trace_wall(side, 1.0f), side);
  const Vec3f towards(0.6f, 0.8f, 0.0f);
  const Vec3f at_r =
      extrapolated(rec, Vec3f(0.0f), Vec3f(0, 0, 1), towards * rec.radius, Vec3f(0, 0, 1));
  const Vec3f far =
      extrapolated(rec, Vec3f(0.0f), Vec3f(0, 0, 1), towards * (10 * rec.radius), Vec3f(0, 0, 1));
  EXPECT_NEAR(far.x, at_r.x, 1e-5f);
  EXPECT_NE(at_r.x, rec.irradiance.x);
}

TEST(IrradianceGradients, NoneWithoutAGrid) {
  const WallRays rays = trace_wall(8, 1.0f);
  const SeedRecord rec = seed_record(
      60, 0, Vec3f(0, 0, 1), 1e-3f, 100.0f, [&](uint32_t r) { return rays.radiance[r]; },
      [&](uint32_t r) { return rays.distance[r]; });
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(rec.translation[a], Vec3f(0.0f));
    EXPECT_EQ(rec.rotation[a], Vec3f(0.0f));
  }
  EXPECT_GT(rec.irradiance.x, 0.0f);
}

}  // namespace
}  // namespace caustica
