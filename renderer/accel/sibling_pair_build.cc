#include <stdexcept>
#include <string>

#include "renderer/accel/sibling_pair_bvh.h"
#include "renderer/base/atomic.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {
namespace {

// A binary subtree that becomes a node: its binary node and the range of sorted triangles it
// covers (internal node k covering [first, last] has children covering [first, k] and
// [k + 1, last]).
struct PairSubtree {
  uint32_t node;
  uint32_t first, last;
};

// Child `side` of the subtree: its range, and whether it ends as one leaf.
struct PairChild {
  uint32_t index;  // binary child field
  uint32_t first, last;
  bool leaf;
};

CAUSTICA_HDI PairChild pair_child(const BvhNode* nodes, const PairSubtree& s, int side,
                                  const Aabb& bounds) {
  const BvhChild& c = nodes[s.node].child[side];
  const uint32_t first = side == 0 ? s.first : s.node + 1, last = side == 0 ? s.node : s.last;
  return {c.index, first, last,
          binary_subtree_becomes_leaf(nodes, c.index, last - first + 1, c.bounds(), bounds)};
}

}  // namespace

SiblingPairBvh build_sibling_pair_bvh(Backend& backend, BinaryTriangleBvh binary) {
  const uint32_t n = binary.bvh.leaf_count;
  if (n > kMaxSiblingPairTriangles)
    throw std::invalid_argument("sibling-pair holds at most " +
                                std::to_string(kMaxSiblingPairTriangles) + " triangles, not " +
                                std::to_string(n));
  SiblingPairBvh out;
  out.triangles = std::move(binary.triangles);
  out.triangle_ids = std::move(binary.triangle_ids);
  out.triangle_count = n;
  out.bounds = binary.bvh.bounds;
  out.nodes.bind(backend);
  out.level_starts = {0};
  if (n < 2) return out;

  // Every node has two children and the leaves are at most n, so there are fewer nodes than n.
  out.nodes.resize_discard(n - 1);
  Buffer<PairSubtree> frontier(backend, 1), next_frontier(backend, 0);
  Buffer<uint32_t> counts(backend, 0);
  frontier.upload(std::vector<PairSubtree>{{binary.bvh.root, 0, n - 1}});
  Buffer<uint32_t> failures(backend, 1);
  backend.fill_bytes(failures.data(), 0, sizeof(uint32_t));
  uint32_t* failed = failures.data();
  const BvhNode* nodes = binary.bvh.nodes.data();
  const Aabb bounds = binary.bvh.bounds;
  SiblingPairNode* pairs = out.nodes.data();
  uint32_t level_base = 0, level_size = 1;
  while (level_size > 0) {
    if (out.level_starts.size() > size_t(kSiblingPairStackSize))
      throw std::invalid_argument("sibling-pair: the tree has more than " +
                                  std::to_string(kSiblingPairStackSize) +
                                  " levels, more than its traversal's stack holds");
    counts.resize_discard(level_size);
    const PairSubtree* front = frontier.data();
    uint32_t* count = counts.data();
    parallel_for(backend, "sibling_pair_count", level_size, [=] CAUSTICA_HD(size_t i) {
      count[i] = uint32_t(!pair_child(nodes, front[i], 0, bounds).leaf) +
                 uint32_t(!pair_child(nodes, front[i], 1, bounds).leaf);
    });
    const uint32_t next_size = backend.exclusive_scan(count, count, level_size);
    next_frontier.resize_discard(next_size);
    PairSubtree* next = next_frontier.data();
    const uint32_t next_base = level_base + level_size;
    const uint32_t base = level_base;
    parallel_for(backend, "sibling_pair_write", level_size, [=] CAUSTICA_HD(size_t i) {
      const PairSubtree s = front[i];
      uint32_t slot = count[i];
      uint32_t reference[2];
      for (int side = 0; side < 2; ++side) {
        const PairChild c = pair_child(nodes, s, side, bounds);
        if (c.leaf) {
          reference[side] = make_sibling_leaf(c.first, c.last - c.first + 1);
        } else {
          next[slot] = {c.index, c.first, c.last};
          reference[side] = next_base + slot;
          ++slot;
        }
      }
      const BvhNode& b = nodes[s.node];
      if (!encode_sibling_pair(b.child[0].bounds(), reference[0], b.child[1].bounds(), reference[1],
                               pairs[base + i]))
        atomic_fetch_add(failed, 1u);
    });
    std::swap(frontier, next_frontier);
    level_base = next_base;
    level_size = next_size;
    out.level_starts.push_back(level_base);
  }
  uint32_t failed_nodes = 0;
  backend.copy_to_host(&failed_nodes, failed, sizeof(uint32_t));
  if (failed_nodes != 0)
    throw std::invalid_argument("sibling-pair: a node's box is not its children's union");
  // Copy into a buffer of the exact size, so the structure holds no slack.
  Buffer<SiblingPairNode> tight(backend, level_base);
  backend.copy_on_device(tight.data(), out.nodes.data(), level_base * sizeof(SiblingPairNode));
  out.nodes = std::move(tight);
  BvhNode root;
  backend.copy_to_host(&root, nodes + binary.bvh.root, sizeof(BvhNode));
  out.bounds = sibling_pair_box(root.child[0].bounds(), root.child[1].bounds());
  return out;
}

double sah_cost(Backend& backend, const SiblingPairBvh& bvh) {
  const float root_area = bvh.bounds.half_area();
  const uint32_t triangles = bvh.triangle_count;
  if (triangles == 0 || !(root_area > 0.0f)) return double(triangles);
  if (triangles == 1) return 1.0;
  // Per node: its children's terms relative to the root's area, as for the 4-wide tree; each
  // level's boxes come from the level above.
  const size_t n = bvh.nodes.size();
  Buffer<float> terms(backend, n);
  Buffer<Aabb> level_boxes(backend, 1), next_boxes(backend, 0);
  level_boxes.upload(std::vector<Aabb>{bvh.bounds});
  float* term = terms.data();
  const SiblingPairNode* nodes = bvh.nodes.data();
  const float inv_root = 1.0f / root_area;
  for (size_t l = 0; l + 1 < bvh.level_starts.size(); ++l) {
    const uint32_t begin = bvh.level_starts[l], end = bvh.level_starts[l + 1];
    const uint32_t next_begin = end;
    next_boxes.resize_discard(l + 2 < bvh.level_starts.size() ? bvh.level_starts[l + 2] - end : 0);
    const Aabb* box = level_boxes.data();
    Aabb* next_box = next_boxes.data();
    parallel_for(backend, "sibling_pair_sah_terms", end - begin, [=] CAUSTICA_HD(size_t i) {
      const SiblingPairNode node = nodes[begin + i];
      Aabb child_box[2];
      sibling_child_boxes(node, box[i], child_box[0], child_box[1]);
      float sum = 0.0f;
      for (int c = 0; c < 2; ++c) {
        const uint32_t reference = sibling_reference(node.child[c]);
        const float area = child_box[c].half_area() * inv_root;
        if (is_leaf(reference)) {
          sum += float(sibling_leaf_count(reference)) * area;
        } else {
          sum += area;
          next_box[reference - next_begin] = child_box[c];
        }
      }
      term[begin + i] = sum;
    });
    std::swap(level_boxes, next_boxes);
  }
  return 1.0 + backend.reduce_sum(term, n);
}

}  // namespace caustica
