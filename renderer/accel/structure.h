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
// instantiation of every kernel; sibling-pair and bvh8 have layouts of their own, dacrt a view that
// answers batches only (ray_queries.h). A kd-tree (kd-sah, kd-siroh) has a view per traversal, and
// the traversal it was built with picks which one visit hands out.
#pragma once

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <type_traits>
#include <variant>

#include "renderer/accel/build_options.h"
#include "renderer/accel/bvh8_traversal.h"
#include "renderer/accel/dacrt.h"
#include "renderer/accel/kd_traversal.h"
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
static_assert(StructureView<KdTreeStackView>);
static_assert(StructureView<KdTreeStacklessView>);

// Every per-ray view, for what must be written once per view: X(View) for each.
#define CAUSTICA_FOR_EACH_STRUCTURE_VIEW(X) \
  X(TriangleBvhView)                        \
  X(SiblingPairView)                        \
  X(Bvh8View)                               \
  X(KdTreeStackView)                        \
  X(KdTreeStacklessView)

// The batch queries of every per-ray view are instantiated once, in ray_queries.cc. nvcc gives an
// extended lambda's host side a function pointer that the translation unit creating the lambda
// sets; with the same instantiation in several units, the linker kept one unit's code while
// another's set its pointer, and a batch traced from the first called through null.
#define CAUSTICA_EXTERN_BATCH_QUERIES(View)                                                  \
  extern template void trace_closest<View>(Backend&, const View&, const Ray*, size_t, Hit*); \
  extern template void trace_any<View>(Backend&, const View&, const Ray*, size_t, uint8_t*);
CAUSTICA_FOR_EACH_STRUCTURE_VIEW(CAUSTICA_EXTERN_BATCH_QUERIES)
#undef CAUSTICA_EXTERN_BATCH_QUERIES

// What a builder reports about the structure it built.
struct StructureStats {
  StructureKind kind = kDefaultStructure;
  // In the structure's own layout (4-wide nodes for a Bvh4, 8-wide for a Bvh8, kd nodes; 0 for
  // dacrt).
  size_t nodes = 0;
  // Everything its traversal reads that is kept between frames: nodes, triangles, triangle ids (a
  // kd-tree's leaves' triangle references instead of ids; dacrt: the triangles and their boxes,
  // its per-frame scratch being DacrtTraceStats's).
  size_t bytes = 0;
  // The surface area heuristic's cost with C_T = C_I = 1: (sum over inner nodes of their area,
  // plus sum over leaves of triangles x area) over the root's area; a kd-tree's nodes weigh by
  // their cells' areas and its leaves by their references.
  double sah_cost = 0;
  double build_ms = 0;  // wall clock from the triangles in memory to the finished structure
  // Refits since the structure was built (refit_structure), build_ms being the last one's time,
  // and the SAH cost it had when built, which a refit's cost is held against (RefitPolicy).
  uint32_t refits = 0;
  double built_sah_cost = 0;
};

namespace detail {

// Calls f with a layout's device view: a kd-tree's for the traversal it is set to.
template <typename Layout, typename F>
decltype(auto) visit_view(const Layout& layout, F& f) {
  return f(layout.view());
}
template <typename F>
decltype(auto) visit_view(const KdTree& tree, F& f) {
  if (tree.traversal == KdTraversal::kStackless) return f(tree.view_for<KdTraversal::kStackless>());
  return f(tree.view_for<KdTraversal::kStack>());
}

}  // namespace detail

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
  TriangleStructure(KdTree kd_tree, const StructureStats& stats)
      : layout_(std::move(kd_tree)), stats_(stats) {}

  const StructureStats& stats() const { return stats_; }
  // The layout, when it is a `Layout` (triangle_bvh.h, kd_tree.h, ...); null otherwise.
  template <typename Layout>
  const Layout* layout_if() const {
    return std::get_if<Layout>(&layout_);
  }
  StructureKind kind() const { return stats_.kind; }

  // Calls f(view) with this structure's device view: the one dispatch on the kind a launch makes.
  template <typename F>
  decltype(auto) visit(F&& f) const {
    return std::visit(
        [&](const auto& layout) -> decltype(auto) { return detail::visit_view(layout, f); },
        layout_);
  }

  Aabb bounds() const {
    return visit([](const auto& view) { return view.bounds; });
  }

  // The traversal of a kd-tree's view from now on (kd_tree.h); false, changing nothing, for a
  // structure that is no kd-tree.
  bool set_kd_traversal(KdTraversal traversal) {
    KdTree* tree = std::get_if<KdTree>(&layout_);
    if (tree == nullptr) return false;
    tree->traversal = traversal;
    return true;
  }

 private:
  std::variant<TriangleBvh, SiblingPairBvh, KdTree, DacrtTriangles, Bvh8> layout_;
  StructureStats stats_;
};

// Builds a structure of `kind` over `count` triangles already in the backend's memory, and
// measures it. Kinds that order triangles along a space-filling curve (lbvh4) take `curve`, by
// default the backend's own (backend_curve), which differs between the CPU and a GPU. The kind's
// builder takes its own of `options` (build_options.h); the other kinds ignore them.
TriangleStructure build_structure(Backend& backend, StructureKind kind,
                                  const TriangleVertices* triangles, uint32_t count,
                                  const BuildOptions& options = {});
TriangleStructure build_structure(Backend& backend, StructureKind kind,
                                  const TriangleVertices* triangles, uint32_t count, Curve curve,
                                  const BuildOptions& options = {});

// `structure` refitted over `triangles` (as many as it was built over, in the same order, moved
// with their topology kept), in new buffers beside it and measured as a build is, its stats'
// refits counted up; nullopt when its kind cannot be refitted (refits, structure_kind.h).
std::optional<TriangleStructure> refit_structure(Backend& backend,
                                                 const TriangleStructure& structure,
                                                 const TriangleVertices* triangles, uint32_t count);

// The SAH cost (StructureStats::sah_cost) of a 4-wide BVH, computed on the backend; the other
// layouts' are with them (sibling_pair_bvh.h, kd_tree.h, bvh8.h).
double sah_cost(Backend& backend, const TriangleBvh& bvh);
// The SAH cost of what dacrt stores: one leaf of every triangle, since the division is made anew
// for every batch and never kept.
double sah_cost(Backend& backend, const DacrtTriangles& dacrt);

}  // namespace caustica
