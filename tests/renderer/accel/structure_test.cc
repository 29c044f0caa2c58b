// Every structure kind behind build_structure: what it reports against the tree it built, and its
// closest and any hits against brute force, one ray at a time where its view answers single rays
// and through the batch entry points (ray_queries.h) always; the binned SAH builder's own
// invariants.
#include "renderer/accel/structure.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "renderer/accel/binned_sah.h"
#include "renderer/accel/sah_subtrees.h"
#include "renderer/scene/shapes.h"
#include "tests/renderer/accel/structure_checks.h"
#include "tests/renderer/accel/triangle_soup.h"

namespace caustica {
namespace {

struct BuiltStructure {
  std::unique_ptr<Backend> backend = make_cpu_backend(size_t(2) << 30);
  Buffer<TriangleVertices> input;
  TriangleStructure structure;
  BuiltStructure(StructureKind kind, const std::vector<TriangleVertices>& tris)
      : input(*backend, tris.size()) {
    input.upload(tris);
    structure = build_structure(*backend, kind, input.data(), uint32_t(tris.size()));
  }
};

std::vector<TriangleVertices> sphere_triangles() {
  std::vector<TriangleVertices> tris;
  append_triangles(make_sphere(Vec3f(0.3f, -0.2f, 0.1f), 1.7f, 64, 128), tris);
  return tris;
}

class EveryStructure : public ::testing::TestWithParam<StructureKind> {
 protected:
  void check(const std::vector<TriangleVertices>& tris, int rays, uint32_t seed,
             bool aim_at_triangles = false) {
    BuiltStructure b(GetParam(), tris);
    b.structure.visit([&](const auto& view) {
      if constexpr (StructureView<std::decay_t<decltype(view)>>) {
        check_rays(tris, view, rays, seed, aim_at_triangles);
        if (::testing::Test::HasFatalFailure()) return;
      }
      check_rays_batch(*b.backend, tris, view, rays, seed + 1000, aim_at_triangles);
    });
  }
};

// The SAH cost walked from the root on the host (the builder sums it per node on the backend),
// with the nodes counted on the way, and the bytes a node takes.
double walked_sah_cost(const TriangleBvhView& v, size_t& nodes) {
  const double root_area = v.bounds.half_area();
  double cost = 1.0;
  nodes = 0;
  std::function<void(uint32_t)> walk = [&](uint32_t node) {
    ++nodes;
    const Bvh4Node& n = v.nodes[node];
    for (int c = 0; c < 4; ++c) {
      if (n.child[c] == kEmptyChild) continue;
      const double area = n.child_bounds(c).half_area() / root_area;
      if (is_leaf(n.child[c])) {
        cost += leaf_count(n.child[c]) * area;
      } else {
        cost += area;
        walk(n.child[c]);
      }
    }
  };
  walk(0);
  return cost;
}

double walked_sah_cost(const Bvh8View& v, size_t& nodes) {
  const double root_area = v.bounds.half_area();
  double cost = 1.0;
  nodes = 0;
  std::function<void(uint32_t)> walk = [&](uint32_t node) {
    ++nodes;
    const Bvh8Node& n = v.nodes[node];
    uint32_t rank = 0;
    for (int s = 0; s < 8; ++s) {
      if (n.meta[s] == 0) continue;
      const double area = bvh8_child_box(n, s).half_area() / root_area;
      if (bvh8_slot_is_internal(n.meta[s])) {
        cost += area;
        walk(n.child_base + rank++);
      } else {
        cost += bvh8_leaf_triangles(n.meta[s]) * area;
      }
    }
  };
  walk(0);
  return cost;
}

// The same for the sibling-pair tree, its boxes decoded from the root's down.
double walked_sah_cost(const SiblingPairView& v, size_t& nodes) {
  const double root_area = v.bounds.half_area();
  double cost = 1.0;
  nodes = 0;
  std::function<void(uint32_t, const Aabb&)> walk = [&](uint32_t node, const Aabb& box) {
    ++nodes;
    Aabb child_box[2];
    sibling_child_boxes(v.nodes[node], box, child_box[0], child_box[1]);
    for (int c = 0; c < 2; ++c) {
      const uint32_t reference = sibling_reference(v.nodes[node].child[c]);
      const double area = child_box[c].half_area() / root_area;
      if (is_leaf(reference)) {
        cost += sibling_leaf_count(reference) * area;
      } else {
        cost += area;
        walk(reference, child_box[c]);
      }
    }
  };
  walk(0, v.bounds);
  return cost;
}

// The same for a kd-tree, whose nodes weigh by their cells, with its references counted.
template <KdTraversal kTraversal>
double walked_sah_cost(const KdTreeView<kTraversal>& v, size_t& nodes, size_t& refs) {
  const double root_area = v.bounds.half_area();
  double cost = 0.0;
  nodes = refs = 0;
  std::function<void(uint32_t, const Aabb&)> walk = [&](uint32_t node, const Aabb& cell) {
    ++nodes;
    const KdNode& n = v.nodes[node];
    if (n.leaf()) {
      refs += n.ref_count();
      cost += n.ref_count() * cell.half_area() / root_area;
      return;
    }
    cost += cell.half_area() / root_area;
    Aabb below = cell, above = cell;
    below.upper[n.axis()] = above.lower[n.axis()] = n.split;
    walk(n.first_child(), below);
    walk(n.first_child() + 1, above);
  };
  walk(0, v.bounds);
  return cost;
}

// Per layout, the stats against a walk of what was built: a BVH's nodes, triangles and ids;
template <typename View>
void check_stats(const StructureStats& s, const View& v,
                 const std::vector<TriangleVertices>& tris) {
  size_t nodes = 0;
  const double cost = walked_sah_cost(v, nodes);
  EXPECT_EQ(s.nodes, nodes);
  EXPECT_NEAR(s.sah_cost, cost, 1e-4 * cost);
  EXPECT_EQ(s.bytes,
            nodes * sizeof(*v.nodes) + tris.size() * (sizeof(TriangleVertices) + sizeof(uint32_t)));
}

// a kd-tree's nodes, references and triangles;
template <KdTraversal kTraversal>
void check_stats(const StructureStats& s, const KdTreeView<kTraversal>& v,
                 const std::vector<TriangleVertices>& tris) {
  size_t nodes = 0, refs = 0;
  const double cost = walked_sah_cost(v, nodes, refs);
  EXPECT_EQ(s.nodes, nodes);
  EXPECT_NEAR(s.sah_cost, cost, 1e-4 * cost);
  EXPECT_EQ(s.bytes, nodes * sizeof(KdNode) + refs * sizeof(uint32_t) +
                         tris.size() * sizeof(TriangleVertices));
}

// dacrt's triangles and their boxes, one leaf of them all.
void check_stats(const StructureStats& s, const DacrtView&,
                 const std::vector<TriangleVertices>& tris) {
  EXPECT_EQ(s.nodes, 0u);
  EXPECT_EQ(s.sah_cost, double(tris.size()));
  EXPECT_EQ(s.bytes, tris.size() * (sizeof(TriangleVertices) + sizeof(Aabb)));
}

TEST_P(EveryStructure, StatsDescribeTheTreeBuilt) {
  const std::vector<TriangleVertices> tris = random_soup(5000, 41);
  BuiltStructure b(GetParam(), tris);
  const StructureStats& s = b.structure.stats();
  EXPECT_EQ(s.kind, GetParam());
  EXPECT_GT(s.build_ms, 0.0);
  Aabb all;
  for (const TriangleVertices& t : tris) all.extend(triangle_bounds(t));
  b.structure.visit([&](const auto& v) {
    EXPECT_EQ(v.bounds.lower, all.lower);
    EXPECT_EQ(v.bounds.upper, all.upper);
    check_stats(s, v, tris);
  });
}

TEST_P(EveryStructure, MatchesBruteForceOnRandomSoup) { check(random_soup(4000, 99), 10000, 1); }

TEST_P(EveryStructure, MatchesBruteForceOnAClosedMesh) { check(sphere_triangles(), 10000, 8); }

TEST_P(EveryStructure, MatchesBruteForceOnBundledScenes) {
  check(scene_triangles("cornell-caustics"), 10000, 2);
  check(scene_triangles("cornell-box"), 4000, 3);
  check(scene_triangles("ring"), 2000, 4);
}

// Roots that hold only leaves, and sizes around the leaf limit and the builders' stage limits.
TEST_P(EveryStructure, MatchesBruteForceOnSmallSoups) {
  for (size_t n = 1; n <= 3 * kMaxLeafTriangles + 1; ++n) {
    SCOPED_TRACE(n);
    check(random_soup(n, uint32_t(100 + n)), 400, uint32_t(n), true);
  }
  const size_t binned_limit = BinnedSahSchedule{}.per_node_limit();
  for (size_t n : {binned_limit, binned_limit + 1, size_t(kSahSubtreeTriangles),
                   size_t(kSahSubtreeTriangles) + 1}) {
    SCOPED_TRACE(n);
    check(random_soup(n, uint32_t(n)), 2000, uint32_t(n), true);
  }
}

// Identical triangles tie at every hit; no split separates their centroids.
TEST_P(EveryStructure, MatchesBruteForceWhenEveryTriangleCoincides) {
  check(std::vector<TriangleVertices>(37, {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0)}), 1000,
        5, true);
  check(std::vector<TriangleVertices>(700, {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0)}), 1000,
        6, true);
}

