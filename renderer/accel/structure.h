// The seam where ray-tracing structures plug in, after pbrt-v4's CreateAccelerator and Embree's
// builder factory: a scene names a StructureKind (structure_kind.h), build_structure runs that
// kind's builder on any backend, and a TriangleStructure owns what it built.
//
// Every structure has a device view, a small struct of plain pointers copied by value into
// kernels, that meets BatchStructureView (ray_queries.h: batches of closest and any hits); views
// that also answer single rays in CAUSTICA_HD code meet StructureView, and kernels may trace
// through them one ray per thread. dacrt's view answers batches only. Kernels are
// templates over the view type: TriangleStructure::visit hands the caller the view of the
// structure's layout, so the dispatch on the kind happens once per launch on the host and never
// per ray on the device (no virtual calls there). Kinds whose builders differ but whose layout is
// the same (lbvh4, binned-sah and hybrid all end in 4-wide nodes) share one view type and so one
// instantiation of every kernel; sibling-pair has a layout of its own.
#pragma once

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <variant>

#include "renderer/accel/bvh8_traversal.h"
#include "renderer/accel/dacrt.h"
#include "renderer/accel/ray_queries.h"
#include "renderer/accel/sibling_pair_traversal.h"
#include "renderer/accel/structure_kind.h"
#include "renderer/accel/traversal.h"
#include "renderer/accel/triangle_bvh.h"

namespace caustica {

static_assert(StructureView<TriangleBvhView>);
static_assert(StructureView<SiblingPairView>);
static_assert(StructureView<Bvh8View>);
static_assert(BatchStructureView<TriangleBvhView>);
static_assert(BatchStructureView<DacrtView> && !StructureView<DacrtView>);

// What a builder reports about the structure it built.
struct StructureStats {
  StructureKind kind = kDefaultStructure;
  // In the structure's own layout (4-wide nodes for a Bvh4, 8-wide for a Bvh8; 0 for dacrt).
  size_t nodes = 0;
  // Everything its traversal reads that is kept between frames: nodes, triangles, triangle ids
  // (dacrt: the triangles and their boxes; its per-frame scratch is DacrtTraceStats's).
  size_t bytes = 0;
  // The surface area heuristic's cost with C_T = C_I = 1: (sum over inner nodes of their area,
  // plus sum over leaves of triangles x area) over the root's area.
  double sah_cost = 0;
  double build_ms = 0;  // wall clock from the triangles in memory to the finished structure
};

class TriangleStructure {
 public:
  TriangleStructure() = default;
  TriangleStructure(TriangleBvh bvh4, const StructureStats& stats)
      : layout_(std::move(bvh4)), stats_(stats) {}
  TriangleStructure(SiblingPairBvh pairs, const StructureStats& stats)
      : layout_(std::move(pairs)), stats_(stats) {}
  TriangleStructure(Bvh8 bvh8, const StructureStats& stats)
      : layout_(std::move(bvh8)), stats_(stats) {}
  TriangleStructure(DacrtTriangles dacrt, const StructureStats& stats)
      : layout_(std::move(dacrt)), stats_(stats) {}

  const StructureStats& stats() const { return stats_; }
  StructureKind kind() const { return stats_.kind; }
  Aabb bounds() const {
    return std::visit([](const auto& layout) { return layout.view().bounds; }, layout_);
  }

  // Calls f(view) with this structure's device view: the one dispatch on the kind a launch makes.
  template <typename F>
  decltype(auto) visit(F&& f) const {
    return std::visit([&](const auto& layout) -> decltype(auto) { return f(layout.view()); },
                      layout_);
  }

 private:
  std::variant<TriangleBvh, SiblingPairBvh, DacrtTriangles, Bvh8> layout_;
  StructureStats stats_;
};

// Builds a structure of `kind` over `count` triangles already in the backend's memory, and
// measures it. Kinds that order triangles along a space-filling curve (lbvh4) take `curve`, by
// default the backend's own (backend_curve), which differs between the CPU and a GPU.
TriangleStructure build_structure(Backend& backend, StructureKind kind,
                                  const TriangleVertices* triangles, uint32_t count);
TriangleStructure build_structure(Backend& backend, StructureKind kind,
                                  const TriangleVertices* triangles, uint32_t count, Curve curve);

// The SAH cost (StructureStats::sah_cost) of a 4-wide BVH, computed on the backend; that of a
// SiblingPairBvh is in sibling_pair_bvh.h.
double sah_cost(Backend& backend, const TriangleBvh& bvh);
// The SAH cost of what dacrt stores: one leaf of every triangle, since the division is made anew
// for every batch and never kept.
double sah_cost(Backend& backend, const DacrtTriangles& dacrt);

}  // namespace caustica
