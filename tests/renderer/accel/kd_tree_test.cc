// The kd-tree builds (kd-sah and kd-siroh): the tree's invariants walked on the host, its SAH cost
// against a walk of its own, and the hits of both traversals against brute force and against
// each other.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "renderer/accel/kd_cost.h"
#include "renderer/accel/kd_traversal.h"
#include "renderer/accel/structure.h"
#include "renderer/scene/mesh_file.h"
#include "renderer/scene/shapes.h"
#include "tests/renderer/accel/structure_checks.h"
#include "tests/renderer/accel/triangle_soup.h"

namespace caustica {
namespace {

struct KdBuild {
  std::unique_ptr<Backend> backend = make_cpu_backend(size_t(4) << 30);
  Buffer<TriangleVertices> input;
  KdTree tree;
  KdBuild(const std::vector<TriangleVertices>& tris, KdCost cost) : input(*backend, tris.size()) {
    input.upload(tris);
    tree = build_kd_tree(*backend, input.data(), uint32_t(tris.size()), cost);
  }
};

std::vector<TriangleVertices> sphere_triangles() {
  std::vector<TriangleVertices> tris;
  append_triangles(make_sphere(Vec3f(0.3f, -0.2f, 0.1f), 1.7f, 64, 128), tris);
  return tris;
}

// The bundled Stanford bunny (scenes/bunny, 69,451 triangles).
std::vector<TriangleVertices> bunny_triangles() {
  absl::StatusOr<MeshFile> file =
      load_mesh_file(std::filesystem::path(CAUSTICA_SCENES_DIR) / "bunny" / "bunny.ply");
  EXPECT_TRUE(file.ok()) << file.status();
  std::vector<TriangleVertices> tris;
  if (file.ok())
    for (const Mesh& m : file->meshes) append_triangles(m, tris);
  return tris;
}

// Whether a box and a cell overlap with volume on every axis where the cell has extent (on one
// where it is flat, touching counts).
bool overlaps_inside(const Aabb& box, const Aabb& cell) {
  for (int a = 0; a < 3; ++a) {
    if (cell.lower[a] < cell.upper[a]) {
      if (!(box.lower[a] < cell.upper[a] && box.upper[a] > cell.lower[a])) return false;
    } else if (!(box.lower[a] <= cell.upper[a] && box.upper[a] >= cell.lower[a])) {
      return false;
    }
  }
  return true;
}

// Walks the tree from the root with each node's cell: splits strictly inside their cells, leaves
// no deeper than the limit, references in range, each node reached once; then every triangle whose
// box overlaps a leaf's cell inside it is referenced by that leaf (found by descending the tree
// with the triangle's box), and every triangle by some leaf. Returns the SAH cost walked on the
// host.
double check_kd_invariants(const KdTree& tree, const std::vector<TriangleVertices>& tris) {
  const size_t n = tris.size();
  const std::vector<KdNode> nodes = tree.nodes.download();
  const std::vector<uint32_t> refs = tree.refs.download();
  EXPECT_EQ(tree.triangle_count, n);
  if (n == 0) {
    EXPECT_TRUE(nodes.empty());
    return 0.0;
  }
  const int limit = std::min(int(8.0 + 1.3 * std::log2(double(n))), kKdMaxLeafDepth);
  EXPECT_LE(tree.depth, limit);
  std::vector<int> seen(nodes.size(), 0), referenced(n, 0);
  std::vector<Aabb> cells(nodes.size());
  std::vector<std::vector<uint32_t>> leaf_sorted(nodes.size());
  const double root_area = tree.bounds.half_area();
  double cost = 0.0;
  std::function<void(uint32_t, const Aabb&, int)> walk = [&](uint32_t index, const Aabb& cell,
                                                             int depth) {
    ASSERT_LT(index, nodes.size());
    ASSERT_EQ(++seen[index], 1) << "node " << index << " reached twice";
    ASSERT_LE(depth, limit);
    cells[index] = cell;
    const KdNode& node = nodes[index];
    if (node.leaf()) {
      const uint32_t first = node.first_ref(), count = node.ref_count();
      ASSERT_LE(size_t(first) + count, refs.size()) << "leaf " << index;
      cost += count * cell.half_area() / root_area;
      for (uint32_t i = first; i < first + count; ++i) {
        ASSERT_LT(refs[i], n);
        leaf_sorted[index].push_back(refs[i]);
        ++referenced[refs[i]];
      }
      std::sort(leaf_sorted[index].begin(), leaf_sorted[index].end());
      return;
    }
    cost += cell.half_area() / root_area;
    const int a = node.axis();
    ASSERT_LT(cell.lower[a], node.split) << "node " << index;
    ASSERT_GT(cell.upper[a], node.split) << "node " << index;
    Aabb below = cell, above = cell;
    below.upper[a] = node.split;
    above.lower[a] = node.split;
    walk(node.first_child(), below, depth + 1);
    if (::testing::Test::HasFatalFailure()) return;
    walk(node.first_child() + 1, above, depth + 1);
  };
  walk(0, tree.bounds, 0);
  if (::testing::Test::HasFatalFailure()) return cost;
  for (size_t i = 0; i < nodes.size(); ++i) EXPECT_EQ(seen[i], 1) << "node " << i;
  for (size_t t = 0; t < n; ++t) EXPECT_GE(referenced[t], 1) << "triangle " << t;
  size_t missing = 0;
  for (uint32_t t = 0; t < n; ++t) {
    const Aabb box = triangle_bounds(tris[t]);
    std::vector<uint32_t> todo{0};
    while (!todo.empty()) {
      const uint32_t index = todo.back();
      todo.pop_back();
      if (!overlaps_inside(box, cells[index])) continue;
      const KdNode& node = nodes[index];
      if (!node.leaf()) {
        todo.push_back(node.first_child());
        todo.push_back(node.first_child() + 1);
      } else if (!std::binary_search(leaf_sorted[index].begin(), leaf_sorted[index].end(), t) &&
                 missing++ < 5) {
        ADD_FAILURE() << "triangle " << t << " overlaps leaf " << index << " but is not in it";
      }
    }
  }
  EXPECT_EQ(missing, 0u);
  return cost;
}

// Both traversals against brute force, and against each other on the same rays: the same
// distance, triangle and barycentrics, and the same any-hit answers.
void check_traversals(const KdTree& tree, const std::vector<TriangleVertices>& tris, int rays,
                      uint32_t seed, bool aim_at_triangles = false) {
  const KdTreeStackView stack = tree.view_for<KdTraversal::kStack>();
  const KdTreeStacklessView stackless = tree.view_for<KdTraversal::kStackless>();
  {
    SCOPED_TRACE("stack");
    check_rays(tris, stack, rays, seed, aim_at_triangles);
  }
  {
    SCOPED_TRACE("stackless");
    check_rays(tris, stackless, rays, seed, aim_at_triangles);
  }
  const Aabb b = tree.bounds;
  std::mt19937 rng(seed + 1000);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < rays; ++i) {
    Ray ray;
    ray.origin = b.lower + b.extent() * Vec3f(u(rng), u(rng), u(rng));
    ray.direction = sample_uniform_sphere(u(rng), u(rng));
    if (i % 3 == 0) ray.t_max = length(b.extent()) * u(rng);
    const Hit a = closest_hit(stack, ray), c = closest_hit(stackless, ray);
    ASSERT_EQ(a.triangle, c.triangle) << "ray " << i;
    ASSERT_EQ(a.t, c.t) << "ray " << i;
    ASSERT_EQ(a.u, c.u) << "ray " << i;
    ASSERT_EQ(a.v, c.v) << "ray " << i;
    ASSERT_EQ(any_hit(stack, ray), any_hit(stackless, ray)) << "ray " << i;
  }
}

class KdTrees : public ::testing::TestWithParam<KdCost> {
 protected:
  void check(const std::vector<TriangleVertices>& tris, int rays, uint32_t seed,
             bool aim_at_triangles = false) {
    KdBuild b(tris, GetParam());
    const double walked = check_kd_invariants(b.tree, tris);
    if (::testing::Test::HasFatalFailure()) return;
    const double reported = sah_cost(*b.backend, b.tree);
    EXPECT_NEAR(reported, walked, 1e-4 * walked);
    std::printf("%zu triangles: %zu nodes, %zu references, depth %d, SAH cost %.2f\n", tris.size(),
                b.tree.node_count(), b.tree.refs.size(), b.tree.depth, reported);
    check_traversals(b.tree, tris, rays, seed, aim_at_triangles);
  }
};

TEST_P(KdTrees, RandomSoups) {
  check(random_soup(4000, 99), 10000, 1);
  check(random_soup(20000, 7), 10000, 2);
}

TEST_P(KdTrees, ClosedMesh) { check(sphere_triangles(), 10000, 8); }

TEST_P(KdTrees, BundledScenes) {
  check(scene_triangles("cornell-caustics"), 10000, 2);
  check(scene_triangles("cornell-box"), 10000, 3);
  check(scene_triangles("ring"), 4000, 4);
}

TEST_P(KdTrees, Bunny) {
  const std::vector<TriangleVertices> bunny = bunny_triangles();
  ASSERT_EQ(bunny.size(), 69451u);
  check(bunny, 2000, 11);
}

TEST_P(KdTrees, SmallSoups) {
  for (size_t n = 1; n <= 70; n += 3) {
    SCOPED_TRACE(n);
    check(random_soup(n, uint32_t(100 + n)), 400, uint32_t(n), true);
  }
}

// Identical triangles straddle every plane: splits that separate nothing stop.
TEST_P(KdTrees, CoincidingTriangles) {
  check(std::vector<TriangleVertices>(700, {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0)}), 1000,
        5, true);
  std::vector<TriangleVertices> mixed = random_soup(3000, 17);
  mixed.insert(mixed.end(), 600, {Vec3f(2, 2, 2), Vec3f(3, 2, 2), Vec3f(2, 3, 2)});
  check(mixed, 4000, 6);
}

