#include "renderer/accel/bvh4.h"

#include "renderer/base/morton.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {
namespace {

// A binary subtree with the range of sorted leaves it covers. The radix tree stores no ranges,
// but they follow from the root down: internal node k covering [first, last] has children
// covering [first, k] and [k + 1, last].
struct Subtree {
  uint32_t node;  // binary child field: internal node index or kLeafFlag | sorted leaf
  uint32_t first, last;
  bool leaf;  // whether it ends the collapse as one leaf child

  CAUSTICA_HDI uint32_t size() const { return last - first + 1; }
};

// The subtree under binary child field `child`, covering sorted leaves [first, last] in `box`.
CAUSTICA_HDI Subtree subtree(const BvhNode* nodes, uint32_t child, uint32_t first, uint32_t last,
                             const Aabb& box, const Aabb& bounds) {
  return {child, first, last,
          binary_subtree_becomes_leaf(nodes, child, last - first + 1, box, bounds)};
}

// The up-to-four children a binary node's 4-wide node takes: start with its two children and
// repeatedly open the one of largest surface area that is not to become a leaf.
struct Opened {
  Subtree child[4];
  Aabb box[4];
  int count;
};

CAUSTICA_HDI Opened open_children(const BvhNode* nodes, Subtree parent, const Aabb& bounds) {
  Opened o;
  // Opening slot i puts the left child of its subtree in its place and appends the right child.
  auto open = [&](int i) {
    const Subtree s = o.child[i];
    const BvhNode& n = nodes[s.node];
    o.box[i] = n.child[0].bounds();
    o.box[o.count] = n.child[1].bounds();
    o.child[i] = subtree(nodes, n.child[0].index, s.first, s.node, o.box[i], bounds);
    o.child[o.count] = subtree(nodes, n.child[1].index, s.node + 1, s.last, o.box[o.count], bounds);
    ++o.count;
  };
  o.child[0] = parent;
  o.count = 1;
  open(0);
  while (o.count < 4) {
    int best = -1;
    float best_area = -1.0f;
    for (int i = 0; i < o.count; ++i) {
      if (!o.child[i].leaf && o.box[i].half_area() > best_area) {
        best_area = o.box[i].half_area();
        best = i;
      }
    }
    if (best < 0) break;
    open(best);
  }
  return o;
}

}  // namespace

Bvh4 collapse_to_bvh4(Backend& backend, const Bvh& binary) {
  Bvh4 out;
  out.bounds = binary.bounds;
  out.triangle_count = binary.leaf_count;
  out.nodes.bind(backend);
  if (binary.leaf_count < 2) return out;

  // Every 4-wide node has at least two children, so there are fewer nodes than leaves.
  out.nodes.resize_discard(binary.leaf_count - 1);
  Buffer<Subtree> frontier(backend, 1), next_frontier(backend, 0);
  Buffer<uint32_t> counts(backend, 0);
  frontier.upload(std::vector<Subtree>{{binary.root, 0, binary.leaf_count - 1, false}});
  const BvhNode* nodes = binary.nodes.data();
  const Aabb bounds = binary.bounds;
  Bvh4Node* wide = out.nodes.data();
  uint32_t level_base = 0, level_size = 1;
  while (level_size > 0) {
    out.level_starts.push_back(level_base);
    counts.resize_discard(level_size);
    const Subtree* front = frontier.data();
    uint32_t* count = counts.data();
    parallel_for(backend, "bvh4_collapse_count", level_size, [=] CAUSTICA_HD(size_t i) {
      Opened o = open_children(nodes, front[i], bounds);
      uint32_t internal = 0;
      for (int c = 0; c < o.count; ++c) internal += !o.child[c].leaf;
      count[i] = internal;
    });
    const uint32_t next_size = backend.exclusive_scan(count, count, level_size);
    next_frontier.resize_discard(next_size);
    Subtree* next = next_frontier.data();
    const uint32_t next_base = level_base + level_size;
    const uint32_t base = level_base;
    parallel_for(backend, "bvh4_collapse_write", level_size, [=] CAUSTICA_HD(size_t i) {
      Opened o = open_children(nodes, front[i], bounds);
      Bvh4Node& w = wide[base + i];
      uint32_t slot = count[i];
      for (int c = 0; c < 4; ++c) {
        w.set_child_bounds(c, c < o.count ? o.box[c] : Aabb{});
        if (c >= o.count) {
          w.child[c] = kEmptyChild;
        } else if (o.child[c].leaf) {
          w.child[c] = make_leaf_child(o.child[c].first, o.child[c].size());
        } else {
          next[slot] = o.child[c];
          w.child[c] = next_base + slot;
          ++slot;
        }
      }
    });
    std::swap(frontier, next_frontier);
    level_base = next_base;
    level_size = next_size;
  }
  out.level_starts.push_back(level_base);
  // Copy into a buffer of the exact size, so the structure holds no slack.
  Buffer<Bvh4Node> tight(backend, level_base);
  backend.copy_on_device(tight.data(), out.nodes.data(), level_base * sizeof(Bvh4Node));
  out.nodes = std::move(tight);
  return out;
}

}  // namespace caustica
