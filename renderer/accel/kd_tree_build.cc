// The kd-tree build (kd_tree.h), breadth-first, every step a launch over the nodes or the
// triangle references of one level (Zhou, Hou, Wang and Guo 2008; Shi 2011):
// - a node of more than kKdLargeNode references is cut by Zhou's rule: an empty-space cut where
//   the references' tight box leaves more than kEmptyCutShare of the cell's extent empty on one
//   side, else the spatial median of the cell's longest axis;
// - a smaller one takes the exact minimum of its cost over all split candidates, swept by one
//   thread per node over its events (Wald and Havran 2006): per axis the start and end of each
//   reference's box and a planar event for boxes flat on that axis, sorted by one radix sort for
//   all of the level's small nodes, ends before planar events before starts at one position;
// - every reference is classified left, right or both, the children's lists are compacted by
//   scans, and a reference going to a child has its box clipped to the child's cell, so that the
//   child's events are its own.
// Every decision is an exact float operation or a comparison, and the sums are in a fixed order
// per node, so both backends build the same tree.
#include <cfloat>
#include <cmath>
#include <vector>

#include "renderer/accel/kd_cost.h"
#include "renderer/accel/kd_tree.h"
#include "renderer/base/atomic.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {
namespace {

// Zhou's empty-space cut: a side of the cell whose empty part is more than this share of the
// cell's extent on the axis is cut off.
constexpr float kEmptyCutShare = 0.25f;

// References per thread when the large nodes' tight boxes are reduced (a run of one node's
// references costs one set of atomics).
constexpr uint32_t kBoundsChunk = 64;

// A node of the level being split: its cell, its references [first, first + count) of the
// level's list, and whether Zhou's large-node rules split it.
struct BuildNode {
  Aabb cell;
  uint32_t first, count;
  uint32_t large;
};

// A node's decision: a leaf (axis -1) or a split plane, with the side planar references on the
// plane go to, and whether it was an empty-space cut.
struct SplitChoice {
  int axis;
  float position;
  uint32_t planar_left;
  uint32_t empty_cut;
};

enum EventType : uint32_t { kEnd = 0, kPlanar = 1, kStart = 2 };
constexpr int kEventAxisShift = 34;
constexpr int kEventNodeShift = 36;

CAUSTICA_HDI float normalized(float x) { return x == 0.0f ? 0.0f : x; }  // -0 sorts as +0

CAUSTICA_HDI uint64_t event_key(uint32_t node, int axis, float position, EventType type) {
  return uint64_t(node) << kEventNodeShift | uint64_t(axis) << kEventAxisShift |
         uint64_t(ordered_bits(normalized(position))) << 2 | uint64_t(type);
}

CAUSTICA_HDI int bits_for(uint32_t values) {
  int bits = 0;
  while (bits < 32 && (uint64_t(1) << bits) < values) ++bits;
  return bits;
}

// The cheapest split of a small node by its sorted events `keys[begin, end)` (all three axes),
// or a leaf when none costs less than testing every reference.
CAUSTICA_HDI SplitChoice sweep_events(const BuildNode& node, const uint64_t* keys, uint32_t begin,
                                      uint32_t end, const KdCostParameters& k, bool siroh,
                                      const Aabb& scene, float scene_volume) {
  SplitChoice best{-1, 0.0f, 1u, 0u};
  const uint32_t n = node.count;
  if (n <= k.leaf_size || n == 0) return best;
  float best_cost = k.intersection * float(n);
  uint32_t i = begin;
  while (i < end) {
    const int axis = int((keys[i] >> kEventAxisShift) & 3u);
    const ChildProbabilities prob =
        child_probabilities(siroh, node.cell, axis, scene, scene_volume);
    uint32_t left = 0, right = n;
    while (i < end && int((keys[i] >> kEventAxisShift) & 3u) == axis) {
      const uint64_t plane = keys[i] >> 2;
      uint32_t ending = 0, planar = 0, starting = 0;
      while (i < end && keys[i] >> 2 == plane && (keys[i] & 3u) == kEnd) ++ending, ++i;
      while (i < end && keys[i] >> 2 == plane && (keys[i] & 3u) == kPlanar) ++planar, ++i;
      while (i < end && keys[i] >> 2 == plane && (keys[i] & 3u) == kStart) ++starting, ++i;
      right -= planar + ending;
      const float position = from_ordered_bits(uint32_t(plane));
      if (prob.lower < position && position < prob.upper) {
        float p_left, p_right;
        prob.at(position, p_left, p_right);
        // Planar references on the plane go to the side where they cost less.
        for (uint32_t planar_left = 0; planar_left < 2; ++planar_left) {
          const uint32_t n_left = left + (planar_left ? planar : 0);
          const uint32_t n_right = right + (planar_left ? 0 : planar);
          float cost =
              k.traversal + k.intersection * (p_left * float(n_left) + p_right * float(n_right));
          const float left_share = (position - prob.lower) / prob.extent;
          if ((n_left == 0 && left_share > k.empty_volume_share) ||
              (n_right == 0 && 1.0f - left_share > k.empty_volume_share)) {
            cost *= 1.0f - k.empty_bonus;
          }
          if (cost < best_cost) {
            best_cost = cost;
            best = {axis, position, planar_left, 0u};
          }
        }
      }
      left += starting + planar;
    }
  }
  return best;
}

// Zhou's split of a large node whose references' boxes span `tight` inside its cell.
CAUSTICA_HDI SplitChoice large_node_split(const BuildNode& node, const Aabb& tight) {
  const Vec3f e = node.cell.extent();
  SplitChoice best{-1, 0.0f, 1u, 0u};
  float best_share = kEmptyCutShare;
  for (int a = 0; a < 3; ++a) {
    if (!(e[a] > 0.0f)) continue;
    const float below = (tight.lower[a] - node.cell.lower[a]) / e[a];
    const float above = (node.cell.upper[a] - tight.upper[a]) / e[a];
    // Planar references on the cut stay with the others.
    if (below > best_share) {
      best_share = below;
      best = {a, tight.lower[a], 0u, 1u};
    }
    if (above > best_share) {
      best_share = above;
      best = {a, tight.upper[a], 1u, 1u};
    }
  }
  if (best.axis >= 0) return best;
  const int a = e.x >= e.y && e.x >= e.z ? 0 : e.y >= e.z ? 1 : 2;
  const float median = node.cell.lower[a] + 0.5f * e[a];
  if (node.cell.lower[a] < median && median < node.cell.upper[a]) best = {a, median, 1u, 0u};
  return best;
}

// Which children of a split get a reference whose box is `box`: bit 0 below, bit 1 above.
CAUSTICA_HDI uint32_t sides_of(const Aabb& box, const SplitChoice& s) {
  const float lo = box.lower[s.axis], hi = box.upper[s.axis];
  if (lo == s.position && hi == s.position) return s.planar_left ? 1u : 2u;
  if (hi <= s.position) return 1u;
  if (lo >= s.position) return 2u;
  return 3u;
}

CAUSTICA_HDI Aabb child_cell(const Aabb& cell, const SplitChoice& s, uint32_t side) {
  Aabb c = cell;
  if (side == 0) {
    c.upper[s.axis] = s.position;
  } else {
    c.lower[s.axis] = s.position;
  }
  return c;
}

CAUSTICA_HDI Aabb clipped(Aabb box, const Aabb& cell) {
  box.lower = max(box.lower, cell.lower);
  box.upper = min(box.upper, cell.upper);
  return box;
}

// What one level's launches write and the next level reads.
struct LevelRefs {
  Buffer<uint32_t> triangle;
  Buffer<Aabb> box;
  Buffer<uint32_t> node;  // the reference's node in the level's list
};

// One level as its launches see it: its `K` nodes and the `m` references of their lists, each with
// its triangle, its box clipped to its node's cell, and its node.
struct KdLevel {
  const BuildNode* nodes;
  uint32_t K, m;
  const uint32_t* ref_tri;
  const Aabb* ref_box;
  const uint32_t* ref_node;
  bool last;  // at the depth limit, where every node becomes a leaf
};

// What a small node's sweep prices its splits by.
struct SweepCost {
  KdCostParameters k;
  bool siroh;
  Aabb scene;
  float scene_volume;
};

// The buffers every level's launches reuse.
struct LevelScratch {
  explicit LevelScratch(Backend& backend)
      : tight_bits(backend, 0),
        event_counts(backend, 0),
        event_values(backend, 0),
        event_keys(backend, 0),
        choices(backend, 0),
        go_left(backend, 0),
        go_right(backend, 0),
        child_refs(backend, 0),
        child_nodes(backend, 0),
        leaf_refs(backend, 0) {}

