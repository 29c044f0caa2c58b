#include "renderer/accel/hybrid_bvh.h"

#include <stdexcept>
#include <string>

#include "renderer/accel/binned_sah.h"
#include "renderer/accel/sah_subtrees.h"

namespace caustica {

BinaryTriangleBvh build_hybrid_bvh(Backend& backend, const TriangleVertices* triangles,
                                   uint32_t count, Curve curve, uint32_t lbvh_limit,
                                   const BinnedSahSchedule& schedule) {
  if (lbvh_limit < 2)
    throw std::invalid_argument(
        "build_hybrid_bvh: the LBVH's subtree limit must be at least 2, not " +
        std::to_string(lbvh_limit));
  Buffer<SmallSubtree> segments(backend, count / 2 + 1);
  Buffer<uint32_t> listed(backend, 1);
  backend.fill_bytes(listed.data(), 0, sizeof(uint32_t));
  BinaryTriangleBvh tree = build_triangle_lbvh_listing_subtrees(
      backend, triangles, count, curve, lbvh_limit, segments.data(), listed.data());
  if (count < 2) return tree;
  uint32_t segment_count = 0;
  backend.copy_to_host(&segment_count, listed.data(), sizeof(uint32_t));
  rebuild_subtrees_by_binned_sah(backend, tree, segments.data(), segment_count, count <= lbvh_limit,
                                 schedule);
  return tree;
}

}  // namespace caustica