// Triangles nearly as large as the scene among a cloud of small ones straddle every plane the
// large-node stage cuts: their references must not multiply without bound.
TEST_P(KdTrees, HugeTrianglesAmongSmallOnes) {
  std::vector<TriangleVertices> tris = random_soup(3000, 23);
  for (int i = 0; i < 600; ++i) {
    const float s = float(i) / 600.0f;
    tris.push_back(
        {Vec3f(-10.0f + s, -10.0f, -s), Vec3f(10.0f, -10.0f + s, s), Vec3f(s, 10.0f, 2.0f * s)});
  }
  KdBuild b(tris, GetParam());
  EXPECT_LT(b.tree.refs.size(), 40 * tris.size());
  check(tris, 4000, 12);
}

// Axis-aligned planar triangles on common planes (a grid of quads): planar events, and planes
// that lie on splits.
TEST_P(KdTrees, AxisAlignedGrid) {
  std::vector<TriangleVertices> tris;
  for (int x = 0; x < 30; ++x) {
    for (int y = 0; y < 30; ++y) {
      const float z = float((x * 7 + y * 3) % 4);
      const Vec3f p(float(x), float(y), z);
      tris.push_back({p, p + Vec3f(1, 0, 0), p + Vec3f(0, 1, 0)});
      tris.push_back({p + Vec3f(1, 0, 0), p + Vec3f(1, 1, 0), p + Vec3f(0, 1, 0)});
      tris.push_back({p, p + Vec3f(0, 0, 1), p + Vec3f(1, 0, 0)});
    }
  }
  check(tris, 10000, 9, true);
}