// The closest hit and the any hit of one ray through the batch entry points.
template <typename View>
std::pair<Hit, bool> trace_one(Backend& backend, const View& view, const Ray& ray) {
  Buffer<Ray> rays(backend, 1);
  rays.upload(std::vector<Ray>{ray});
  Buffer<Hit> hit(backend, 1);
  Buffer<uint8_t> blocked(backend, 1);
  trace_closest(backend, view, rays.data(), 1, hit.data());
  trace_any(backend, view, rays.data(), 1, blocked.data());
  return {hit.download()[0], blocked.download()[0] != 0};
}

TEST_P(EveryStructure, EmptyAndSingleTriangle) {
  BuiltStructure empty(GetParam(), {});
  EXPECT_EQ(empty.structure.stats().nodes, 0u);
  const Ray ray{Vec3f(0, 0, -1), Vec3f(0, 0, 1)};
  empty.structure.visit([&](const auto& v) {
    const auto [hit, blocked] = trace_one(*empty.backend, v, ray);
    EXPECT_FALSE(hit.valid());
    EXPECT_FALSE(blocked);
  });
  BuiltStructure one(GetParam(), {{Vec3f(-1, -1, 0), Vec3f(1, -1, 0), Vec3f(0, 1, 0)}});
  one.structure.visit([&](const auto& v) {
    const auto [h, blocked] = trace_one(*one.backend, v, ray);
    ASSERT_TRUE(h.valid());
    EXPECT_FLOAT_EQ(h.t, 1.0f);
    EXPECT_EQ(h.triangle, 0u);
    EXPECT_TRUE(blocked);
  });
}

