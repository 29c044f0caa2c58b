#include "renderer/accel/sah_subtrees.h"

#include "renderer/accel/bvh4.h"
#include "renderer/base/atomic.h"
#include "renderer/base/uninitialized.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {
namespace {

// Bins per axis for the split candidates of a range.
constexpr int kSahBins = 16;

// A range of sorted positions, its box, and the slot that is to point to it.
struct PendingRange {
  uint32_t first, last;
  uint32_t parent, side;
  Aabb box;
};

// How a range splits: positions [first, mid] to the left, the rest to the right.
struct RangeSplit {
  uint32_t mid;
  Aabb left, right;
};

CAUSTICA_HDI Aabb bounds_of(const Aabb* box, uint32_t first, uint32_t last) {
  Aabb b;
  for (uint32_t p = first; p <= last; ++p) b.extend(box[p]);
  return b;
}

// The bin (of `bins`) of centroid coordinate c along an axis whose centroids span
// [low, low + bins / scale].
CAUSTICA_HDI int bin_of(float c, float low, float scale, int bins) {
  const int b = int((c - low) * scale);
  return b < 0 ? 0 : b < bins ? b : bins - 1;
}

// The cheapest split of positions [first, last] between two of `bins` bins along `axis`: sets
// `cost` and `bin` (the last bin of the left side) when it beats `cost`.
CAUSTICA_HDI void best_split_along(const Aabb* box, uint32_t first, uint32_t last, int axis,
                                   float low, float scale, int bins, float& cost, int& bin) {
  uint32_t count[kSahBins];
  Uninitialized<Aabb, kSahBins> bounds;
  for (int i = 0; i < bins; ++i) {
    count[i] = 0;
    bounds.item[i] = Aabb{};
  }
  for (uint32_t p = first; p <= last; ++p) {
    const Aabb b = box[p];
    const int i = bin_of(b.center()[axis], low, scale, bins);
    ++count[i];
    bounds.item[i].extend(b);
  }
  // right_area[i], right_count[i]: the bins from i on.
  float right_area[kSahBins];
  uint32_t right_count[kSahBins];
  Aabb right;
  uint32_t right_total = 0;
  for (int i = bins - 1; i > 0; --i) {
    right.extend(bounds.item[i]);
    right_total += count[i];
    right_area[i] = right.half_area();
    right_count[i] = right_total;
  }
  Aabb left;
  uint32_t left_count = 0;
  for (int i = 0; i + 1 < bins; ++i) {
    left.extend(bounds.item[i]);
    left_count += count[i];
    if (left_count == 0 || right_count[i + 1] == 0) continue;
    const float c =
        float(left_count) * left.half_area() + float(right_count[i + 1]) * right_area[i + 1];
    if (c < cost) {
      cost = c;
      bin = i;
    }
  }
}

// Positions [first, mid] on the left, [mid + 1, last] on the right, with their bounds.
CAUSTICA_HDI RangeSplit split_at(const Aabb* box, uint32_t first, uint32_t mid, uint32_t last) {
  return {mid, bounds_of(box, first, mid), bounds_of(box, mid + 1, last)};
}

// The split in the middle, in the order the range has: for a range the collapse turns into one
// leaf whatever its inner splits (always_one_leaf), where SAH splits change nothing a ray meets but
// the order of a leaf's triangles and each costs a binning's fixed setup, and for one whose
// centroids all fall in one bin.
CAUSTICA_HDI RangeSplit split_in_middle(const Aabb* box, uint32_t first, uint32_t last) {
  return split_at(box, first, first + (last - first + 1) / 2 - 1, last);
}

// Splits positions [first, last] (at least two) where the binned SAH cost (left count x left area +
// right count x right area) is least, reordering their boxes and `order` alike so that the left
// side comes first; where every centroid falls in one bin on every axis, in the middle. One axis
// at a time, in a few hundred bytes: on a GPU every thread's arrays live in local memory, and
// bins for all three axes at once (1.8 KB a thread) went through L2 at every level.
CAUSTICA_HDI RangeSplit split_range(Aabb* box, uint32_t* order, uint32_t first, uint32_t last) {
  if (last == first + 1) return {first, box[first], box[last]};  // the only split there is
  Aabb centroids;
  for (uint32_t p = first; p <= last; ++p) centroids.extend(box[p].center());
  // No more bins than triangles: most ranges are small, and there the bins' setup and sweeps
  // would cost more than the binning.
  const uint32_t size = last - first + 1;
  const int bins = size < uint32_t(kSahBins) ? int(size) : kSahBins;
  float best_cost = INFINITY, best_low = 0.0f, best_scale = 0.0f;
  int best_axis = -1, best_bin = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const float low = centroids.lower[axis], extent = centroids.upper[axis] - low;
    if (!(extent > 0.0f)) continue;
    const float scale = float(bins) / extent;
    const float before = best_cost;
    best_split_along(box, first, last, axis, low, scale, bins, best_cost, best_bin);
    if (best_cost < before) {
      best_axis = axis;
      best_low = low;
      best_scale = scale;
    }
  }
  if (best_axis < 0) return split_in_middle(box, first, last);
  // In place: the left side's positions to the front (each side has at least one).
  auto goes_left = [&](uint32_t p) {
    return bin_of(box[p].center()[best_axis], best_low, best_scale, bins) <= best_bin;
  };
  uint32_t i = first, j = last;
  while (true) {
    while (goes_left(i)) ++i;
    while (!goes_left(j)) --j;
    if (i > j) break;
    const uint32_t t = order[i];
    order[i] = order[j];
    order[j] = t;
    const Aabb b = box[i];
    box[i] = box[j];
    box[j] = b;
  }
  return split_at(box, first, i - 1, last);
}