TEST_P(KdTrees, EmptyAndSingleTriangle) {
  KdBuild empty({}, GetParam());
  EXPECT_EQ(empty.tree.node_count(), 0u);
  const Ray ray{Vec3f(0, 0, -1), Vec3f(0, 0, 1)};
  EXPECT_FALSE(closest_hit(empty.tree.view_for<KdTraversal::kStack>(), ray).valid());
  EXPECT_FALSE(any_hit(empty.tree.view_for<KdTraversal::kStackless>(), ray));
  KdBuild one({{Vec3f(-1, -1, 0), Vec3f(1, -1, 0), Vec3f(0, 1, 0)}}, GetParam());
  for (const Hit h : {closest_hit(one.tree.view_for<KdTraversal::kStack>(), ray),
                      closest_hit(one.tree.view_for<KdTraversal::kStackless>(), ray)}) {
    ASSERT_TRUE(h.valid());
    EXPECT_FLOAT_EQ(h.t, 1.0f);
    EXPECT_EQ(h.triangle, 0u);
  }
}

// A deep tree (many levels of the large-node stage) stays within the depth the stackless walk
// handles and both walks still agree with brute force.
TEST_P(KdTrees, LargeSoupStaysWithinTheDepthLimit) {
  const std::vector<TriangleVertices> tris = random_soup(200000, 13);
  KdBuild b(tris, GetParam());
  EXPECT_LE(b.tree.depth, kKdMaxLeafDepth);
  check_traversals(b.tree, tris, 2000, 17);
}

INSTANTIATE_TEST_SUITE_P(Costs, KdTrees, ::testing::Values(KdCost::kSah, KdCost::kSiroh),
                         [](const ::testing::TestParamInfo<KdCost>& info) {
                           return std::string(info.param == KdCost::kSah ? "sah" : "siroh");
                         });