INSTANTIATE_TEST_SUITE_P(Kinds, EveryStructure, ::testing::ValuesIn(kStructureKinds),
                         [](const ::testing::TestParamInfo<StructureKind>& info) {
                           std::string name = structure_kind_name(info.param);
                           for (char& c : name)
                             if (c == '-') c = '_';
                           return name;
                         });

struct BinnedBuild {
  std::unique_ptr<Backend> backend = make_cpu_backend(size_t(2) << 30);
  Buffer<TriangleVertices> input;
  BinaryTriangleBvh binary;
  TriangleBvh wide;
  explicit BinnedBuild(const std::vector<TriangleVertices>& tris,
                       const BinnedSahSchedule& schedule = BinnedSahSchedule{})
      : input(*backend, tris.size()) {
    input.upload(tris);
    binary = build_binned_sah_bvh(*backend, input.data(), uint32_t(tris.size()), schedule);
    // The collapse takes over its tree's triangles, so it gets a build of its own.
    wide = collapse_triangle_bvh(
        *backend, build_binned_sah_bvh(*backend, input.data(), uint32_t(tris.size()), schedule));
  }
};

void check_binned_invariants(const std::vector<TriangleVertices>& tris,
                             const BinnedSahSchedule& schedule = BinnedSahSchedule{}) {
  BinnedBuild b(tris, schedule);
  {
    SCOPED_TRACE("binary");
    check_binary_invariants(b.binary, tris);
  }
  if (::testing::Test::HasFatalFailure()) return;
  SCOPED_TRACE("collapsed");
  check_wide_invariants(b.wide, tris);
}

