// The variable kernels of photon/vkde_kernel.h against the ellipsoid they stand for.
#include "renderer/photon/vkde_kernel.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace caustica {
namespace {

// A footprint in the plane z = 0 (normal +z), skewed, with spacing 1 so that dampening maps the
// longer span's length l to l^(1/4).
struct SkewedFootprint {
  Photon photon{Vec3f(0.5f, -0.25f, 2.0f), Vec3f(3.0f, 2.0f, 1.0f), Vec3f(0, 0, 1)};
  PhotonFootprint footprint{Vec3f(16.0f, 0.0f, 0.0f), Vec3f(3.0f, 4.0f, 0.0f)};
  Vec3f normal{0, 0, 1};
};

TEST(VkdeKernel, AxesFollowTheFootprintDampenedSpreadAndClamped) {
  const SkewedFootprint f;
  VkdeKernel k;
  ASSERT_TRUE(vkde_kernel(f.photon, f.footprint, f.normal, 1.0f, {2.0f, INFINITY, 0.05f}, k));
  // Longer span 16 -> 16^(1/4) = 2, the factor 1/8 applied to both, then the spread 2.
  EXPECT_NEAR(length(k.major), 4.0f, 1e-5f);
  EXPECT_NEAR(length(k.minor), 2.0f * 5.0f / 8.0f, 1e-5f);
  EXPECT_GT(dot(cross(k.major, k.minor), f.normal), 0.0f) << "right-handed with the normal";
  // Flux over the kernel's area / pi, |M x m1| = 4 * 1.25 * sin(angle) with sin = 4/5.
  EXPECT_NEAR(k.flux.x, 3.0f / (4.0f * 1.25f * 0.8f), 1e-5f);
  ASSERT_TRUE(vkde_kernel(f.photon, f.footprint, f.normal, 1.0f, {2.0f, 1.5f, 0.05f}, k));
  EXPECT_NEAR(length(k.major), 1.5f, 1e-5f);
  EXPECT_NEAR(length(k.minor), 1.25f, 1e-5f);
}

TEST(VkdeKernel, DegenerateFootprintsAreDiscarded) {
  const SkewedFootprint f;
  VkdeKernel k;
  // Height 4 over base 16: kept at f = 1/20, discarded at f = 1/2.
  EXPECT_TRUE(vkde_kernel(f.photon, f.footprint, f.normal, 1.0f, {1.0f, INFINITY, 0.05f}, k));
  EXPECT_FALSE(vkde_kernel(f.photon, f.footprint, f.normal, 1.0f, {1.0f, INFINITY, 0.5f}, k));
  const PhotonFootprint line{Vec3f(1, 0, 0), Vec3f(2, 0, 0)};
  EXPECT_FALSE(vkde_kernel(f.photon, line, f.normal, 1.0f, {}, k));
}

// |d| is the norm of the coordinates in the basis (M, m1, m2): points built from coordinates give
// them back, and the box holds every point of the ellipsoid and touches it.
TEST(VkdeKernel, DistanceAndBoundsMatchTheEllipsoid) {
  for (const Vec3f normal : {Vec3f(0, 0, 1), normalize(Vec3f(0.3f, -0.5f, 0.8f))}) {
    // A skewed footprint in the plane of `normal`.
    const Vec3f u = normalize(cross(normal, Vec3f(1, 0, 0))), v = cross(normal, u);
    const PhotonFootprint footprint{u * 3.0f + v * 0.5f, u * 0.4f + v * 1.2f};
    const Photon photon{Vec3f(1, 2, 3), Vec3f(1), normal};
    VkdeKernel k;
    ASSERT_TRUE(vkde_kernel(photon, footprint, normal, 1.0f, {1.5f, INFINITY, 0.05f}, k));
    const Vec3f m2 = vkde_normal(k) * std::sqrt(vkde_thickness_squared(k));
    EXPECT_NEAR(dot(vkde_normal(k), normal), 1.0f, 1e-5f);
    const Aabb box = vkde_bounds(k);
    std::mt19937 rng(3);
    std::normal_distribution<float> g(0.0f, 1.0f);
    Vec3f reach(0.0f);
    for (int i = 0; i < 20000; ++i) {
      Vec3f c(g(rng), g(rng), g(rng));
      const float r = std::pow(std::uniform_real_distribution<float>(0, 1)(rng), 1.0f / 3.0f);
      c = normalize(c) * (i % 2 ? r : 1.0f);  // inside, and on the surface
      const Vec3f x = k.center + k.major * c.x + k.minor * c.y + m2 * c.z;
      EXPECT_NEAR(vkde_distance_squared(k, x), length_squared(c), 1e-4f);
      for (int axis = 0; axis < 3; ++axis) {
        EXPECT_LE(x[axis], box.upper[axis] + 1e-4f);
        EXPECT_GE(x[axis], box.lower[axis] - 1e-4f);
        reach[axis] = std::max(reach[axis], std::fabs(x[axis] - k.center[axis]));
      }
    }
    for (int axis = 0; axis < 3; ++axis)
      EXPECT_NEAR(reach[axis], box.upper[axis] - k.center[axis],
                  0.02f * (box.upper[axis] - k.center[axis]));
  }
}

}  // namespace
}  // namespace caustica
