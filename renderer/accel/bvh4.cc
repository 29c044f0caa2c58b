#include "renderer/accel/bvh4.h"

#include "renderer/parallel/parallel_for.h"

namespace caustica {
namespace {

// The up-to-four children a binary node's 4-wide node takes: start with its two children and
// repeatedly open the internal one of largest surface area.
struct Opened {
  uint32_t child[4];
  Aabb box[4];
  int count;
};

CAUSTICA_HDI Opened open_children(const BvhNode* nodes, uint32_t binary_node) {
  Opened o;
  o.count = 2;
  for (int i = 0; i < 2; ++i) {
    o.child[i] = nodes[binary_node].child[i];
    o.box[i] = nodes[binary_node].child_bounds[i];
  }
  while (o.count < 4) {
    int best = -1;
    float best_area = -1.0f;
    for (int i = 0; i < o.count; ++i) {
      if (!is_leaf(o.child[i]) && o.box[i].half_area() > best_area) {
        best_area = o.box[i].half_area();
        best = i;
      }
    }
    if (best < 0) break;
    const BvhNode& n = nodes[o.child[best]];
    o.child[best] = n.child[0];
    o.box[best] = n.child_bounds[0];
    o.child[o.count] = n.child[1];
    o.box[o.count] = n.child_bounds[1];
    ++o.count;
  }
  return o;
}

}  // namespace

Bvh4 collapse_to_bvh4(Backend& backend, const Bvh& binary) {
  Bvh4 out;
  out.bounds = binary.bounds;
  out.leaf_count = binary.leaf_count;
  out.nodes.bind(backend);
  if (binary.leaf_count < 2) return out;

  // Every 4-wide node takes at least one more leaf than it splits off, so n - 1 nodes suffice.
  out.nodes.resize_discard(binary.leaf_count - 1);
  Buffer<uint32_t> frontier(backend, 1), next_frontier(backend, 0), counts(backend, 0);
  frontier.upload(std::vector<uint32_t>{binary.root});
  const BvhNode* nodes = binary.nodes.data();
  Bvh4Node* wide = out.nodes.data();
  uint32_t level_base = 0, level_size = 1;
  while (level_size > 0) {
    counts.resize_discard(level_size);
    const uint32_t* front = frontier.data();
    uint32_t* count = counts.data();
    parallel_for(backend, level_size, [=] CAUSTICA_HD(size_t i) {
      Opened o = open_children(nodes, front[i]);
      uint32_t internal = 0;
      for (int c = 0; c < o.count; ++c) internal += !is_leaf(o.child[c]);
      count[i] = internal;
    });
    const uint32_t next_size = backend.exclusive_scan(count, count, level_size);
    next_frontier.resize_discard(next_size);
    uint32_t* next = next_frontier.data();
    const uint32_t next_base = level_base + level_size;
    const uint32_t base = level_base;
    parallel_for(backend, level_size, [=] CAUSTICA_HD(size_t i) {
      Opened o = open_children(nodes, front[i]);
      Bvh4Node& w = wide[base + i];
      uint32_t slot = count[i];
      for (int c = 0; c < 4; ++c) {
        Aabb b = c < o.count ? o.box[c] : Aabb{};
        w.lower_x[c] = b.lower.x;
        w.lower_y[c] = b.lower.y;
        w.lower_z[c] = b.lower.z;
        w.upper_x[c] = b.upper.x;
        w.upper_y[c] = b.upper.y;
        w.upper_z[c] = b.upper.z;
        if (c >= o.count) {
          w.child[c] = kEmptyChild;
        } else if (is_leaf(o.child[c])) {
          w.child[c] = o.child[c];
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
  // Copy into a buffer of the exact size, so the structure holds no slack.
  Buffer<Bvh4Node> tight(backend, level_base);
  backend.copy_on_device(tight.data(), out.nodes.data(), level_base * sizeof(Bvh4Node));
  out.nodes = std::move(tight);
  return out;
}

}  // namespace caustica