// Sizes below, at and above the data-parallel stage's limit, and large enough for several of its
// levels.
TEST(BinnedSah, InvariantsOnRandomSoups) {
  const size_t limit = BinnedSahSchedule{}.per_node_limit();
  for (size_t n : {size_t(2), size_t(3), limit, limit + 1, size_t(1000), size_t(40000)}) {
    SCOPED_TRACE(n);
    check_binned_invariants(random_soup(n, uint32_t(7 + n)));
  }
}

// A large node whose centroids coincide cannot be binned: the per-node stage splits it.
TEST(BinnedSah, InvariantsWhenEveryCentroidCoincides) {
  check_binned_invariants(
      std::vector<TriangleVertices>(1000, {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0)}));
  // And beside a cloud of ordinary triangles.
  std::vector<TriangleVertices> mixed = random_soup(3000, 17);
  mixed.insert(mixed.end(), 600, {Vec3f(2, 2, 2), Vec3f(3, 2, 2), Vec3f(2, 3, 2)});
  check_binned_invariants(mixed);
}

// `n` triangles each nearly as large as their common box, no two alike.
std::vector<TriangleVertices> huge_triangles(size_t n) {
  std::vector<TriangleVertices> tris;
  for (size_t i = 0; i < n; ++i) {
    const float s = float(i) / float(n);
    tris.push_back(
        {Vec3f(-10.0f + s, -10.0f, -s), Vec3f(10.0f, -10.0f + s, s), Vec3f(s, 10.0f, 2.0f * s)});
  }
  return tris;
}

// Huge triangles take a bin of their own: the root splits them from a cloud of small ones, and a
// node of nothing but huge triangles, which no bin separates, goes to the per-node stage.
TEST(BinnedSah, InvariantsAndHitsWithHugeTriangles) {
  std::vector<TriangleVertices> mixed = random_soup(3000, 23);
  const std::vector<TriangleVertices> huge = huge_triangles(600);
  mixed.insert(mixed.end(), huge.begin(), huge.end());
  for (const std::vector<TriangleVertices>& tris : {huge, mixed}) {
    SCOPED_TRACE(tris.size());
    check_binned_invariants(tris);
    BuiltStructure b(StructureKind::kBinnedSah, tris);
    b.structure.visit([&](const auto& view) {
      if constexpr (StructureView<std::decay_t<decltype(view)>>) {
        check_rays(tris, view, 3000, 31);
      } else {
        FAIL() << "binned-sah built a layout that answers batches only";
      }
    });
  }
}

TEST(BinnedSah, InvariantsOnBundledSceneAndAClosedMesh) {
  check_binned_invariants(scene_triangles("cornell-caustics"));
  check_binned_invariants(sphere_triangles());
}

// Atomic minima, maxima and counts reduce the bins in any order to the same values, and the sorts
// are stable: every build is the same tree.
TEST(BinnedSah, EveryBuildIsTheSameTree) {
  const std::vector<TriangleVertices> tris = random_soup(60000, 3);
  BinnedBuild first(tris), second(tris);
  expect_same_binary_tree(first.binary, second.binary);
}