// Points the slot of range `r` (a child of r.parent, or the root) at `index`.
CAUSTICA_HDI void point_slot(BvhNode* nodes, uint32_t* root, const PendingRange& r,
                             uint32_t index) {
  if (r.parent == kNoParent) {
    *root = index;
  } else {
    nodes[r.parent].child[r.side] = BvhChild{r.box.lower, index, r.box.upper};
  }
}

// Ranges of at most this many triangles are split all the way down by the thread that meets
// them, the smaller half first so that at most log2 of it wait. Level by level, each of the last
// levels would cost a launch, a scan and a wait on the host for little work.
constexpr uint32_t kRangeFinishedAlone = 16;
constexpr int kWaitingRanges = 5;
static_assert(kRangeFinishedAlone <= (1u << (kWaitingRanges - 1)), "room for the waiting halves");

CAUSTICA_HDI bool finished_alone(const PendingRange& r) {
  return r.last - r.first < kRangeFinishedAlone;
}

// Splits `r` and its halves down to single triangles.
CAUSTICA_HDI void finish_range(BvhNode* nodes, uint32_t* root, Aabb* box, uint32_t* order,
                               const Aabb& bounds, PendingRange r) {
  PendingRange waiting[kWaitingRanges];
  int top = 0;
  while (true) {
    if (r.first == r.last) {
      point_slot(nodes, root, r, kLeafFlag | r.first);
      if (top == 0) return;
      r = waiting[--top];
      continue;
    }
    const RangeSplit split = always_one_leaf(r.last - r.first + 1, r.box, bounds)
                                 ? split_in_middle(box, r.first, r.last)
                                 : split_range(box, order, r.first, r.last);
    point_slot(nodes, root, r, split.mid);
    const PendingRange left{r.first, split.mid, split.mid, 0, split.left};
    const PendingRange right{split.mid + 1, r.last, split.mid, 1, split.right};
    const bool left_smaller = split.mid - r.first < r.last - split.mid - 1;
    waiting[top++] = left_smaller ? right : left;
    r = left_smaller ? left : right;
  }
}

}  // namespace

