// The photon map of variable kernel density estimation: a BVH over the kernels' support regions
// (vkde_kernel.h), queried by point, built by Fabianowski's improved LBVH (2011 sec. 6.1.2-6.1.3):
// - kernels sorted by the Morton code of their centres, runs of equal codes merged first;
// - one merge point per pair of neighbours with different codes, at the level of the highest bit
//   they differ in, the merge points sorted by level and each level merged in parallel, deepest
//   first;
// - the merge tracks each interval in three arrays: its size at its first and last index, and its
//   box and node at its first, so that a merge reads and writes O(1) entries;
// - a node is made only where a merged interval holds more than the leaf size n_auto, so every
//   leaf is the largest interval under it and no singleton nodes or box passes are needed.
// An inner node made at merge point i is stored at index i, so the nodes are sparse in an array
// of n - 1 and the build needs no counters.
#pragma once

#include <cstdint>

#include "renderer/accel/bvh.h"
#include "renderer/parallel/buffer.h"
#include "renderer/photon/vkde_kernel.h"

namespace caustica {

// A child of a node: its box, and either an inner node's index or a leaf's first kernel and count.
struct alignas(16) KernelMapChild {
  Vec3f lower;
  uint32_t index;  // inner node index, or kLeafFlag | first kernel of the leaf
  Vec3f upper;
  uint32_t count;  // kernels in the leaf; 0 for an inner node

  CAUSTICA_HDI bool contains(Vec3f x) const {
    return x.x >= lower.x && x.y >= lower.y && x.z >= lower.z && x.x <= upper.x && x.y <= upper.y &&
           x.z <= upper.z;
  }
};

struct KernelMapNode {
  KernelMapChild child[2];
};

struct KernelMapView {
  const KernelMapNode* nodes = nullptr;
  const VkdeKernel* kernels = nullptr;  // in the order of their codes
  KernelMapChild root{};                // a leaf of every kernel when n <= n_auto
  uint32_t count = 0;
};

struct KernelMap {
  Buffer<KernelMapNode> nodes;  // n - 1, written where merges made nodes
  Buffer<VkdeKernel> kernels;
  KernelMapChild root{};

  KernelMapView view() const {
    return {nodes.data(), kernels.data(), root, uint32_t(kernels.size())};
  }
  size_t size() const { return kernels.size(); }
  size_t bytes() const { return nodes.bytes() + kernels.bytes(); }
};

// Fabianowski's leaf size: c times the kernels' total support area (sum of pi |M x m1|) over the
// scene's surface area, the number of kernels expected to cover a point, and at least 5.
uint32_t kernel_leaf_size(double kernel_area, double surface_area, double c = 8.0);

// Builds the map over `kernels` with leaves of more than `leaf_size` kernels only where a merge
// needs a node.
KernelMap build_kernel_map(Backend& backend, const Buffer<VkdeKernel>& kernels, uint32_t leaf_size);

// Calls visit(i, kernel) for every kernel whose leaf's box holds `x`, i its index in the map; the
// caller tests the kernel itself (vkde_distance_squared). Siblings are tested together and the
// left pushed when both hold x (his algorithm 6.2, on full boxes).
template <typename Visit>
CAUSTICA_HDI void visit_kernels_at(const KernelMapView& map, Vec3f x, Visit visit) {
  if (map.count == 0 || !map.root.contains(x)) return;
  // A tree over 30-bit codes is at most 31 merges deep, so the stack never overflows.
  uint32_t stack[32];
  uint32_t top = 0;
  KernelMapChild current = map.root;
  for (;;) {
    if (is_leaf(current.index)) {
      const uint32_t first = leaf_index(current.index);
      for (uint32_t i = first; i < first + current.count; ++i) visit(i, map.kernels[i]);
    } else {
      const KernelMapNode& node = map.nodes[current.index];
      const bool left = node.child[0].contains(x), right = node.child[1].contains(x);
      if (left && right) {
        stack[top++] = current.index;  // its left child, taken again when popped
        current = node.child[1];
        continue;
      }
      if (left || right) {
        current = node.child[left ? 0 : 1];
        continue;
      }
    }
    if (top == 0) return;
    current = map.nodes[stack[--top]].child[0];
  }
}

}  // namespace caustica
