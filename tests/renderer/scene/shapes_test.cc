#include "renderer/scene/shapes.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <utility>

#include "tests/renderer/scene/scene_test_util.h"

namespace caustica {
namespace {

using ::caustica::testing::triangle_cross;
using ::caustica::testing::Vec3Near;

// Signed volume by the divergence theorem: positive exactly when a closed mesh faces outwards.
double signed_volume(const Mesh& mesh) {
  double volume = 0;
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    const Vec3f a = mesh.positions[mesh.indices[3 * t]];
    const Vec3f b = mesh.positions[mesh.indices[3 * t + 1]];
    const Vec3f c = mesh.positions[mesh.indices[3 * t + 2]];
    volume += dot(a, cross(b, c)) / 6.0;
  }
  return volume;
}

// Every directed edge (by position) must be matched by its reverse exactly once: the mesh is
// closed and consistently wound.
void expect_closed_and_consistent(const Mesh& mesh) {
  auto key = [](Vec3f p) { return std::make_tuple(p.x, p.y, p.z); };
  std::map<std::pair<std::tuple<float, float, float>, std::tuple<float, float, float>>, int> edges;
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const Vec3f from = mesh.positions[mesh.indices[3 * t + k]];
      const Vec3f to = mesh.positions[mesh.indices[3 * t + (k + 1) % 3]];
      ++edges[{key(from), key(to)}];
    }
  }
  for (const auto& [edge, count] : edges) {
    ASSERT_EQ(count, 1) << "directed edge used twice";
    const auto reverse = edges.find({edge.second, edge.first});
    ASSERT_NE(reverse, edges.end()) << "open edge";
  }
}

TEST(MakeQuad, SplitsAlongTheFirstDiagonal) {
  const Mesh mesh = make_quad({Vec3f{0, 0, 0}, Vec3f{1, 0, 0}, Vec3f{1, 1, 0}, Vec3f{0, 1, 0}});
  EXPECT_EQ(mesh.positions.size(), 4u);
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_THAT(triangle_cross(mesh, 0), Vec3Near(Vec3f(0, 0, 1), 0));
  EXPECT_THAT(triangle_cross(mesh, 1), Vec3Near(Vec3f(0, 0, 1), 0));
}

TEST(MakeSphere, CountsMatchTheTessellation) {
  const Mesh mesh = make_sphere({0, 0, 0}, 1, 32, 64);
  EXPECT_EQ(mesh.positions.size(), 2u + 31u * 64u);
  EXPECT_EQ(mesh.triangle_count(), 3968u);
  EXPECT_EQ(sphere_triangle_count(32, 64), 3968u);
  EXPECT_TRUE(mesh.normals.empty());
}

TEST(MakeSphere, VerticesLieOnTheSphereWithPolesOnY) {
  const Vec3f center{370, 100, 350};
  const float radius = 100;
  const Mesh mesh = make_sphere(center, radius, 32, 64);
  for (const Vec3f& p : mesh.positions) {
    EXPECT_NEAR(length(p - center), radius, 1e-4 * radius);
  }
  EXPECT_THAT(mesh.positions.front(), Vec3Near(center + Vec3f(0, radius, 0), 0));
  EXPECT_THAT(mesh.positions.back(), Vec3Near(center - Vec3f(0, radius, 0), 0));
  // Ring i = 16 of 32 is the equator.
  EXPECT_THAT(mesh.positions[1 + 15 * 64], Vec3Near(center + Vec3f(radius, 0, 0), 1e-3f));
}

TEST(MakeSphere, EveryTriangleFacesOutwards) {
  const Vec3f center{1, 2, 3};
  const Mesh mesh = make_sphere(center, 2, 32, 64);
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    const Vec3f centroid =
        (mesh.positions[mesh.indices[3 * t]] + mesh.positions[mesh.indices[3 * t + 1]] +
         mesh.positions[mesh.indices[3 * t + 2]]) /
        3.0f;
    EXPECT_GT(dot(triangle_cross(mesh, t), centroid - center), 0) << "triangle " << t;
  }
  expect_closed_and_consistent(mesh);
  EXPECT_GT(signed_volume(mesh), 0);
}

TEST(MakeSphere, SmallestTessellationIsAClosedBipyramid) {
  const Mesh mesh = make_sphere({0, 0, 0}, 1, 2, 3);
  EXPECT_EQ(mesh.positions.size(), 5u);
  EXPECT_EQ(mesh.triangle_count(), 6u);
  expect_closed_and_consistent(mesh);
  EXPECT_GT(signed_volume(mesh), 0);
}

TEST(MakeRing, IsAClosedOutwardBandWithTheExpectedVolume) {
  const float r = 100, t = 4, h = 60;
  const int segments = 256;
  const Mesh mesh = make_ring({0, 0, 0}, r, t, h, segments);
  EXPECT_EQ(mesh.triangle_count(), ring_triangle_count(segments));
  EXPECT_EQ(mesh.triangle_count(), 8u * segments);
  expect_closed_and_consistent(mesh);
  // A regular polygon of n sides and circumradius R has area n/2 R^2 sin(2 pi / n).
  const double polygon = segments / 2.0 * std::sin(2 * M_PI / segments);
  const double expected = polygon * ((r + t) * (r + t) - r * r) * h;
  EXPECT_NEAR(signed_volume(mesh), expected, 1e-3 * expected);
}

TEST(MakeRing, StandsOnItsBaseWithNormalsAgreeingWithWinding) {
  const Vec3f base{10, 5, -20};
  const Mesh mesh = make_ring(base, 50, 2, 30, 64);
  ASSERT_EQ(mesh.normals.size(), mesh.positions.size());
  float min_y = INFINITY, max_y = -INFINITY;
  for (const Vec3f& p : mesh.positions) {
    min_y = std::min(min_y, p.y);
    max_y = std::max(max_y, p.y);
    const float radial = std::hypot(p.x - base.x, p.z - base.z);
    EXPECT_TRUE(std::fabs(radial - 50) < 1e-3f || std::fabs(radial - 52) < 1e-3f) << radial;
  }
  EXPECT_EQ(min_y, 5);
  EXPECT_EQ(max_y, 35);
  for (size_t tri = 0; tri < mesh.triangle_count(); ++tri) {
    const Vec3f geometric = triangle_cross(mesh, tri);
    for (int k = 0; k < 3; ++k) {
      EXPECT_GT(dot(geometric, mesh.normals[mesh.indices[3 * tri + k]]), 0) << "triangle " << tri;
    }
  }
}

}  // namespace
}  // namespace caustica