  Buffer<uint32_t> tight_bits, event_counts, event_values;
  Buffer<uint64_t> event_keys;
  Buffer<SplitChoice> choices;
  Buffer<uint32_t> go_left, go_right;
  Buffer<uint32_t> child_refs, child_nodes, leaf_refs;
};

// Where a level's launches put what they write, as exclusive scans: per reference, the copies of
// the references before it going left and going right; per node, its children's first reference,
// its first child and its leaf's first reference.
struct Placement {
  const uint32_t* left;
  const uint32_t* right;
  const uint32_t* child_ref;
  const uint32_t* child_node;
  const uint32_t* leaf_ref;
};

// How much a level's children and leaves take.
struct ChildTotals {
  uint32_t refs, nodes, leaf_refs;
};

// The finished levels, concatenated at the end, and how many nodes and leaf references they hold.
struct FinishedLevels {
  std::vector<Buffer<KdNode>> nodes;
  std::vector<Buffer<float>> areas;
  std::vector<Buffer<uint32_t>> leaf_refs;
  size_t node_total = 0, leaf_ref_total = 0;
};

// The level after one: its nodes and their references.
struct NextLevel {
  Buffer<BuildNode> nodes;
  LevelRefs refs;
  uint32_t node_count, ref_count;
};

int max_leaf_depth(uint32_t count) {
  const int by_size = int(8.0 + 1.3 * std::log2(double(count)));
  return by_size < kKdMaxLeafDepth ? by_size : kKdMaxLeafDepth;
}

// The root's references, one a triangle of the `count` `triangles` with its box, and their bounds
// in `bounds`.
LevelRefs root_refs(Backend& backend, const TriangleVertices* triangles, uint32_t count,
                    Aabb& bounds) {
  LevelRefs refs{Buffer<uint32_t>(backend, count), Buffer<Aabb>(backend, count),
                 Buffer<uint32_t>(backend, count)};
  uint32_t* tri = refs.triangle.data();
  Aabb* box = refs.box.data();
  uint32_t* owner = refs.node.data();
  parallel_for(backend, "kd_root_refs", count, [=] CAUSTICA_HD(size_t i) {
    tri[i] = uint32_t(i);
    box[i] = triangle_bounds(triangles[i]);
    owner[i] = 0;
  });
  bounds = backend.reduce_bounds(box, count);
  return refs;
}

// The large nodes' tight boxes into `tight_bits`, six words a node, as ordered bits reduced by
// atomics over runs of references.
void reduce_tight_bounds(Backend& backend, const KdLevel& level, Buffer<uint32_t>& tight_bits) {
  const BuildNode* nodes = level.nodes;
  const uint32_t m = level.m;
  const Aabb* ref_box = level.ref_box;
  const uint32_t* ref_node = level.ref_node;
  tight_bits.resize_discard(size_t(level.K) * 6);
  uint32_t* tight = tight_bits.data();
  parallel_for(backend, "kd_clear_tight_bounds", level.K, [=] CAUSTICA_HD(size_t j) {
    for (int a = 0; a < 3; ++a) {
      tight[6 * j + a] = ordered_bits(FLT_MAX);
      tight[6 * j + 3 + a] = ordered_bits(-FLT_MAX);
    }
  });
  const size_t chunks = (size_t(m) + kBoundsChunk - 1) / kBoundsChunk;
  parallel_for(backend, "kd_tight_bounds", chunks, [=] CAUSTICA_HD(size_t c) {
    const uint32_t begin = uint32_t(c * kBoundsChunk);
    const uint32_t end = begin + kBoundsChunk < m ? begin + kBoundsChunk : m;
    uint32_t run_node = ref_node[begin];
    Aabb run;
    auto flush = [&] {
      if (!nodes[run_node].large || run.empty()) return;
      for (int a = 0; a < 3; ++a) {
        atomic_min(&tight[6 * run_node + a], ordered_bits(run.lower[a]));
        atomic_max(&tight[6 * run_node + 3 + a], ordered_bits(run.upper[a]));
      }
    };
    for (uint32_t i = begin; i < end; ++i) {
      if (ref_node[i] != run_node) {
        flush();
        run_node = ref_node[i];
        run = Aabb{};
      }
      run.extend(ref_box[i]);
    }
    flush();
  });
}

// Where each reference's events start among the small nodes' events (one planar or a start and
// an end event per axis), an exclusive scan into `event_counts` (m + 1 entries); returns how many
// events there are.
uint32_t count_events(Backend& backend, const KdLevel& level, const KdCostParameters& k,
                      Buffer<uint32_t>& event_counts) {
  const BuildNode* nodes = level.nodes;
  const uint32_t m = level.m;
  const Aabb* ref_box = level.ref_box;
  const uint32_t* ref_node = level.ref_node;
  const bool last_level = level.last;
  event_counts.resize_discard(size_t(m) + 1);
  uint32_t* event_count = event_counts.data();
  parallel_for(backend, "kd_count_events", size_t(m) + 1, [=] CAUSTICA_HD(size_t i) {
    uint32_t events = 0;
    // Nodes too small to split (kd-siroh's n <= 4) need no events.
    const BuildNode* n = i < m ? &nodes[ref_node[i]] : nullptr;
    if (n != nullptr && !last_level && !n->large && n->count > k.leaf_size) {
      for (int a = 0; a < 3; ++a) events += ref_box[i].lower[a] == ref_box[i].upper[a] ? 1u : 2u;
    }
    event_count[i] = events;
  });
  return backend.exclusive_scan(event_count, event_count, size_t(m) + 1);
}

// The `total_events` small nodes' events, placed by `event_count` (count_events) and sorted by
// (node, axis, position, type), into `event_keys` with their references in `event_values`.
// Sorting them again at every level is simpler than Shi's order-preserving split of the sorted
// lists, and costs more.
void write_sorted_events(Backend& backend, const KdLevel& level, const uint32_t* event_count,
                         uint32_t total_events, Buffer<uint64_t>& event_keys,
                         Buffer<uint32_t>& event_values) {
  const Aabb* ref_box = level.ref_box;
  const uint32_t* ref_node = level.ref_node;
  event_keys.resize_discard(total_events);
  event_values.resize_discard(total_events);
  uint64_t* key = event_keys.data();
  uint32_t* value = event_values.data();
  parallel_for(backend, "kd_write_events", level.m, [=] CAUSTICA_HD(size_t i) {
    uint32_t at = event_count[i];
    if (event_count[i + 1] == at) return;
    const Aabb b = ref_box[i];
    const uint32_t j = ref_node[i];
    for (int a = 0; a < 3; ++a) {
      if (b.lower[a] == b.upper[a]) {
        value[at] = uint32_t(i);
        key[at++] = event_key(j, a, b.lower[a], kPlanar);
      } else {
        value[at] = uint32_t(i);
        key[at++] = event_key(j, a, b.lower[a], kStart);
        value[at] = uint32_t(i);
        key[at++] = event_key(j, a, b.upper[a], kEnd);
      }
    }
  });
  backend.sort_pairs(key, value, total_events, kEventNodeShift + bits_for(level.K));
}

// Each node's decision into `choice`: a large node's by Zhou's rules from its tight box
// (`tight`), a small node's by the sweep over its sorted events (`key`, placed by `event_count`).
void choose_splits(Backend& backend, const KdLevel& level, const uint32_t* tight,
                   const uint32_t* event_count, const uint64_t* key, const SweepCost& cost,
                   SplitChoice* choice) {
  const BuildNode* nodes = level.nodes;
  const bool last_level = level.last;
  const KdCostParameters k = cost.k;
  const bool siroh = cost.siroh;
  const Aabb scene = cost.scene;
  const float scene_volume = cost.scene_volume;
  parallel_for(backend, "kd_choose_splits", level.K, [=] CAUSTICA_HD(size_t j) {
    const BuildNode n = nodes[j];
    SplitChoice s{-1, 0.0f, 1u, 0u};
    if (!last_level && n.count > 0) {
      if (n.large) {
        Aabb t;
        for (int a = 0; a < 3; ++a) {
          t.lower[a] = from_ordered_bits(tight[6 * j + a]);
          t.upper[a] = from_ordered_bits(tight[6 * j + 3 + a]);
        }
        s = large_node_split(n, t);
      } else {
        // The node's events, in the sorted order, span what its references' counts did.
        s = sweep_events(n, key, event_count[n.first], event_count[n.first + n.count], k, siroh,
                         scene, scene_volume);
      }
    }
    choice[j] = s;
  });
}

// Each reference's sides, as exclusive scans over the references going left (`left`) and going
// right (`right`), m + 1 entries each.
void classify_refs(Backend& backend, const KdLevel& level, const SplitChoice* choice,
                   uint32_t* left, uint32_t* right) {
  const uint32_t m = level.m;
  const Aabb* ref_box = level.ref_box;
  const uint32_t* ref_node = level.ref_node;
  parallel_for(backend, "kd_classify", size_t(m) + 1, [=] CAUSTICA_HD(size_t i) {
    uint32_t sides = 0;
    if (i < m) {
      const SplitChoice s = choice[ref_node[i]];
      if (s.axis >= 0) sides = sides_of(ref_box[i], s);
    }
    left[i] = sides & 1u;
    right[i] = sides >> 1;
  });
  backend.exclusive_scan(left, left, size_t(m) + 1);
  backend.exclusive_scan(right, right, size_t(m) + 1);
}

// Per node, where its children's references, its children and its leaf's references start, as
// exclusive scans into `child_ref`, `child_node` and `leaf_ref` (K + 1 entries each) of the counts
// from its choice and its references' sides (`left`, `right`); returns the totals.
ChildTotals count_children(Backend& backend, const KdLevel& level, const SplitChoice* choice,
                           const uint32_t* left, const uint32_t* right, uint32_t* child_ref,
                           uint32_t* child_node, uint32_t* leaf_ref) {
  const BuildNode* nodes = level.nodes;
  const uint32_t K = level.K;
  parallel_for(backend, "kd_child_counts", size_t(K) + 1, [=] CAUSTICA_HD(size_t j) {
    child_ref[j] = child_node[j] = leaf_ref[j] = 0;
    if (j == K) return;
    const BuildNode n = nodes[j];
    if (choice[j].axis >= 0) {
      const uint32_t end = n.first + n.count;
      child_ref[j] = left[end] - left[n.first] + right[end] - right[n.first];
      child_node[j] = 2;
    } else {
      leaf_ref[j] = n.count;
    }
  });
  const uint32_t refs = backend.exclusive_scan(child_ref, child_ref, size_t(K) + 1);
  const uint32_t nodes_total = backend.exclusive_scan(child_node, child_node, size_t(K) + 1);
  const uint32_t leaf_total = backend.exclusive_scan(leaf_ref, leaf_ref, size_t(K) + 1);
  return {refs, nodes_total, leaf_total};
}

// The level's nodes in the kd layout into `out`, their cells' half areas into `area`, and the
// next level's nodes into `child`; the level's first child is node `first_child_base` of the tree
// and its first leaf reference `leaf_ref_base`.
void write_level_nodes(Backend& backend, const KdLevel& level, const SplitChoice* choice,
                       const Placement& place, uint32_t first_child_base, uint32_t leaf_ref_base,
                       KdNode* out, float* area, BuildNode* child) {
  const BuildNode* nodes = level.nodes;
  const uint32_t *left = place.left, *right = place.right;
  const uint32_t *child_ref = place.child_ref, *child_node = place.child_node;
  const uint32_t* leaf_ref = place.leaf_ref;
  parallel_for(backend, "kd_write_nodes", level.K, [=] CAUSTICA_HD(size_t j) {
    const BuildNode n = nodes[j];
    const SplitChoice s = choice[j];
    area[j] = n.cell.half_area();
    if (s.axis < 0) {
      out[j] = KdNode::leaf_of(leaf_ref_base + leaf_ref[j], n.count);
      return;
    }
    out[j] = KdNode::inner(s.axis, s.position, first_child_base + child_node[j]);
    const uint32_t end = n.first + n.count;
    const uint32_t counts[2] = {left[end] - left[n.first], right[end] - right[n.first]};
    uint32_t first = child_ref[j];
    for (uint32_t side = 0; side < 2; ++side) {
      const uint32_t c = counts[side];
      // A large child stays large while the median cut it to at most three quarters of its
      // parent's references (or it is the full side of an empty-space cut); else triangles
      // straddling every median would be copied into every node down to the depth limit, and
      // the SAH sweep, which prices the copies, decides instead.
      const bool large =
          n.large && c > kKdLargeNode && (s.empty_cut || 4 * uint64_t(c) <= 3 * uint64_t(n.count));
      child[child_node[j] + side] = {child_cell(n.cell, s, side), first, c, large ? 1u : 0u};
      first += c;
    }
  });
}

// The references: to the children in `next`, clipped to their cells, or into the level's leaves
// in `leaf_out`.
void scatter_refs(Backend& backend, const KdLevel& level, const SplitChoice* choice,
                  const Placement& place, uint32_t* leaf_out, LevelRefs& next) {
  const BuildNode* nodes = level.nodes;
  const uint32_t* ref_tri = level.ref_tri;
  const Aabb* ref_box = level.ref_box;
  const uint32_t* ref_node = level.ref_node;
  const uint32_t *left = place.left, *right = place.right;
  const uint32_t *child_ref = place.child_ref, *child_node = place.child_node;
  const uint32_t* leaf_ref = place.leaf_ref;
  uint32_t* next_tri = next.triangle.data();
  Aabb* next_box = next.box.data();
  uint32_t* next_owner = next.node.data();
  parallel_for(backend, "kd_scatter_refs", level.m, [=] CAUSTICA_HD(size_t i) {
    const uint32_t j = ref_node[i];
    const BuildNode n = nodes[j];
    const SplitChoice s = choice[j];
    if (s.axis < 0) {
      leaf_out[leaf_ref[j] + (uint32_t(i) - n.first)] = ref_tri[i];
      return;
    }
    const uint32_t left_count = left[n.first + n.count] - left[n.first];
    if (left[i + 1] != left[i]) {
      const uint32_t at = child_ref[j] + left[i] - left[n.first];
      next_tri[at] = ref_tri[i];
      next_box[at] = clipped(ref_box[i], child_cell(n.cell, s, 0));
      next_owner[at] = child_node[j];
    }
    if (right[i + 1] != right[i]) {
      const uint32_t at = child_ref[j] + left_count + right[i] - right[n.first];
      next_tri[at] = ref_tri[i];
      next_box[at] = clipped(ref_box[i], child_cell(n.cell, s, 1));
      next_owner[at] = child_node[j] + 1;
    }
  });
}

// Decides every node of `level` and writes what follows: the level's kd nodes, cell areas and
// leaf references, appended to `done`, and the next level, returned.
NextLevel split_level(Backend& backend, const KdLevel& level, const SweepCost& cost,
                      LevelScratch& scratch, FinishedLevels& done) {
  const uint32_t K = level.K, m = level.m;
  reduce_tight_bounds(backend, level, scratch.tight_bits);
  const uint32_t total_events = count_events(backend, level, cost.k, scratch.event_counts);
  if (total_events > 0) {
    write_sorted_events(backend, level, scratch.event_counts.data(), total_events,
                        scratch.event_keys, scratch.event_values);
  }
  scratch.choices.resize_discard(K);
  choose_splits(backend, level, scratch.tight_bits.data(), scratch.event_counts.data(),
                scratch.event_keys.data(), cost, scratch.choices.data());
  scratch.go_left.resize_discard(size_t(m) + 1);
  scratch.go_right.resize_discard(size_t(m) + 1);
  classify_refs(backend, level, scratch.choices.data(), scratch.go_left.data(),
                scratch.go_right.data());
  scratch.child_refs.resize_discard(size_t(K) + 1);
  scratch.child_nodes.resize_discard(size_t(K) + 1);
  scratch.leaf_refs.resize_discard(size_t(K) + 1);
  const ChildTotals totals = count_children(
      backend, level, scratch.choices.data(), scratch.go_left.data(), scratch.go_right.data(),
      scratch.child_refs.data(), scratch.child_nodes.data(), scratch.leaf_refs.data());
  const Placement place{scratch.go_left.data(), scratch.go_right.data(), scratch.child_refs.data(),
                        scratch.child_nodes.data(), scratch.leaf_refs.data()};

  Buffer<KdNode> written(backend, K);
  Buffer<float> areas(backend, K);
  NextLevel next{Buffer<BuildNode>(backend, totals.nodes), LevelRefs{}, totals.nodes, totals.refs};
  write_level_nodes(backend, level, scratch.choices.data(), place, uint32_t(done.node_total + K),
                    uint32_t(done.leaf_ref_total), written.data(), areas.data(), next.nodes.data());
  Buffer<uint32_t> leaf_list(backend, totals.leaf_refs);
  next.refs = LevelRefs{Buffer<uint32_t>(backend, totals.refs), Buffer<Aabb>(backend, totals.refs),
                        Buffer<uint32_t>(backend, totals.refs)};
  scatter_refs(backend, level, scratch.choices.data(), place, leaf_list.data(), next.refs);

  done.nodes.push_back(std::move(written));
  done.areas.push_back(std::move(areas));
  done.leaf_refs.push_back(std::move(leaf_list));
  done.node_total += K;
  done.leaf_ref_total += totals.leaf_refs;
  return next;
}

// The finished levels' nodes, cell areas and leaf references, one after another, into `tree`.
void concatenate_levels(Backend& backend, const FinishedLevels& done, KdTree& tree) {
  tree.nodes.resize_discard(done.node_total);
  tree.cell_half_areas.resize_discard(done.node_total);
  tree.refs.resize_discard(done.leaf_ref_total);
  size_t node_at = 0, ref_at = 0;
  for (size_t l = 0; l < done.nodes.size(); ++l) {
    const size_t n = done.nodes[l].size(), r = done.leaf_refs[l].size();
    backend.copy_on_device(tree.nodes.data() + node_at, done.nodes[l].data(), n * sizeof(KdNode));
    backend.copy_on_device(tree.cell_half_areas.data() + node_at, done.areas[l].data(),
                           n * sizeof(float));
    if (r > 0) {
      backend.copy_on_device(tree.refs.data() + ref_at, done.leaf_refs[l].data(),
                             r * sizeof(uint32_t));
    }
    node_at += n;
    ref_at += r;
  }
}

}  // namespace