// SIROH weighs nodes by where rays start inside the scene, so on the same triangles its tree
// differs from the SAH's, and, built to minimise it, costs no less by the SAH's own measure than
// a tree that stopped early would: both beat a single leaf by far.
TEST(KdTree, BothCostsBeatOneLeafAndDiffer) {
  const std::vector<TriangleVertices> tris = scene_triangles("cornell-caustics");
  KdBuild sah(tris, KdCost::kSah), siroh(tris, KdCost::kSiroh);
  const double sah_cost_sah = sah_cost(*sah.backend, sah.tree);
  const double sah_cost_siroh = sah_cost(*siroh.backend, siroh.tree);
  EXPECT_LT(sah_cost_sah, 0.1 * double(tris.size()));
  EXPECT_LT(sah_cost_siroh, 0.1 * double(tris.size()));
  EXPECT_NE(sah.tree.nodes.download().size() * 1000003 + sah.tree.refs.size(),
            siroh.tree.nodes.download().size() * 1000003 + siroh.tree.refs.size());
}

// The per-candidate forms of both probabilities against their definitions: SAH, the children's
// areas over the cell's; SIROH, eq. 4.6 evaluated for each child, over the cell's (for which the
// whole scene box is 1).
TEST(KdTree, ChildProbabilitiesMatchTheirDefinitions) {
  const Aabb scene{Vec3f(-2.0f, 0.0f, 1.0f), Vec3f(3.0f, 4.0f, 2.5f)};
  const Vec3f e = scene.extent();
  const float volume = e.x * e.y * e.z;
  EXPECT_NEAR(siroh_probability(scene, scene, volume), 1.0f, 1e-6f);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int trial = 0; trial < 2000; ++trial) {
    Aabb cell;
    for (int a = 0; a < 3; ++a) {
      float x = scene.lower[a] + e[a] * u(rng), y = scene.lower[a] + e[a] * u(rng);
      cell.lower[a] = std::min(x, y);
      cell.upper[a] = std::max(x, y);
    }
    const int axis = trial % 3;
    const float split = cell.lower[axis] + (cell.upper[axis] - cell.lower[axis]) * u(rng);
    Aabb below = cell, above = cell;
    below.upper[axis] = above.lower[axis] = split;
    for (bool siroh : {false, true}) {
      SCOPED_TRACE(siroh ? "siroh" : "sah");
      const ChildProbabilities p = child_probabilities(siroh, cell, axis, scene, volume);
      float left, right;
      p.at(split, left, right);
      const double parent = siroh ? siroh_probability(scene, cell, volume) : cell.half_area();
      const double want_left =
          (siroh ? siroh_probability(scene, below, volume) : below.half_area()) / parent;
      const double want_right =
          (siroh ? siroh_probability(scene, above, volume) : above.half_area()) / parent;
      ASSERT_NEAR(left, want_left, 1e-4 * want_left + 1e-6) << "trial " << trial;
      ASSERT_NEAR(right, want_right, 1e-4 * want_right + 1e-6) << "trial " << trial;
    }
  }
}

// build_structure takes the traversal from its options, set_kd_traversal changes it, and visit
// hands out the view of the traversal set; both views of one build answer alike.
TEST(KdTree, StructureHandsOutTheViewOfItsTraversal) {
  const std::vector<TriangleVertices> tris = scene_triangles("cornell-caustics");
  auto backend = make_cpu_backend(size_t(1) << 30);
  Buffer<TriangleVertices> input(*backend, tris.size());
  input.upload(tris);
  for (StructureKind kind : {StructureKind::kKdSah, StructureKind::kKdSiroh}) {
    SCOPED_TRACE(structure_kind_name(kind));
    EXPECT_FALSE(build_structure(*backend, kind, input.data(), uint32_t(tris.size()))
                     .visit([](const auto& view) {
                       return std::is_same_v<std::decay_t<decltype(view)>, KdTreeStacklessView>;
                     }));
    TriangleStructure structure =
        build_structure(*backend, kind, input.data(), uint32_t(tris.size()),
                        BuildOptions{.binned_sah = {}, .kd_traversal = KdTraversal::kStackless});
    auto is_stackless = [](const auto& view) {
      return std::is_same_v<std::decay_t<decltype(view)>, KdTreeStacklessView>;
    };
    EXPECT_TRUE(structure.visit(is_stackless));
    structure.visit([&](const auto& view) {
      if constexpr (StructureView<std::decay_t<decltype(view)>>) check_rays(tris, view, 3000, 21);
    });
    EXPECT_TRUE(structure.set_kd_traversal(KdTraversal::kStack));
    EXPECT_FALSE(structure.visit(is_stackless));
    structure.visit([&](const auto& view) {
      if constexpr (StructureView<std::decay_t<decltype(view)>>) check_rays(tris, view, 3000, 21);
    });
  }
  TriangleStructure bvh =
      build_structure(*backend, StructureKind::kLbvh4, input.data(), uint32_t(tris.size()));
  EXPECT_FALSE(bvh.set_kd_traversal(KdTraversal::kStackless));
}

}  // namespace
}  // namespace caustica
