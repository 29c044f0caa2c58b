#include "renderer/accel/triangle_bvh.h"

#include "renderer/accel/bvh_build.h"
#include "renderer/accel/curve_order.h"
#include "renderer/accel/sah_subtrees.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {

BinaryTriangleBvh build_triangle_lbvh(Backend& backend, const TriangleVertices* triangles,
                                      uint32_t count) {
  return build_triangle_lbvh(backend, triangles, count, backend_curve(backend));
}

namespace {

// The LBVH, with `on_node` called for each internal node as build_bvh_from_sorted_codes does.
template <typename OnNode>
BinaryTriangleBvh build_lbvh(Backend& backend, const TriangleVertices* triangles, uint32_t count,
                             Curve curve, OnNode on_node) {
  BinaryTriangleBvh out;
  out.triangles.bind(backend);
  out.triangle_ids.bind(backend);
  if (count == 0) {
    out.bvh.nodes.bind(backend);
    return out;
  }
  // Pass 1: triangle boxes and the scene box, left on the device for the next kernels. Codes
  // quantise box centres over the scene box (not the tighter centroid box): one reduction less,
  // and no measurable loss on scanned meshes.
  Buffer<Aabb> boxes(backend, count);
  Buffer<BvhSummary> summary(backend, 1);
  Aabb* box = boxes.data();
  parallel_for(backend, "lbvh_triangle_boxes", count,
               [=] CAUSTICA_HD(size_t i) { box[i] = triangle_bounds(triangles[i]); });
  backend.reduce_bounds_to(box, count, &summary.data()->bounds);

  // Pass 2: the curve's codes, sorted with the triangle indices.
  CurveOrder sorted_order = sort_by_curve(backend, box, count, &summary.data()->bounds, curve);
  out.triangle_ids = std::move(sorted_order.order);
  const uint32_t* ids = out.triangle_ids.data();

  // Pass 3: the hierarchy; each leaf's thread also moves its triangle into leaf order, so the
  // triangles are read once, not once for a gather and again for their boxes.
  out.triangles.resize_discard(count);
  TriangleVertices* sorted = out.triangles.data();
  out.bvh = build_bvh_from_sorted_codes(
      backend, sorted_order.codes.data(), count, summary.data(),
      [=] CAUSTICA_HD(uint32_t leaf) {
        const TriangleVertices t = triangles[ids[leaf]];
        sorted[leaf] = t;
        return triangle_bounds(t);
      },
      on_node);
  return out;
}

}  // namespace

BinaryTriangleBvh build_triangle_lbvh(Backend& backend, const TriangleVertices* triangles,
                                      uint32_t count, Curve curve) {
  return build_lbvh(backend, triangles, count, curve, IgnoreNodes{});
}

TriangleBvh build_triangle_bvh(Backend& backend, const TriangleVertices* triangles,
                               uint32_t count) {
  return build_triangle_bvh(backend, triangles, count, backend_curve(backend));
}

BinaryTriangleBvh build_triangle_lbvh_listing_subtrees(Backend& backend,
                                                       const TriangleVertices* triangles,
                                                       uint32_t count, Curve curve, uint32_t limit,
                                                       SmallSubtree* list, uint32_t* listed) {
  return build_lbvh(backend, triangles, count, curve,
                    ListSmallSubtrees{list, listed, count, limit});
}

BinaryTriangleBvh build_sah_refined_lbvh(Backend& backend, const TriangleVertices* triangles,
                                         uint32_t count, Curve curve) {
  Buffer<SmallSubtree> small(backend, count / 2 + 1);
  Buffer<uint32_t> listed(backend, 1);
  backend.fill_bytes(listed.data(), 0, sizeof(uint32_t));
  BinaryTriangleBvh lbvh = build_triangle_lbvh_listing_subtrees(
      backend, triangles, count, curve, kSahSubtreeTriangles, small.data(), listed.data());
  uint32_t small_count = 0;
  if (count >= 2) backend.copy_to_host(&small_count, listed.data(), sizeof(uint32_t));
  rebuild_small_subtrees(backend, lbvh.bvh, small.data(), small_count, lbvh.triangles,
                         lbvh.triangle_ids, count <= kSahSubtreeTriangles);
  return lbvh;
}

TriangleBvh build_triangle_bvh(Backend& backend, const TriangleVertices* triangles, uint32_t count,
                               Curve curve) {
  return collapse_triangle_bvh(backend, build_sah_refined_lbvh(backend, triangles, count, curve));
}

TriangleBvh collapse_triangle_bvh(Backend& backend, BinaryTriangleBvh binary) {
  TriangleBvh out;
  out.bvh = collapse_to_bvh4(backend, binary.bvh);
  out.triangles = std::move(binary.triangles);
  out.triangle_ids = std::move(binary.triangle_ids);
  return out;
}

}  // namespace caustica
