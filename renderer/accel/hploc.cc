#include "renderer/accel/hploc.h"

#include <cstring>

#include "renderer/accel/bvh_build.h"
#include "renderer/accel/curve_order.h"
#include "renderer/base/atomic.h"
#include "renderer/base/warp.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {
namespace {

// Marks the end of a range's clusters in the cluster array when it holds fewer than its size.
constexpr uint32_t kNoCluster = 0xfffffffeu;

// A subtree not yet merged: a leaf (kLeafFlag | sorted position) or an internal node.
struct Cluster {
  Aabb box;
  uint32_t id;
  uint32_t size;    // triangles
  uint32_t pieces;  // ClusteredTriangleBvh::leaf_pieces (1 for a leaf)
};

// The order in which pairs merge: by the area of their merged box, then by their positions, so
// every pair differs and the nearest pair of a round is always mutual (each round merges one
// pair at least). Positions are below 2 x kHplocMaxClusters = 32.
CAUSTICA_HDI uint64_t pair_key(const Aabb& a, const Aabb& b, uint32_t first, uint32_t second) {
  return uint64_t(ordered_bits(merge(a, b).half_area())) << 10 | first << 5 | second;
}

// What the climb reads and writes; a plain struct of pointers copied into the kernel.
struct ClimbState {
  const uint32_t* codes;   // sorted
  const Aabb* leaf_boxes;  // sorted order
  uint32_t* other_end;     // per radix-tree split: the far end of the first child to arrive
  uint32_t* clusters;      // per sorted position
  BvhNode* nodes;
  Aabb* node_boxes;
  uint32_t* node_sizes;
  uint32_t* leaf_pieces;
  uint32_t* node_count;
  uint32_t* root;
  uint32_t count;
};

// Reads data another thread of the launch wrote: on a GPU from L2, past an SM's L1, which does
// not see other SMs' stores.
template <typename T>
CAUSTICA_HDI T load_published(const T* p) {
#if defined(__CUDA_ARCH__)
  static_assert(sizeof(T) % 4 == 0, "whole words");
  uint32_t words[sizeof(T) / 4];
  const uint32_t* from = reinterpret_cast<const uint32_t*>(p);
  for (size_t w = 0; w < sizeof(T) / 4; ++w) words[w] = __ldcg(from + w);
  T out;
  memcpy(&out, words, sizeof(T));
  return out;
#else
  return *p;
#endif
}

CAUSTICA_HDI Cluster cluster_of(const ClimbState& s, uint32_t id) {
  if (is_leaf(id)) return {s.leaf_boxes[leaf_index(id)], id, 1, 1};
  return {load_published(s.node_boxes + id), id, load_published(s.node_sizes + id),
          load_published(s.leaf_pieces + id)};
}

// Writes the node joining clusters a and b (a first) at index `node`.
CAUSTICA_HDI Cluster join(const ClimbState& s, uint32_t node, const Cluster& a, const Cluster& b) {
  BvhNode n;
  n.child[0] = BvhChild{a.box.lower, a.id, a.box.upper, a.size};
  n.child[1] = BvhChild{b.box.lower, b.id, b.box.upper, b.size};
  s.nodes[node] = n;
  // A part of at most kHplocLeafTriangles is one piece; a larger one counts its parts'.
  const uint32_t pieces = (a.size <= kHplocLeafTriangles ? 1u : a.pieces) +
                          (b.size <= kHplocLeafTriangles ? 1u : b.pieces);
  const Cluster joined{merge(a.box, b.box), node, a.size + b.size, pieces};
  s.node_boxes[node] = joined.box;
  s.node_sizes[node] = joined.size;
  s.leaf_pieces[node] = pieces;
  return joined;
}

// The next step up for a thread holding [l, r]: false when it is the first child to reach the
// parent, which the sibling then finishes; else the range grows to the parent's and `split` is
// the first position of its right child. As bvh_build.h's climb.
CAUSTICA_HDI bool climb_to_parent(const ClimbState& s, uint32_t& l, uint32_t& r, uint32_t& split) {
  const uint32_t last = s.count - 1;
  if (l == 0 || (r != last && detail::split_key(s.codes, r) < detail::split_key(s.codes, l - 1))) {
    const uint32_t seen = atomic_exchange(&s.other_end[r], l);
    if (seen == detail::kUnvisited) return false;
    split = r + 1;
    r = seen;
  } else {
    const uint32_t seen = atomic_exchange(&s.other_end[l - 1], r);
    if (seen == detail::kUnvisited) return false;
    split = l;
    l = seen;
  }
  return true;
}

#if !defined(__CUDA_ARCH__)

// The clusters of [first, end) into `out`; returns how many.
uint32_t load_clusters(const ClimbState& s, uint32_t first, uint32_t end, Cluster* out) {
  const uint32_t n = end - first < kHplocMaxClusters ? end - first : kHplocMaxClusters;
  uint32_t k = 0;
  for (; k < n; ++k) {
    const uint32_t id = s.clusters[first + k];
    if (id == kNoCluster) break;
    out[k] = cluster_of(s, id);
  }
  return k;
}

// PLOC rounds over c[0, count) until at most `target` clusters remain, in the order a warp runs
// them (merge_clusters_in_warp): nearest neighbours, then mutual pairs joined at the first's
// place, then the rest closed up in order.
uint32_t merge_clusters(const ClimbState& s, Cluster* c, uint32_t count, uint32_t target) {
  uint32_t nearest[2 * kHplocMaxClusters];
  while (count > target) {
    for (uint32_t i = 0; i < count; ++i) {
      uint64_t best = ~uint64_t(0);
      const uint32_t lo = i > kHplocSearchRadius ? i - kHplocSearchRadius : 0;
      const uint32_t hi = i + kHplocSearchRadius < count ? i + kHplocSearchRadius : count - 1;
      for (uint32_t j = lo; j <= hi; ++j) {
        if (j == i) continue;
        const uint64_t key =
            i < j ? pair_key(c[i].box, c[j].box, i, j) : pair_key(c[j].box, c[i].box, j, i);
        if (key < best) {
          best = key;
          nearest[i] = j;
        }
      }
    }
    uint32_t kept = 0;
    for (uint32_t i = 0; i < count; ++i) {
      const uint32_t j = nearest[i];
      if (nearest[j] != i) {
        c[kept++] = c[i];
      } else if (i < j) {
        // c[j] lies after i, so it is not yet overwritten.
        c[kept++] = join(s, atomic_fetch_add(s.node_count, 1), c[i], c[j]);
      }
    }
    count = kept;
  }
  return count;
}

void climb_serial(const ClimbState& s, uint32_t leaf) {
  uint32_t l = leaf, r = leaf, split = 0;
  Cluster c[2 * kHplocMaxClusters];
  while (climb_to_parent(s, l, r, split)) {
    const uint32_t size = r - l + 1;
    const bool root = size == s.count;
    if (size > kHplocMaxClusters || root) {
      uint32_t count = load_clusters(s, l, split, c);
      count += load_clusters(s, split, r + 1, c + count);
      count = merge_clusters(s, c, count, root ? 1 : kHplocMaxClusters);
      for (uint32_t k = 0; k < count; ++k) s.clusters[l + k] = c[k].id;
      if (count < size) s.clusters[l + count] = kNoCluster;
      if (root) *s.root = c[0].id;
    }
    if (root) return;
  }
}

#else

constexpr unsigned kWholeWarp = 0xffffffffu;

__device__ __forceinline__ Cluster shuffle_cluster(const Cluster& c, int source) {
  return detail::shuffle_words(kWholeWarp, c, source);
}

// merge_clusters with lane k holding cluster k of c[0, count).
__device__ uint32_t merge_clusters_in_warp(const ClimbState& s, Cluster& c, uint32_t count,
                                           uint32_t target, uint32_t lane) {
  while (count > target) {
    const bool holds = lane < count;
    uint64_t best = ~uint64_t(0);
    uint32_t nearest = lane;
    for (uint32_t d = 1; d <= kHplocSearchRadius; ++d) {
      // Each pair's key is computed once, by its first lane, and handed up to the second.
      Aabb after;
      after.lower.x = __shfl_down_sync(kWholeWarp, c.box.lower.x, d);
      after.lower.y = __shfl_down_sync(kWholeWarp, c.box.lower.y, d);
      after.lower.z = __shfl_down_sync(kWholeWarp, c.box.lower.z, d);
      after.upper.x = __shfl_down_sync(kWholeWarp, c.box.upper.x, d);
      after.upper.y = __shfl_down_sync(kWholeWarp, c.box.upper.y, d);
      after.upper.z = __shfl_down_sync(kWholeWarp, c.box.upper.z, d);
      const bool pair = lane + d < count;
      const uint64_t key = pair ? pair_key(c.box, after, lane, lane + d) : ~uint64_t(0);
      if (key < best) {
        best = key;
        nearest = lane + d;
      }
      const uint64_t from_before = __shfl_up_sync(kWholeWarp, key, d);
      if (lane >= d && holds && from_before < best) {
        best = from_before;
        nearest = lane - d;
      }
    }
    const uint32_t nearest_of_nearest = __shfl_sync(kWholeWarp, nearest, nearest & 31u);
    const bool mutual = holds && nearest_of_nearest == lane;
    const bool joins = mutual && lane < nearest;
    const Cluster partner = shuffle_cluster(c, int(nearest & 31u));
    const unsigned joining = __ballot_sync(kWholeWarp, joins);
    uint32_t first_node = 0;
    if (lane == uint32_t(__ffs(joining) - 1)) first_node = atomicAdd(s.node_count, __popc(joining));
    first_node = __shfl_sync(kWholeWarp, first_node, __ffs(joining) - 1);
    if (joins) c = join(s, first_node + __popc(joining & ((1u << lane) - 1u)), c, partner);
    const unsigned kept = __ballot_sync(kWholeWarp, holds && !(mutual && lane > nearest));
    count = __popc(kept);
    c = shuffle_cluster(c, lane < count ? detail::nth_set_lane(kept, int(lane)) : int(lane));
  }
  return count;
}

// The whole warp climbs together: every lane's thread climbs as climb_serial does, and each range
// that needs merging is merged by all 32 lanes, one range after another.
__device__ void climb_in_warp(const ClimbState& s, uint32_t leaf) {
  uint32_t lane;
  asm("mov.u32 %0, %%laneid;" : "=r"(lane));
  uint32_t l = leaf, r = leaf, split = 0;
  bool climbing = leaf < s.count;
  while (__any_sync(kWholeWarp, climbing)) {
    if (climbing) climbing = climb_to_parent(s, l, r, split);
    const uint32_t size = r - l + 1;
    const bool root = climbing && size == s.count;
    if (root) climbing = false;
    unsigned pending = __ballot_sync(kWholeWarp, climbing && size > kHplocMaxClusters || root);
    // Orders the ranges' loads after the exchanges that made them this warp's to merge.
    __syncwarp();
    while (pending != 0) {
      const int owner = __ffs(pending) - 1;
      pending &= pending - 1;
      const uint32_t first = __shfl_sync(kWholeWarp, l, owner);
      const uint32_t last = __shfl_sync(kWholeWarp, r, owner);
      const uint32_t middle = __shfl_sync(kWholeWarp, split, owner);
      const bool whole = __shfl_sync(kWholeWarp, root, owner);
      // Lane k reads cluster k of each half.
      const uint32_t left_end =
          middle - first < kHplocMaxClusters ? middle - first : kHplocMaxClusters;
      const uint32_t right_end =
          last + 1 - middle < kHplocMaxClusters ? last + 1 - middle : kHplocMaxClusters;
      const uint32_t left_id = lane < left_end ? __ldcg(s.clusters + first + lane) : kNoCluster;
      const uint32_t right_id = lane < right_end ? __ldcg(s.clusters + middle + lane) : kNoCluster;
      const uint32_t left_count = __ffs(~__ballot_sync(kWholeWarp, left_id != kNoCluster)) - 1;
      const uint32_t right_count = __ffs(~__ballot_sync(kWholeWarp, right_id != kNoCluster)) - 1;
      const uint32_t from_right = __shfl_sync(kWholeWarp, right_id, int((lane - left_count) & 31u));
      uint32_t count = left_count + right_count;
      const uint32_t id = lane < left_count ? left_id : from_right;
      Cluster c{Aabb{}, id, 0, 0};
      if (lane < count) c = cluster_of(s, id);
      count = merge_clusters_in_warp(s, c, count, whole ? 1 : kHplocMaxClusters, lane);
      if (lane < count) s.clusters[first + lane] = c.id;
      if (lane == 0 && count < last - first + 1) s.clusters[first + count] = kNoCluster;
      if (whole && lane == 0) *s.root = c.id;
      // Publishes the clusters and nodes before the owner's next exchange hands them on.
      __threadfence();
      __syncwarp();
    }
  }
}

#endif

}  // namespace

