#include "renderer/accel/structure.h"

#include <chrono>

#include "renderer/accel/binned_sah.h"
#include "renderer/accel/hybrid_bvh.h"
#include "renderer/accel/kd_tree.h"
#include "renderer/accel/wide_sah_cost.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {
namespace {

KdCost kd_cost_of(StructureKind kind) {
  return kind == StructureKind::kKdSiroh ? KdCost::kSiroh : KdCost::kSah;
}

// The structure `build` makes (a layout with node_count, bytes and an sah_cost), timed from the
// triangles in memory to the finished structure, and measured.
template <typename Build>
TriangleStructure measured(Backend& backend, StructureKind kind, Build build) {
  const auto start = std::chrono::steady_clock::now();
  auto layout = build();
  backend.synchronize();
  StructureStats stats;
  stats.kind = kind;
  stats.build_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  stats.nodes = layout.node_count();
  stats.bytes = layout.bytes();
  stats.sah_cost = sah_cost(backend, layout);
  stats.built_sah_cost = stats.sah_cost;
  return TriangleStructure(std::move(layout), stats);
}

}  // namespace

TriangleStructure build_structure(Backend& backend, StructureKind kind,
                                  const TriangleVertices* triangles, uint32_t count,
                                  const BuildOptions& options) {
  return build_structure(backend, kind, triangles, count, backend_curve(backend), options);
}

TriangleStructure build_structure(Backend& backend, StructureKind kind,
                                  const TriangleVertices* triangles, uint32_t count, Curve curve,
                                  const BuildOptions& options) {
  switch (kind) {
    case StructureKind::kLbvh4:
      return measured(backend, kind,
                      [&] { return build_triangle_bvh(backend, triangles, count, curve); });
    case StructureKind::kBinnedSah:
      return measured(backend, kind, [&] {
        return collapse_triangle_bvh(
            backend, build_binned_sah_bvh(backend, triangles, count, options.binned_sah));
      });
    case StructureKind::kHybrid:
      return measured(backend, kind, [&] {
        return collapse_triangle_bvh(
            backend, build_hybrid_bvh(backend, triangles, count, curve, kHybridLbvhSubtreeTriangles,
                                      options.binned_sah));
      });
    case StructureKind::kSiblingPair:
      return measured(backend, kind, [&] {
        return build_sibling_pair_bvh(backend,
                                      build_sah_refined_lbvh(backend, triangles, count, curve));
      });
    case StructureKind::kKdSah:
    case StructureKind::kKdSiroh:
      return measured(backend, kind, [&] {
        KdTree tree = build_kd_tree(backend, triangles, count, kd_cost_of(kind));
        tree.traversal = options.kd_traversal;
        return tree;
      });
    case StructureKind::kDacrt:
      return measured(backend, kind,
                      [&] { return build_dacrt_triangles(backend, triangles, count); });
    case StructureKind::kBvh8:
      return measured(backend, kind, [&] { return build_bvh8(backend, triangles, count, curve); });
  }
  throw DeviceError("build_structure: unknown structure kind");
}

std::optional<TriangleStructure> refit_structure(Backend& backend,
                                                 const TriangleStructure& structure,
                                                 const TriangleVertices* triangles,
                                                 uint32_t count) {
  const TriangleBvh* bvh = structure.layout_if<TriangleBvh>();
  if (!refits(structure.kind()) || bvh == nullptr) return std::nullopt;
  const auto start = std::chrono::steady_clock::now();
  TriangleBvh refitted = refit_triangle_bvh(backend, *bvh, triangles, count);
  backend.synchronize();
  StructureStats stats = structure.stats();
  stats.build_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  stats.sah_cost = sah_cost(backend, refitted);
  ++stats.refits;
  return TriangleStructure(std::move(refitted), stats);
}

namespace {

// A 4-wide node's children's terms (wide_sah_cost).
struct Bvh4ChildrenTerms {
  CAUSTICA_HDI float operator()(const Bvh4Node& node, float inv_root) const {
    float sum = 0.0f;
    for (int c = 0; c < 4; ++c) {
      const uint32_t child = node.child[c];
      if (child == kEmptyChild) continue;
      const float area = node.child_bounds(c).half_area() * inv_root;
      sum += is_leaf(child) ? float(leaf_count(child)) * area : area;
    }
    return sum;
  }
};

}  // namespace

double sah_cost(Backend& backend, const TriangleBvh& bvh) {
  return wide_sah_cost(backend, "sah_cost_terms", bvh.bvh.nodes.data(), bvh.bvh.nodes.size(),
                       bvh.bvh.triangle_count, bvh.bvh.bounds.half_area(), Bvh4ChildrenTerms{});
}

double sah_cost(Backend&, const DacrtTriangles& dacrt) { return double(dacrt.triangles.size()); }

}  // namespace caustica