void rebuild_small_subtrees(Backend& backend, Bvh& bvh, const SmallSubtree* list, uint32_t count,
                            Buffer<TriangleVertices>& triangles, Buffer<uint32_t>& triangle_ids,
                            bool root_listed) {
  if (count == 0) return;
  const uint32_t n = bvh.leaf_count;
  Buffer<Aabb> boxes(backend, n);
  Buffer<uint32_t> orders(backend, n);
  Buffer<uint32_t> new_root(backend, 1);
  Aabb* box = boxes.data();
  uint32_t* order = orders.data();
  const TriangleVertices* tri = triangles.data();
  parallel_for(backend, "sah_subtree_boxes", n, [=] CAUSTICA_HD(size_t i) {
    box[i] = triangle_bounds(tri[i]);
    order[i] = uint32_t(i);
  });
  BvhNode* nodes = bvh.nodes.data();
  uint32_t* root = new_root.data();

  // Level by level over every subtree at once, a range per thread: one thread per subtree left
  // a GPU nearly idle behind each thread's chain of a few thousand dependent steps.
  Buffer<PendingRange> ranges(backend, count), next_ranges(backend, 0);
  PendingRange* start = ranges.data();
  const Aabb bounds = bvh.bounds;
  parallel_for(backend, "sah_subtree_ranges", count, [=] CAUSTICA_HD(size_t i) {
    const SmallSubtree s = list[i];
    const Aabb s_box = s.parent == kNoParent ? bounds : nodes[s.parent].child[s.side].bounds();
    start[i] = {s.first, s.last, s.parent, s.side, s_box};
  });
  // Each range larger than kRangeFinishedAlone leaves its two halves to the next level, in range
  // order.
  Buffer<PendingRange> halves(backend, 0);
  Buffer<uint32_t> continuing(backend, 0);
  uint32_t level_size = count;
  while (level_size > 0) {
    halves.resize_discard(2 * size_t(level_size));
    continuing.resize_discard(level_size);
    const PendingRange* range = ranges.data();
    PendingRange* half = halves.data();
    uint32_t* more = continuing.data();
    parallel_for(backend, "sah_subtree_level", level_size, [=] CAUSTICA_HD(size_t i) {
      const PendingRange r = range[i];
      if (finished_alone(r)) {
        finish_range(nodes, root, box, order, bounds, r);
        more[i] = 0;
        return;
      }
      const RangeSplit split = split_range(box, order, r.first, r.last);
      point_slot(nodes, root, r, split.mid);
      half[2 * i] = {r.first, split.mid, split.mid, 0, split.left};
      half[2 * i + 1] = {split.mid + 1, r.last, split.mid, 1, split.right};
      more[i] = 2;
    });
    const uint32_t next_size = backend.exclusive_scan(more, more, level_size);
    next_ranges.resize_discard(next_size);
    PendingRange* next = next_ranges.data();
    parallel_for(backend, "sah_subtree_next_level", level_size, [=] CAUSTICA_HD(size_t i) {
      if (finished_alone(range[i])) return;
      next[more[i]] = half[2 * i];
      next[more[i] + 1] = half[2 * i + 1];
    });
    std::swap(ranges, next_ranges);
    level_size = next_size;
  }

  // The triangles and their ids in the new leaf order.
  Buffer<TriangleVertices> moved(backend, n);
  Buffer<uint32_t> moved_ids(backend, n);
  TriangleVertices* to = moved.data();
  uint32_t* to_id = moved_ids.data();
  const uint32_t* id = triangle_ids.data();
  parallel_for(backend, "sah_subtree_reorder", n, [=] CAUSTICA_HD(size_t i) {
    to[i] = tri[order[i]];
    to_id[i] = id[order[i]];
  });
  triangles = std::move(moved);
  triangle_ids = std::move(moved_ids);
  if (root_listed) backend.copy_to_host(&bvh.root, root, sizeof(uint32_t));
}

}  // namespace caustica