ClusteredTriangleBvh build_hploc_bvh(Backend& backend, const TriangleVertices* triangles,
                                     uint32_t count, Curve curve) {
  ClusteredTriangleBvh out;
  out.nodes.bind(backend);
  out.leaf_pieces.bind(backend);
  out.triangles.bind(backend);
  out.triangle_ids.bind(backend);
  out.count = count;
  if (count == 0) return out;

  Buffer<Aabb> boxes(backend, count);
  Buffer<BvhSummary> summary(backend, 1);
  {
    Aabb* box = boxes.data();
    parallel_for(backend, "hploc_triangle_boxes", count,
                 [=] CAUSTICA_HD(size_t i) { box[i] = triangle_bounds(triangles[i]); });
  }
  backend.reduce_bounds_to(boxes.data(), count, &summary.data()->bounds);
  CurveOrder order = sort_by_curve(backend, boxes.data(), count, &summary.data()->bounds, curve);
  out.triangle_ids = std::move(order.order);

  // The triangles and their boxes in curve order; the boxes are the leaves' clusters.
  out.triangles.resize_discard(count);
  Buffer<Aabb> leaf_boxes(backend, count);
  Buffer<uint32_t> clusters(backend, count);
  {
    const uint32_t* ids = out.triangle_ids.data();
    TriangleVertices* sorted = out.triangles.data();
    Aabb* leaf_box = leaf_boxes.data();
    const Aabb* box = boxes.data();
    uint32_t* cluster = clusters.data();
    parallel_for(backend, "hploc_sort_leaves", count, [=] CAUSTICA_HD(size_t i) {
      sorted[i] = triangles[ids[i]];
      leaf_box[i] = box[ids[i]];
      cluster[i] = kLeafFlag | uint32_t(i);
    });
  }
  if (count == 1) {
    backend.copy_to_host(&out.bounds, &summary.data()->bounds, sizeof(Aabb));
    out.root = kLeafFlag;
    return out;
  }

  out.nodes.resize_discard(count - 1);
  Buffer<Aabb> node_boxes(backend, count - 1);
  Buffer<uint32_t> node_sizes(backend, count - 1);
  out.leaf_pieces.resize_discard(count - 1);
  Buffer<uint32_t> other_end(backend, count - 1);
  backend.fill_bytes(other_end.data(), 0xff, other_end.bytes());
  backend.fill_bytes(&summary.data()->root, 0, sizeof(uint32_t));
  // The node counter lives in the summary's spare word: one copy brings back bounds and root.
  Buffer<uint32_t> node_count(backend, 1);
  backend.fill_bytes(node_count.data(), 0, sizeof(uint32_t));
  const ClimbState state{order.codes.data(),
                         leaf_boxes.data(),
                         other_end.data(),
                         clusters.data(),
                         out.nodes.data(),
                         node_boxes.data(),
                         node_sizes.data(),
                         out.leaf_pieces.data(),
                         node_count.data(),
                         &summary.data()->root,
                         count};
  // Whole warps on a GPU: the lanes past the last triangle help merge.
  const size_t threads =
      backend.kind() == DeviceKind::kCpu ? count : (size_t(count) + 31) / 32 * 32;
  parallel_for(backend, "hploc_climb", threads, [=] CAUSTICA_HD(size_t i) {
#if defined(__CUDA_ARCH__)
    climb_in_warp(state, uint32_t(i));
#else
    climb_serial(state, uint32_t(i));
#endif
  });
  BvhSummary s;
  backend.copy_to_host(&s, summary.data(), sizeof(BvhSummary));
  out.bounds = s.bounds;
  out.root = s.root;
  return out;
}

}  // namespace caustica
