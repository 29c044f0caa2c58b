// DACRT (dacrt.h): its batch queries against brute force on soups and real meshes, at the paper's
// thresholds and at small ones that divide small inputs deeply, and the division's invariant that
// every ray-triangle pair that intersects meets in some terminal node.
#include "renderer/accel/dacrt.h"

#include <gtest/gtest.h>

#include <vector>

#include "renderer/scene/shapes.h"
#include "tests/renderer/accel/structure_checks.h"
#include "tests/renderer/accel/triangle_soup.h"

namespace caustica {
namespace {

struct DacrtFixture {
  std::unique_ptr<Backend> backend = make_cpu_backend(size_t(2) << 30);
  Buffer<TriangleVertices> input;
  DacrtTriangles dacrt;
  DacrtFixture(const std::vector<TriangleVertices>& tris, const DacrtSettings& settings = {})
      : input(*backend, tris.size()) {
    input.upload(tris);
    dacrt = build_dacrt_triangles(*backend, input.data(), uint32_t(tris.size()), settings);
  }
};

// Small thresholds: many levels even over a few thousand triangles and rays.
DacrtSettings deep_settings() {
  DacrtSettings s;
  s.terminal_triangles = 8;
  s.terminal_rays = 8;
  s.max_terminal_tests = 256;
  return s;
}

void check(const std::vector<TriangleVertices>& tris, int rays, uint32_t seed,
           bool aim_at_triangles = false) {
  for (const DacrtSettings& settings : {DacrtSettings{}, deep_settings()}) {
    SCOPED_TRACE(settings.terminal_triangles);
    DacrtFixture f(tris, settings);
    check_rays_batch(*f.backend, tris, f.dacrt.view(), rays, seed, aim_at_triangles);
    if (::testing::Test::HasFatalFailure()) return;
  }
}

TEST(Dacrt, StoresTheTrianglesAndTheirBoxes) {
  const std::vector<TriangleVertices> tris = random_soup(3000, 4);
  DacrtFixture f(tris);
  const DacrtView v = f.dacrt.view();
  EXPECT_EQ(v.count, tris.size());
  Aabb all;
  for (const TriangleVertices& t : tris) all.extend(triangle_bounds(t));
  EXPECT_EQ(v.bounds.lower, all.lower);
  EXPECT_EQ(v.bounds.upper, all.upper);
  EXPECT_EQ(f.dacrt.bytes(), tris.size() * (sizeof(TriangleVertices) + sizeof(Aabb)));
  const std::vector<Aabb> boxes = f.dacrt.triangle_bounds.download();
  for (size_t i = 0; i < tris.size(); ++i) {
    ASSERT_EQ(boxes[i].lower, triangle_bounds(tris[i]).lower);
    ASSERT_EQ(boxes[i].upper, triangle_bounds(tris[i]).upper);
  }
}

TEST(Dacrt, MatchesBruteForceOnRandomSoup) { check(random_soup(4000, 99), 10000, 1); }

TEST(Dacrt, MatchesBruteForceOnAClosedMesh) {
  std::vector<TriangleVertices> tris;
  append_triangles(make_sphere(Vec3f(0.3f, -0.2f, 0.1f), 1.7f, 64, 128), tris);
  check(tris, 10000, 8);
}

TEST(Dacrt, MatchesBruteForceOnBundledScenes) {
  check(scene_triangles("cornell-caustics"), 10000, 2);
  check(scene_triangles("cornell-box"), 4000, 3);
  check(scene_triangles("ring"), 2000, 4);
}

TEST(Dacrt, MatchesBruteForceOnSmallSoupsAndCoincidentTriangles) {
  for (size_t n : {size_t(1), size_t(2), size_t(7), size_t(300)}) {
    SCOPED_TRACE(n);
    check(random_soup(n, uint32_t(100 + n)), 400, uint32_t(n), true);
  }
  check(std::vector<TriangleVertices>(700, {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0)}), 1000,
        6, true);
}

TEST(Dacrt, NoTrianglesOrNoRays) {
  DacrtFixture empty({});
  Buffer<Ray> ray(*empty.backend, 1);
  ray.upload(std::vector<Ray>{Ray{Vec3f(0, 0, -1), Vec3f(0, 0, 1)}});
  Buffer<Hit> hit(*empty.backend, 1);
  Buffer<uint8_t> blocked(*empty.backend, 1);
  trace_closest(*empty.backend, empty.dacrt.view(), ray.data(), 1, hit.data());
  trace_any(*empty.backend, empty.dacrt.view(), ray.data(), 1, blocked.data());
  EXPECT_FALSE(hit.download()[0].valid());
  EXPECT_EQ(blocked.download()[0], 0);
  DacrtFixture one({{Vec3f(-1, -1, 0), Vec3f(1, -1, 0), Vec3f(0, 1, 0)}});
  trace_closest(*one.backend, one.dacrt.view(), nullptr, 0, nullptr);
  Buffer<Ray> through(*one.backend, 1);
  through.upload(std::vector<Ray>{Ray{Vec3f(0, 0, -1), Vec3f(0, 0, 1)}});
  Buffer<Hit> one_hit(*one.backend, 1);
  trace_closest(*one.backend, one.dacrt.view(), through.data(), 1, one_hit.data());
  const Hit h = one_hit.download()[0];
  ASSERT_TRUE(h.valid());
  EXPECT_FLOAT_EQ(h.t, 1.0f);
  EXPECT_EQ(h.triangle, 0u);
}

// Every pair that intersects (brute force over all pairs) shares a terminal node, and every
// terminal node is one the settings allow to end the division.
TEST(Dacrt, EveryIntersectingPairMeetsInATerminalNode) {
  const std::vector<TriangleVertices> tris = random_soup(600, 12);
  DacrtFixture f(tris, deep_settings());
  const std::vector<Ray> rays = random_check_rays(tris, f.dacrt.view().bounds, 3000, 5, true);
  Buffer<Ray> ray_buffer(*f.backend, rays.size());
  ray_buffer.upload(rays);
  const std::vector<DacrtTerminal> terminals =
      dacrt_terminal_nodes(*f.backend, f.dacrt.view(), ray_buffer.data(), rays.size());
  ASSERT_GT(terminals.size(), 20u);  // the division went deep
  std::vector<uint8_t> met(rays.size() * tris.size(), 0);
  const DacrtSettings s = deep_settings();
  for (const DacrtTerminal& t : terminals) {
    ASSERT_FALSE(t.triangles.empty());
    ASSERT_FALSE(t.rays.empty());
    // A soup's splits always separate some triangles, so only small and cheap nodes end.
    const bool small = t.triangles.size() < s.terminal_triangles || t.rays.size() < s.terminal_rays;
    const bool cheap = uint64_t(t.triangles.size()) * t.rays.size() <= s.max_terminal_tests;
    EXPECT_TRUE(small && cheap) << t.triangles.size() << " triangles, " << t.rays.size()
                                << " rays";
    for (uint32_t r : t.rays)
      for (uint32_t tri : t.triangles) met[size_t(r) * tris.size() + tri] = 1;
  }
  size_t pairs = 0;
  for (size_t r = 0; r < rays.size(); ++r) {
    const WatertightRay w(rays[r]);
    for (size_t tri = 0; tri < tris.size(); ++tri) {
      float t, u, v;
      if (!intersect_triangle(w, tris[tri], rays[r].t_min, rays[r].t_max, t, u, v)) continue;
      ++pairs;
      ASSERT_TRUE(met[r * tris.size() + tri]) << "ray " << r << " triangle " << tri;
    }
  }
  EXPECT_GT(pairs, rays.size() / 4);
}

// The stats describe the batch, and the same batch gives the same hits every time.
TEST(Dacrt, StatsAndRepeatability) {
  const std::vector<TriangleVertices> tris = random_soup(20000, 3);
  DacrtFixture f(tris);
  const std::vector<Ray> rays = random_check_rays(tris, f.dacrt.view().bounds, 20000, 9, true);
  Buffer<Ray> ray_buffer(*f.backend, rays.size());
  ray_buffer.upload(rays);
  Buffer<Hit> first(*f.backend, rays.size()), second(*f.backend, rays.size());
  DacrtTraceStats stats;
  trace_closest(*f.backend, f.dacrt.view(), ray_buffer.data(), rays.size(), first.data(), &stats);
  trace_closest(*f.backend, f.dacrt.view(), ray_buffer.data(), rays.size(), second.data());
  EXPECT_GT(stats.levels, 3u);
  EXPECT_GT(stats.terminal_nodes, 10u);
  EXPECT_GT(stats.triangle_tests, rays.size());
  // Far fewer tests than brute force, and scratch of at least the rays' keys.
  EXPECT_LT(stats.triangle_tests, uint64_t(rays.size()) * tris.size() / 20);
  EXPECT_GE(stats.peak_scratch_bytes, rays.size() * sizeof(uint64_t));
  const std::vector<Hit> a = first.download(), b = second.download();
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].triangle, b[i].triangle);
    ASSERT_EQ(a[i].t, b[i].t);
  }
}

}  // namespace
}  // namespace caustica