KdTree build_kd_tree(Backend& backend, const TriangleVertices* triangles, uint32_t count,
                     KdCost cost) {
  KdTree tree;
  tree.nodes.bind(backend);
  tree.refs.bind(backend);
  tree.triangles.bind(backend);
  tree.cell_half_areas.bind(backend);
  tree.triangle_count = count;
  if (count == 0) return tree;
  tree.triangles.resize_discard(count);
  backend.copy_on_device(tree.triangles.data(), triangles,
                         size_t(count) * sizeof(TriangleVertices));

  LevelRefs refs = root_refs(backend, triangles, count, tree.bounds);
  const Aabb scene = tree.bounds;
  const Vec3f scene_extent = scene.extent();
  const float scene_volume = scene_extent.x * scene_extent.y * scene_extent.z;
  // SIROH's probabilities divide by the scene's volume and face areas: a flat scene falls back
  // to the SAH's.
  const bool siroh = cost == KdCost::kSiroh && scene_volume > 0.0f && std::isfinite(scene_volume);
  const SweepCost sweep{parameters_of(cost), siroh, scene, scene_volume};
  const int max_depth = max_leaf_depth(count);

  Buffer<BuildNode> level(backend, 1);
  level.upload(std::vector<BuildNode>{{scene, 0, count, count > kKdLargeNode ? 1u : 0u}});
  uint32_t node_count = 1, ref_count = count;
  FinishedLevels done;
  LevelScratch scratch(backend);
  for (int depth = 0; node_count > 0; ++depth) {
    const uint32_t K = node_count, m = ref_count;
    // Node indices fill 30 bits of a kd node and 28 of an event key.
    if (K >= (1u << (64 - kEventNodeShift)) || done.node_total + K >= (size_t(1) << 30)) {
      throw DeviceError("build_kd_tree: more nodes than the kd node layout can index");
    }
    const KdLevel l{
        level.data(),      K, m, refs.triangle.data(), refs.box.data(), refs.node.data(),
        depth >= max_depth};
    NextLevel next = split_level(backend, l, sweep, scratch, done);
    tree.depth = depth;
    level = std::move(next.nodes);
    refs = std::move(next.refs);
    node_count = next.node_count;
    ref_count = next.ref_count;
  }
  concatenate_levels(backend, done, tree);
  return tree;
}

double sah_cost(Backend& backend, const KdTree& tree) {
  const size_t n = tree.nodes.size();
  const float root_area = tree.bounds.half_area();
  if (n == 0 || !(root_area > 0.0f)) return double(tree.triangle_count);
  Buffer<float> terms(backend, n);
  float* term = terms.data();
  const KdNode* nodes = tree.nodes.data();
  const float* area = tree.cell_half_areas.data();
  const float inv_root = 1.0f / root_area;
  parallel_for(backend, "kd_sah_cost_terms", n, [=] CAUSTICA_HD(size_t i) {
    const KdNode node = nodes[i];
    term[i] = area[i] * inv_root * (node.leaf() ? float(node.ref_count()) : 1.0f);
  });
  return backend.reduce_sum(term, n);
}

}  // namespace caustica
