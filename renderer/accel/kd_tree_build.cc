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
#include <cstdlib>
#include <stdexcept>
#include <string>
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

int max_leaf_depth(uint32_t count) {
  const int by_size = int(8.0 + 1.3 * std::log2(double(count)));
  return by_size < kKdMaxLeafDepth ? by_size : kKdMaxLeafDepth;
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

  LevelRefs refs{Buffer<uint32_t>(backend, count), Buffer<Aabb>(backend, count),
                 Buffer<uint32_t>(backend, count)};
  {
    uint32_t* tri = refs.triangle.data();
    Aabb* box = refs.box.data();
    uint32_t* owner = refs.node.data();
    parallel_for(backend, "kd_root_refs", count, [=] CAUSTICA_HD(size_t i) {
      tri[i] = uint32_t(i);
      box[i] = triangle_bounds(triangles[i]);
      owner[i] = 0;
    });
    tree.bounds = backend.reduce_bounds(box, count);
  }
  const Aabb scene = tree.bounds;
  const Vec3f scene_extent = scene.extent();
  const float scene_volume = scene_extent.x * scene_extent.y * scene_extent.z;
  // SIROH's probabilities divide by the scene's volume and face areas: a flat scene falls back
  // to the SAH's.
  const bool siroh = cost == KdCost::kSiroh && scene_volume > 0.0f && std::isfinite(scene_volume);
  const KdCostParameters k = parameters_of(cost);
  const int max_depth = max_leaf_depth(count);

  Buffer<BuildNode> level(backend, 1);
  level.upload(std::vector<BuildNode>{{scene, 0, count, count > kKdLargeNode ? 1u : 0u}});
  uint32_t node_count = 1, ref_count = count;

  // The finished levels, concatenated at the end.
  std::vector<Buffer<KdNode>> level_nodes;
  std::vector<Buffer<float>> level_areas;
  std::vector<Buffer<uint32_t>> level_leaf_refs;
  size_t level_base = 0, leaf_base = 0;

  Buffer<uint32_t> tight_bits(backend, 0), event_counts(backend, 0), event_values(backend, 0);
  Buffer<uint64_t> event_keys(backend, 0);
  Buffer<SplitChoice> choices(backend, 0);
  Buffer<uint32_t> go_left(backend, 0), go_right(backend, 0);
  Buffer<uint32_t> child_refs(backend, 0), child_nodes(backend, 0), leaf_refs(backend, 0);

  for (int depth = 0; node_count > 0; ++depth) {
    const bool last_level = depth >= max_depth;
    const uint32_t K = node_count, m = ref_count;
    // Node indices fill 30 bits of a kd node and 28 of an event key.
    if (K >= (1u << (64 - kEventNodeShift)) || level_base + K >= (size_t(1) << 30)) {
      throw DeviceError("build_kd_tree: more nodes than the kd node layout can index");
    }
    const BuildNode* nodes = level.data();
    const uint32_t* ref_tri = refs.triangle.data();
    const Aabb* ref_box = refs.box.data();
    const uint32_t* ref_node = refs.node.data();

    // The large nodes' tight boxes, as ordered bits reduced by atomics over runs of references.
    tight_bits.resize_discard(size_t(K) * 6);
    uint32_t* tight = tight_bits.data();
    parallel_for(backend, "kd_clear_tight_bounds", K, [=] CAUSTICA_HD(size_t j) {
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

    // The small nodes' events: per reference and axis one planar or a start and an end event,
    // placed by a scan and sorted by (node, axis, position, type). Sorting them again at every
    // level is simpler than Shi's order-preserving split of the sorted lists, and costs more.
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
    const uint32_t total_events = backend.exclusive_scan(event_count, event_count, size_t(m) + 1);
    if (total_events > 0) {
      event_keys.resize_discard(total_events);
      event_values.resize_discard(total_events);
      uint64_t* key = event_keys.data();
      uint32_t* value = event_values.data();
      parallel_for(backend, "kd_write_events", m, [=] CAUSTICA_HD(size_t i) {
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
      backend.sort_pairs(key, value, total_events, kEventNodeShift + bits_for(K));
    }

    // Each node's decision.
    choices.resize_discard(K);
    SplitChoice* choice = choices.data();
    const uint64_t* key = event_keys.data();
    parallel_for(backend, "kd_choose_splits", K, [=] CAUSTICA_HD(size_t j) {
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

    // Each reference's sides, and the children's lists placed by scans.
    go_left.resize_discard(size_t(m) + 1);
    go_right.resize_discard(size_t(m) + 1);
    uint32_t* left = go_left.data();
    uint32_t* right = go_right.data();
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
    child_refs.resize_discard(size_t(K) + 1);
    child_nodes.resize_discard(size_t(K) + 1);
    leaf_refs.resize_discard(size_t(K) + 1);
    uint32_t* child_ref = child_refs.data();
    uint32_t* child_node = child_nodes.data();
    uint32_t* leaf_ref = leaf_refs.data();
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
    const uint32_t next_refs = backend.exclusive_scan(child_ref, child_ref, size_t(K) + 1);
    const uint32_t next_nodes = backend.exclusive_scan(child_node, child_node, size_t(K) + 1);
    const uint32_t leaf_total = backend.exclusive_scan(leaf_ref, leaf_ref, size_t(K) + 1);

    // The level's nodes, and the next level's.
    Buffer<KdNode> written(backend, K);
    Buffer<float> areas(backend, K);
    Buffer<BuildNode> next(backend, next_nodes);
    KdNode* out = written.data();
    float* area = areas.data();
    BuildNode* child = next.data();
    const uint32_t first_child_base = uint32_t(level_base + K);
    const uint32_t leaf_ref_base = uint32_t(leaf_base);
    parallel_for(backend, "kd_write_nodes", K, [=] CAUSTICA_HD(size_t j) {
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
        // straddling every median would be copied into every node down to the depth limit,
        // and the SAH sweep, which prices the copies, decides instead.
        const bool large = n.large && c > kKdLargeNode &&
                           (s.empty_cut || 4 * uint64_t(c) <= 3 * uint64_t(n.count));
        child[child_node[j] + side] = {child_cell(n.cell, s, side), first, c, large ? 1u : 0u};
        first += c;
      }
    });

    // The references: to the children, clipped to their cells, or into the level's leaves.
    Buffer<uint32_t> leaf_list(backend, leaf_total);
    LevelRefs next_refs_list{Buffer<uint32_t>(backend, next_refs), Buffer<Aabb>(backend, next_refs),
                             Buffer<uint32_t>(backend, next_refs)};
    uint32_t* leaf_out = leaf_list.data();
    uint32_t* next_tri = next_refs_list.triangle.data();
    Aabb* next_box = next_refs_list.box.data();
    uint32_t* next_owner = next_refs_list.node.data();
    parallel_for(backend, "kd_scatter_refs", m, [=] CAUSTICA_HD(size_t i) {
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

    level_nodes.push_back(std::move(written));
    level_areas.push_back(std::move(areas));
    level_leaf_refs.push_back(std::move(leaf_list));
    level_base += K;
    leaf_base += leaf_total;
    tree.depth = depth;
    level = std::move(next);
    refs = std::move(next_refs_list);
    node_count = next_nodes;
    ref_count = next_refs;
  }

  tree.nodes.resize_discard(level_base);
  tree.cell_half_areas.resize_discard(level_base);
  tree.refs.resize_discard(leaf_base);
  size_t node_at = 0, ref_at = 0;
  for (size_t l = 0; l < level_nodes.size(); ++l) {
    const size_t n = level_nodes[l].size(), r = level_leaf_refs[l].size();
    backend.copy_on_device(tree.nodes.data() + node_at, level_nodes[l].data(), n * sizeof(KdNode));
    backend.copy_on_device(tree.cell_half_areas.data() + node_at, level_areas[l].data(),
                           n * sizeof(float));
    if (r > 0) {
      backend.copy_on_device(tree.refs.data() + ref_at, level_leaf_refs[l].data(),
                             r * sizeof(uint32_t));
    }
    node_at += n;
    ref_at += r;
  }
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

const char* kd_traversal_name(KdTraversal traversal) {
  return traversal == KdTraversal::kStackless ? "stackless" : "stack";
}

KdTraversal kd_traversal_from_environment() {
  const char* value = std::getenv("CAUSTICA_KD_TRAVERSAL");
  if (value == nullptr || *value == '\0') return KdTraversal::kStack;
  const std::string name(value);
  if (name == "stack") return KdTraversal::kStack;
  if (name == "stackless") return KdTraversal::kStackless;
  throw std::invalid_argument("CAUSTICA_KD_TRAVERSAL='" + name +
                              "' is not a kd-tree traversal (expected stack or stackless)");
}

}  // namespace caustica
