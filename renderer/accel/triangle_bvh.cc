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

TriangleBvh refit_triangle_bvh(Backend& backend, const TriangleBvh& bvh,
                               const TriangleVertices* triangles, uint32_t count) {
  if (count != bvh.bvh.triangle_count)
    throw DeviceError("refit_triangle_bvh: the triangle count differs from the structure's");
  TriangleBvh out;
  out.triangles = Buffer<TriangleVertices>(backend, count);
  out.triangle_ids = Buffer<uint32_t>(backend, count);
  out.bvh.nodes = Buffer<Bvh4Node>(backend, bvh.bvh.nodes.size());
  out.bvh.triangle_count = count;
  out.bvh.level_starts = bvh.bvh.level_starts;
  if (count == 0) return out;
  backend.copy_on_device(out.triangle_ids.data(), bvh.triangle_ids.data(),
                         out.triangle_ids.bytes());
  const uint32_t* ids = bvh.triangle_ids.data();
  TriangleVertices* sorted = out.triangles.data();
  parallel_for(backend, "refit_gather_triangles", count,
               [=] CAUSTICA_HD(size_t i) { sorted[i] = triangles[ids[i]]; });
  if (bvh.bvh.nodes.empty()) {
    TriangleVertices only;
    backend.copy_to_host(&only, sorted, sizeof(only));
    out.bvh.bounds = triangle_bounds(only);
    return out;
  }
  // The deepest level first, so that a node's children are done when it reads their boxes.
  const Bvh4Node* old_nodes = bvh.bvh.nodes.data();
  Bvh4Node* nodes = out.bvh.nodes.data();
  const std::vector<uint32_t>& levels = bvh.bvh.level_starts;
  for (size_t level = levels.size() - 1; level-- > 0;) {
    const uint32_t first = levels[level];
    parallel_for(backend, "refit_bvh4_level", levels[level + 1] - first, [=] CAUSTICA_HD(size_t i) {
      const uint32_t index = first + uint32_t(i);
      Bvh4Node node = old_nodes[index];
      for (int c = 0; c < 4; ++c) {
        const uint32_t child = node.child[c];
        Aabb box;
        if (child == kEmptyChild) {
        } else if (is_leaf(child)) {
          const uint32_t begin = leaf_first(child), end = begin + leaf_count(child);
          for (uint32_t t = begin; t < end; ++t) box.extend(triangle_bounds(sorted[t]));
        } else {
          const Bvh4Node& below = nodes[child];
          for (int g = 0; g < 4; ++g)
            if (below.child[g] != kEmptyChild) box.extend(below.child_bounds(g));
        }
        node.set_child_bounds(c, box);
      }
      nodes[index] = node;
    });
  }
  Bvh4Node root;
  backend.copy_to_host(&root, nodes, sizeof(root));
  for (int c = 0; c < 4; ++c)
    if (root.child[c] != kEmptyChild) out.bvh.bounds.extend(root.child_bounds(c));
  return out;
}

}  // namespace caustica
