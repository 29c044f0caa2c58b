#include "renderer/accel/structure.h"

#include <chrono>

#include "renderer/accel/binned_sah.h"
#include "renderer/accel/hybrid_bvh.h"
#include "renderer/accel/kd_tree.h"
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
  return TriangleStructure(std::move(layout), stats);
}

}  // namespace

TriangleStructure build_structure(Backend& backend, StructureKind kind,
                                  const TriangleVertices* triangles, uint32_t count) {
  return build_structure(backend, kind, triangles, count, backend_curve(backend));
}

TriangleStructure build_structure(Backend& backend, StructureKind kind,
                                  const TriangleVertices* triangles, uint32_t count, Curve curve) {
  switch (kind) {
    case StructureKind::kLbvh4:
      return measured(backend, kind,
                      [&] { return build_triangle_bvh(backend, triangles, count, curve); });
    case StructureKind::kBinnedSah: {
      // Read before the build, so that a bad setting fails before any work.
      const BinnedSahSchedule schedule = binned_sah_schedule_from_environment();
      return measured(backend, kind, [&] {
        return collapse_triangle_bvh(backend,
                                     build_binned_sah_bvh(backend, triangles, count, schedule));
      });
    }
    case StructureKind::kHybrid: {
      const BinnedSahSchedule schedule = binned_sah_schedule_from_environment();
      return measured(backend, kind, [&] {
        return collapse_triangle_bvh(
            backend, build_hybrid_bvh(backend, triangles, count, curve, kHybridLbvhSubtreeTriangles,
                                      schedule));
      });
    }
    case StructureKind::kSiblingPair:
      return measured(backend, kind, [&] {
        return build_sibling_pair_bvh(backend,
                                      build_sah_refined_lbvh(backend, triangles, count, curve));
      });
    case StructureKind::kKdSah:
    case StructureKind::kKdSiroh: {
      // Read before the build, so that a bad setting fails before any work.
      const KdTraversal traversal = kd_traversal_from_environment();
      return measured(backend, kind, [&] {
        KdTree tree = build_kd_tree(backend, triangles, count, kd_cost_of(kind));
        tree.traversal = traversal;
        return tree;
      });
    }
    case StructureKind::kDacrt:
      return measured(backend, kind,
                      [&] { return build_dacrt_triangles(backend, triangles, count); });
    case StructureKind::kBvh8:
      return measured(backend, kind, [&] { return build_bvh8(backend, triangles, count, curve); });
  }
  throw DeviceError("build_structure: unknown structure kind");
}

double sah_cost(Backend& backend, const TriangleBvh& bvh) {
  const float root_area = bvh.bvh.bounds.half_area();
  const uint32_t triangles = bvh.bvh.triangle_count;
  if (triangles == 0 || !(root_area > 0.0f)) return double(triangles);
  if (triangles == 1) return 1.0;
  // Per node: its children's terms relative to the root's area (C_T for an inner child, C_I per
  // triangle of a leaf); the root itself adds 1.
  const size_t n = bvh.bvh.nodes.size();
  Buffer<float> terms(backend, n);
  float* term = terms.data();
  const Bvh4Node* nodes = bvh.bvh.nodes.data();
  const float inv_root = 1.0f / root_area;
  parallel_for(backend, "sah_cost_terms", n, [=] CAUSTICA_HD(size_t i) {
    const Bvh4Node& node = nodes[i];
    float sum = 0.0f;
    for (int c = 0; c < 4; ++c) {
      const uint32_t child = node.child[c];
      if (child == kEmptyChild) continue;
      const float area = node.child_bounds(c).half_area() * inv_root;
      sum += is_leaf(child) ? float(leaf_count(child)) * area : area;
    }
    term[i] = sum;
  });
  return 1.0 + backend.reduce_sum(term, n);
}

double sah_cost(Backend&, const DacrtTriangles& dacrt) { return double(dacrt.triangles.size()); }

}  // namespace caustica
