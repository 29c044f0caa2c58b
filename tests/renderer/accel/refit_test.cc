// Refitting (refit_structure): over triangles that did not move it gives the structure it was
// built as, byte for byte; over moved ones it keeps the topology and finds brute force's hits and
// a fresh build's; the kinds that cannot be refitted say so; and on an exploding mesh the refit
// policy holds the structure in use within its bound of the cost it had when built.
#include <gtest/gtest.h>

#include <cstring>
#include <optional>
#include <vector>

#include "renderer/accel/structure.h"
#include "renderer/motion/explosion.h"
#include "renderer/scene/shapes.h"
#include "tests/renderer/accel/structure_checks.h"
#include "tests/renderer/accel/triangle_soup.h"

namespace caustica {
namespace {

std::vector<TriangleVertices> sphere(int rings, int segments) {
  std::vector<TriangleVertices> tris;
  append_triangles(make_sphere(Vec3f(0.3f, -0.2f, 0.1f), 1.7f, rings, segments), tris);
  return tris;
}

std::vector<TriangleVertices> exploded(const std::vector<TriangleVertices>& rest, float seconds,
                                       const Explosion& explosion = {}) {
  std::vector<TriangleVertices> out(rest.size());
  for (size_t i = 0; i < rest.size(); ++i)
    out[i] = exploded_triangle(rest[i], uint32_t(i), seconds, explosion);
  return out;
}

template <typename T>
bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

class Refit : public ::testing::TestWithParam<StructureKind> {
 protected:
  std::unique_ptr<Backend> backend = make_cpu_backend(size_t(2) << 30);
};

TEST_P(Refit, OverUnmovedTrianglesIsTheStructureBuilt) {
  for (const std::vector<TriangleVertices>& tris : {sphere(48, 96), random_soup(3000, 7)}) {
    Buffer<TriangleVertices> input(*backend, 0);
    input.upload(tris);
    const uint32_t n = uint32_t(tris.size());
    const TriangleStructure built = build_structure(*backend, GetParam(), input.data(), n);
    std::optional<TriangleStructure> refitted = refit_structure(*backend, built, input.data(), n);
    ASSERT_TRUE(refitted);
    const TriangleBvh& a = *built.layout_if<TriangleBvh>();
    const TriangleBvh& b = *refitted->layout_if<TriangleBvh>();
    EXPECT_TRUE(same_bytes(a.bvh.nodes.download(), b.bvh.nodes.download()));
    EXPECT_TRUE(same_bytes(a.triangles.download(), b.triangles.download()));
    EXPECT_TRUE(same_bytes(a.triangle_ids.download(), b.triangle_ids.download()));
    EXPECT_EQ(a.bvh.bounds.lower, b.bvh.bounds.lower);
    EXPECT_EQ(a.bvh.bounds.upper, b.bvh.bounds.upper);
    EXPECT_EQ(refitted->stats().sah_cost, built.stats().sah_cost);
    EXPECT_EQ(refitted->stats().built_sah_cost, built.stats().sah_cost);
    EXPECT_EQ(refitted->stats().refits, 1u);
    EXPECT_EQ(built.stats().refits, 0u);
  }
}

// Moved triangles: the wide tree's invariants but for the leaves' grouping, which the refit
// keeps; every closest and any hit brute force's; and the hits of a structure built anew over
// them, ray for ray.
TEST_P(Refit, OverMovedTrianglesFindsTheHitsOfBruteForceAndOfABuild) {
  const std::vector<TriangleVertices> rest = sphere(40, 80);
  Buffer<TriangleVertices> input(*backend, 0);
  input.upload(rest);
  const uint32_t n = uint32_t(rest.size());
  const TriangleStructure built = build_structure(*backend, GetParam(), input.data(), n);
  for (float seconds : {0.05f, 0.3f, 1.0f}) {
    SCOPED_TRACE(seconds);
    const std::vector<TriangleVertices> moved =
        exploded(rest, seconds, {.speed = 2.0f, .gravity = Vec3f(0, -3, 0)});
    Buffer<TriangleVertices> moved_input(*backend, 0);
    moved_input.upload(moved);
    std::optional<TriangleStructure> refitted =
        refit_structure(*backend, built, moved_input.data(), n);
    ASSERT_TRUE(refitted);
    const TriangleStructure rebuilt = build_structure(*backend, GetParam(), moved_input.data(), n);
    Aabb all;
    for (const TriangleVertices& t : moved) all.extend(triangle_bounds(t));
    const std::vector<Ray> rays = random_check_rays(moved, all, 3000, 11, false);
    const TriangleBvhView view = refitted->layout_if<TriangleBvh>()->view();
    const TriangleBvhView fresh = rebuilt.layout_if<TriangleBvh>()->view();
    EXPECT_EQ(view.bounds.lower, all.lower);
    EXPECT_EQ(view.bounds.upper, all.upper);
    check_rays(moved, view, 3000, 12);
    check_rays_batch(*backend, moved, view, 2000, 13);
    for (size_t i = 0; i < rays.size(); ++i) {
      expect_same_hit(moved, rays[i], closest_hit(view, rays[i]), closest_hit(fresh, rays[i]), i);
      ASSERT_EQ(any_hit(view, rays[i]), any_hit(fresh, rays[i])) << "ray " << i;
    }
    EXPECT_GT(refitted->stats().sah_cost, 0.0);
    EXPECT_EQ(refitted->stats().built_sah_cost, built.stats().sah_cost);
  }
}

TEST_P(Refit, OneTriangleAndNone) {
  for (size_t count : {size_t(0), size_t(1)}) {
    const std::vector<TriangleVertices> rest = random_soup(count, 3);
    Buffer<TriangleVertices> input(*backend, 0);
    input.upload(rest);
    const TriangleStructure built =
        build_structure(*backend, GetParam(), input.data(), uint32_t(count));
    const std::vector<TriangleVertices> moved = exploded(rest, 0.5f);
    Buffer<TriangleVertices> moved_input(*backend, 0);
    moved_input.upload(moved);
    std::optional<TriangleStructure> refitted =
        refit_structure(*backend, built, moved_input.data(), uint32_t(count));
    ASSERT_TRUE(refitted);
    if (count == 1) {
      const Aabb box = triangle_bounds(moved[0]);
      EXPECT_EQ(refitted->bounds().lower, box.lower);
      EXPECT_EQ(refitted->bounds().upper, box.upper);
    }
  }
}

TEST_P(Refit, RefusesAnotherTriangleCount) {
  const std::vector<TriangleVertices> rest = random_soup(100, 4);
  Buffer<TriangleVertices> input(*backend, 0);
  input.upload(rest);
  const TriangleStructure built = build_structure(*backend, GetParam(), input.data(), 100);
  EXPECT_THROW(refit_structure(*backend, built, input.data(), 99), DeviceError);
}

std::vector<StructureKind> refittable() {
  std::vector<StructureKind> kinds;
  for (StructureKind kind : kStructureKinds)
    if (refits(kind)) kinds.push_back(kind);
  return kinds;
}

INSTANTIATE_TEST_SUITE_P(Kinds, Refit, ::testing::ValuesIn(refittable()),
                         [](const ::testing::TestParamInfo<StructureKind>& info) {
                           std::string name = structure_kind_name(info.param);
                           for (char& c : name)
                             if (c == '-') c = '_';
                           return name;
                         });

TEST(RefitKinds, TheFourWideBvhsRefitAndTheOthersDoNot) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  const std::vector<TriangleVertices> rest = random_soup(500, 5);
  Buffer<TriangleVertices> input(*backend, 0);
  input.upload(rest);
  for (StructureKind kind : kStructureKinds) {
    SCOPED_TRACE(structure_kind_name(kind));
    const TriangleStructure built = build_structure(*backend, kind, input.data(), 500);
    EXPECT_EQ(refit_structure(*backend, built, input.data(), 500).has_value(), refits(kind));
  }
  EXPECT_EQ(refittable().size(), 3u);
}

// An exploding sphere, frame by frame under the auto policy's rule: a refit is kept while its
// cost is within the bound of the cost at the last build. The structure in use then stays within
// the bound of that build's cost, and a little beyond it of a fresh build's; the explosion makes
// the policy build anew now and then, and refits save builds in between.
TEST_P(Refit, AutoPolicyHoldsTheCostWithinItsBoundOnAnExplodingMesh) {
  const std::vector<TriangleVertices> rest = sphere(64, 128);
  const uint32_t n = uint32_t(rest.size());
  const float bound = kDefaultRefitSahBound;
  Buffer<TriangleVertices> input(*backend, 0);
  input.upload(rest);
  TriangleStructure in_use = build_structure(*backend, GetParam(), input.data(), n);
  int refits = 0, builds = 0;
  double worst_over_fresh = 0;
  for (int frame = 1; frame <= 30; ++frame) {
    const std::vector<TriangleVertices> moved =
        exploded(rest, frame / 30.0f, {.speed = 1.0f, .gravity = Vec3f(0, -2, 0)});
    input.upload(moved);
    std::optional<TriangleStructure> refitted = refit_structure(*backend, in_use, input.data(), n);
    ASSERT_TRUE(refitted);
    const TriangleStructure fresh = build_structure(*backend, GetParam(), input.data(), n);
    if (refitted->stats().sah_cost <= bound * refitted->stats().built_sah_cost) {
      in_use = *std::move(refitted);
      ++refits;
    } else {
      in_use = build_structure(*backend, GetParam(), input.data(), n);
      ++builds;
    }
    EXPECT_LE(in_use.stats().sah_cost, bound * in_use.stats().built_sah_cost) << frame;
    worst_over_fresh = std::max(worst_over_fresh, in_use.stats().sah_cost / fresh.stats().sah_cost);
  }
  EXPECT_GT(refits, 0);
  EXPECT_GT(builds, 0);
  EXPECT_LE(worst_over_fresh, bound * 1.1);
  RecordProperty("worst_cost_over_a_fresh_build", std::to_string(worst_over_fresh));
  std::printf("refits %d builds %d worst cost over a fresh build %.3f\n", refits, builds,
              worst_over_fresh);
}

}  // namespace
}  // namespace caustica