// SAH from the root places the top splits where the surface is, not where the curve's octree
// cells are: its inner nodes cost less than the radix tree's on a scanned-like closed surface and
// on a soup.
TEST(BinnedSah, InnerNodesCostLessThanTheRadixTrees) {
  for (const std::vector<TriangleVertices>& tris : {sphere_triangles(), random_soup(40000, 5)}) {
    BinnedBuild b(tris);
    auto backend = make_cpu_backend(size_t(1) << 30);
    Buffer<TriangleVertices> input(*backend, tris.size());
    input.upload(tris);
    const BinaryTriangleBvh radix =
        build_triangle_lbvh(*backend, input.data(), uint32_t(tris.size()));
    const double binned = internal_area_cost(b.binary), lbvh = internal_area_cost(radix);
    std::printf("%zu triangles: inner-node SAH binned %.1f, radix tree %.1f\n", tris.size(), binned,
                lbvh);
    EXPECT_LT(binned, lbvh);
  }
}

// The message of the std::invalid_argument that `f` throws, or "" when it throws none.
template <typename F>
std::string refusal(F&& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(BinnedSahSchedule, ParsesStagesAndNamesEachProblem) {
  const BinnedSahSchedule s = parse_binned_sah_schedule("65536:64,4096:32,128:8");
  ASSERT_EQ(s.stage_count, 3);
  EXPECT_EQ(s.per_node_limit(), 128u);
  EXPECT_EQ(s.max_bins(), 64u);
  EXPECT_EQ(s.bins_for(1000000), 64u);
  EXPECT_EQ(s.bins_for(65537), 64u);
  EXPECT_EQ(s.bins_for(65536), 32u);
  EXPECT_EQ(s.bins_for(129), 8u);
  EXPECT_EQ(s.bins_for(128), 0u);
  EXPECT_EQ(binned_sah_stages_text(s), "65536:64,4096:32,128:8");
  EXPECT_EQ(binned_sah_stages_text(
                parse_binned_sah_schedule(binned_sah_stages_text(BinnedSahSchedule{}))),
            binned_sah_stages_text(BinnedSahSchedule{}));

  EXPECT_NE(refusal([] { parse_binned_sah_schedule(""); }).find("none given"), std::string::npos);
  EXPECT_NE(refusal([] {
              parse_binned_sah_schedule("256");
            }).find("stage 1 ('256'): expected ABOVE:BINS"),
            std::string::npos);
  EXPECT_NE(refusal([] {
              parse_binned_sah_schedule("4096:32,256:x");
            }).find("stage 2 ('256:x'): BINS 'x' is not a whole number"),
            std::string::npos);
  EXPECT_NE(refusal([] { parse_binned_sah_schedule("-5:4"); }).find("ABOVE '-5'"),
            std::string::npos);
  EXPECT_NE(
      refusal([] { parse_binned_sah_schedule("4096:256"); }).find("BINS must be within [2, 128]"),
      std::string::npos);
  EXPECT_NE(refusal([] { parse_binned_sah_schedule("4096:1"); }).find("BINS must be within"),
            std::string::npos);
  EXPECT_NE(refusal([] { parse_binned_sah_schedule("16:32"); }).find("ABOVE must be at least BINS"),
            std::string::npos);
  EXPECT_NE(refusal([] {
              parse_binned_sah_schedule("256:16,4096:32");
            }).find("stage 2 ('4096:32'): ABOVE must be below the previous stage's 256"),
            std::string::npos);
  EXPECT_NE(refusal([] { parse_binned_sah_schedule("256:16,"); }).find("stage 2 (''): expected"),
            std::string::npos);
  EXPECT_NE(refusal([] {
              parse_binned_sah_schedule("7000:2,6000:2,5000:2,4000:2,3000:2,2000:2,1000:2");
            }).find("stage 7"),
            std::string::npos);
}

// --structure-option's words, each refusal naming the option and the problem, and the scene's
// own check of a schedule from the wire.
TEST(BuildOptions, StructureOptionsApplyInOrderAndNameEachProblem) {
  BuildOptions o;
  EXPECT_EQ(binned_sah_stages_text(o.binned_sah), "64:16");
  EXPECT_FALSE(apply_structure_option("binned-sah-reorder=split", o));
  EXPECT_FALSE(apply_structure_option("binned-sah-stages=1024:16,64:4", o));
  EXPECT_FALSE(apply_structure_option("kd-traversal=stackless", o));
  EXPECT_EQ(binned_sah_stages_text(o.binned_sah), "1024:16,64:4");
  EXPECT_EQ(o.binned_sah.reorder, BinnedSahReorder::kSegmentedSplits);  // kept by the stages
  EXPECT_EQ(o.kd_traversal, KdTraversal::kStackless);
  EXPECT_FALSE(apply_structure_option("refit=never", o));
  EXPECT_FALSE(apply_structure_option("refit-sah-bound=1.25", o));
  EXPECT_EQ(o.refit, RefitPolicy::kNever);
  EXPECT_EQ(o.refit_sah_bound, 1.25f);
  EXPECT_EQ(build_options_text(o),
            "binned-sah-stages=1024:16,64:4 binned-sah-reorder=split kd-traversal=stackless "
            "refit=never refit-sah-bound=1.25");
  // The refit policy decides what a geometry change does, not how a build goes.
  EXPECT_EQ(options_read_by(StructureKind::kLbvh4, o), BuildOptions{});
  EXPECT_EQ(apply_structure_options({"kd-traversal=stack", "kd-traversal=stackless"}, {}),
            (BuildOptions{.binned_sah = {}, .kd_traversal = KdTraversal::kStackless}));

  const BuildOptions before = o;
  auto refusal_of = [&](const char* option) {
    const std::optional<std::string> problem = apply_structure_option(option, o);
    EXPECT_EQ(o, before) << "a refused option changed the options: " << option;
    return problem.value_or("");
  };
  EXPECT_NE(refusal_of("binned-sah-reorder=bucket")
                .find("binned-sah-reorder: unknown binned-sah reorder 'bucket' (expected sort or "
                      "split)"),
            std::string::npos);
  EXPECT_NE(refusal_of("binned-sah-stages=64:4,1024:16")
                .find("binned-sah-stages: stage 2 ('1024:16'): ABOVE must be below"),
            std::string::npos);
  EXPECT_NE(refusal_of("kd-traversal=rope").find("unknown kd-tree traversal 'rope'"),
            std::string::npos);
  EXPECT_NE(refusal_of("kd_traversal=stack").find("'kd_traversal' is not a structure option"),
            std::string::npos);
  EXPECT_NE(refusal_of("stackless").find("expected NAME=VALUE"), std::string::npos);
  EXPECT_NE(refusal_of("refit=sometimes")
                .find("refit: unknown refit policy 'sometimes' (expected auto, always or never)"),
            std::string::npos);
  EXPECT_NE(refusal_of("refit-sah-bound=0.5").find("refit-sah-bound: must be within [1, 1000]"),
            std::string::npos);
  EXPECT_NE(refusal_of("refit-sah-bound=nan").find("refit-sah-bound: must be within"),
            std::string::npos);
  EXPECT_NE(refusal_of("refit-sah-bound=1.5x").find("refit-sah-bound: '1.5x' is not a number"),
            std::string::npos);

  BinnedSahSchedule wire;  // as the wire fills it: the values unchecked
  wire.stage[0] = {16, 32};
  EXPECT_NE(binned_sah_stages_problem(wire).value_or("").find("stage 1 ('16:32'): ABOVE must be at "
                                                              "least BINS"),
            std::string::npos);
  wire.stage_count = 0;
  EXPECT_NE(binned_sah_stages_problem(wire).value_or("").find("no stages"), std::string::npos);
  EXPECT_FALSE(binned_sah_stages_problem(BinnedSahSchedule{}));
}

// build_structure hands binned-sah and hybrid the schedule it is given: a coarse one and a fine
// one build different trees, each the tree of its schedule built directly.
TEST(BuildOptions, BuildStructureBuildsWithTheGivenSchedule) {
  const std::vector<TriangleVertices> tris = random_soup(30000, 11);
  std::unique_ptr<Backend> backend = make_cpu_backend(size_t(2) << 30);
  Buffer<TriangleVertices> input(*backend, tris.size());
  input.upload(tris);
  for (StructureKind kind : {StructureKind::kBinnedSah, StructureKind::kHybrid}) {
    SCOPED_TRACE(structure_kind_name(kind));
    std::vector<double> costs;
    for (const char* stages : {"4096:4,256:4", "4096:64,256:32"}) {
      BuildOptions options;
      options.binned_sah = parse_binned_sah_schedule(stages);
      const TriangleStructure built =
          build_structure(*backend, kind, input.data(), uint32_t(tris.size()), options);
      costs.push_back(built.stats().sah_cost);
    }
    EXPECT_NE(costs[0], costs[1]);
    BinnedBuild direct(tris, parse_binned_sah_schedule("4096:4,256:4"));
    if (kind == StructureKind::kBinnedSah) {
      EXPECT_DOUBLE_EQ(costs[0], sah_cost(*direct.backend, direct.wide));
    }
  }
}

// Schedules of other shapes than the default: many bins at the top, a data-parallel part down to
// nodes of two triangles, a single coarse stage; each with both orderings.
std::vector<BinnedSahSchedule> schedule_shapes() {
  std::vector<BinnedSahSchedule> shapes;
  for (const char* text : {"4096:128,512:16,32:8", "2:2", "1000:4"}) {
    for (BinnedSahReorder reorder :
         {BinnedSahReorder::kRadixSort, BinnedSahReorder::kSegmentedSplits})
      shapes.push_back(parse_binned_sah_schedule(text, reorder));
  }
  return shapes;
}

TEST(BinnedSahSchedule, EveryShapeKeepsTheInvariantsAndFindsBruteForcesHits) {
  std::vector<TriangleVertices> mixed = random_soup(6000, 29);
  const std::vector<TriangleVertices> huge = huge_triangles(300);
  mixed.insert(mixed.end(), huge.begin(), huge.end());
  mixed.insert(mixed.end(), 400, {Vec3f(2, 2, 2), Vec3f(3, 2, 2), Vec3f(2, 3, 2)});
  for (const BinnedSahSchedule& schedule : schedule_shapes()) {
    for (const std::vector<TriangleVertices>& tris : {mixed, sphere_triangles()}) {
      SCOPED_TRACE(binned_sah_stages_text(schedule) + " by " + kind_name(schedule.reorder) + ", " +
                   std::to_string(tris.size()) + " triangles");
      check_binned_invariants(tris, schedule);
      if (::testing::Test::HasFatalFailure()) return;
      BinnedBuild b(tris, schedule);
      check_rays(tris, b.wide.view(), 2000, 37);
    }
  }
}

// The radix sort and the segmented splits put each level in the same order, so they build the
// same tree; and the stages' bins change the tree (the test would not notice a schedule ignored).
TEST(BinnedSahSchedule, BothOrderingsBuildTheSameTree) {
  const std::vector<TriangleVertices> tris = random_soup(30000, 11);
  const std::vector<BinnedSahSchedule> shapes = schedule_shapes();
  for (size_t i = 0; i < shapes.size(); i += 2) {
    SCOPED_TRACE(binned_sah_stages_text(shapes[i]));
    BinnedBuild sorted(tris, shapes[i]), split(tris, shapes[i + 1]);
    expect_same_binary_tree(sorted.binary, split.binary);
  }
  BinnedBuild coarse(tris, parse_binned_sah_schedule("256:4")),
      fine(tris, parse_binned_sah_schedule("256:64"));
  EXPECT_NE(internal_area_cost(coarse.binary), internal_area_cost(fine.binary));
}

}  // namespace
}  // namespace caustica
