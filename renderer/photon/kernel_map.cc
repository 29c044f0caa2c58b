#include "renderer/photon/kernel_map.h"

#include <algorithm>
#include <cmath>

#include "renderer/base/bits.h"
#include "renderer/base/morton.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {
namespace {

constexpr uint32_t kCodeBits = 30;
constexpr uint32_t kNoMerge = 32;  // the level key of neighbours with equal codes

}  // namespace

uint32_t kernel_leaf_size(double kernel_area, double surface_area, double c) {
  const double n = surface_area > 0 ? c * kernel_area / surface_area : 0.0;
  // Above a few thousand a leaf is the whole map of a small scene; the cap only keeps the
  // conversion defined.
  return uint32_t(std::clamp(std::ceil(n), 5.0, double(1u << 30)));
}

KernelMap build_kernel_map(Backend& backend, const Buffer<VkdeKernel>& kernels,
                           uint32_t leaf_size) {
  KernelMap map;
  map.nodes.bind(backend);
  map.kernels.bind(backend);
  const uint32_t n = uint32_t(kernels.size());
  if (n == 0) return map;

  // Codes of the kernels' centres on a grid over the centres' bounds; the ids sort with them.
  const VkdeKernel* in = kernels.data();
  Buffer<Aabb> boxes(backend, n);
  Buffer<Aabb> bounds(backend, 1);
  Aabb* box = boxes.data();
  parallel_for(backend, "kernel_map_centres", n, [=] CAUSTICA_HD(size_t i) {
    box[i] = Aabb{in[i].center, in[i].center};
  });
  backend.reduce_bounds_to(box, n, bounds.data());
  Buffer<uint32_t> codes(backend, n), ids(backend, n);
  uint32_t* code = codes.data();
  uint32_t* id = ids.data();
  const Aabb* centre_bounds = bounds.data();
  parallel_for(backend, "kernel_map_codes", n, [=] CAUSTICA_HD(size_t i) {
    code[i] = morton_code(in[i].center, *centre_bounds);
    id[i] = uint32_t(i);
  });
  backend.sort_pairs(code, id, n, kCodeBits);

  // The three arrays: S (sizes), N (node + 1, 0 for none) and the boxes, which start as each
  // kernel's own support box.
  map.kernels.resize_discard(n);
  VkdeKernel* sorted = map.kernels.data();
  Buffer<uint32_t> sizes(backend, n), node_of(backend, n);
  uint32_t* size = sizes.data();
  uint32_t* node = node_of.data();
  parallel_for(backend, "kernel_map_order", n, [=] CAUSTICA_HD(size_t i) {
    const VkdeKernel k = in[id[i]];
    sorted[i] = k;
    box[i] = vkde_bounds(k);
    size[i] = 1;
    node[i] = 0;
  });
  // Runs of equal codes become one interval each before any merge; their first kernel walks them.
  parallel_for(backend, "kernel_map_equal_codes", n, [=] CAUSTICA_HD(size_t i) {
    if (i > 0 && code[i - 1] == code[i]) return;
    size_t last = i;
    Aabb run = box[i];
    while (last + 1 < n && code[last + 1] == code[i]) run.extend(box[++last]);
    if (last == i) return;
    box[i] = run;
    size[i] = size[last] = uint32_t(last - i + 1);
  });

  map.nodes.resize_discard(n > 1 ? n - 1 : 0);
  if (n > 1) {
    // Merge points: neighbours i, i + 1 with different codes, keyed by the highest differing bit
    // (their level, 0 deepest), and sorted by it so that each level is one range.
    const uint32_t m = n - 1;
    Buffer<uint32_t> levels(backend, m), points(backend, m);
    uint32_t* level = levels.data();
    uint32_t* point = points.data();
    parallel_for(backend, "kernel_map_merge_points", m, [=] CAUSTICA_HD(size_t i) {
      const uint32_t differ = code[i] ^ code[i + 1];
      level[i] = differ == 0 ? kNoMerge : highest_bit32(differ);
      point[i] = uint32_t(i);
    });
    backend.sort_pairs(level, point, m, 6);
    Buffer<uint32_t> level_ends(backend, kCodeBits);
    uint32_t* level_end = level_ends.data();
    backend.fill_bytes(level_end, 0, kCodeBits * sizeof(uint32_t));
    parallel_for(backend, "kernel_map_levels", m, [=] CAUSTICA_HD(size_t j) {
      if (level[j] < kCodeBits && (j + 1 == m || level[j + 1] != level[j]))
        level_end[level[j]] = uint32_t(j + 1);
    });
    const std::vector<uint32_t> ends = level_ends.download();

    KernelMapNode* nodes = map.nodes.data();
    const uint32_t leaf_max = leaf_size;
    uint32_t begin = 0;
    for (uint32_t l = 0; l < kCodeBits; ++l) {
      if (ends[l] == 0) continue;
      const uint32_t first_point = begin;
      begin = ends[l];
      parallel_for(backend, "kernel_map_merge", ends[l] - first_point, [=] CAUSTICA_HD(size_t t) {
        const uint32_t i = point[first_point + t];
        const uint32_t left_size = size[i], right_size = size[i + 1];
        const uint32_t first = i + 1 - left_size, last = i + right_size;
        const uint32_t merged = left_size + right_size;
        const Aabb left_box = box[first], right_box = box[i + 1];
        if (merged > leaf_max) {
          auto child = [&](uint32_t start, uint32_t count, const Aabb& b) {
            const uint32_t inner = node[start];
            return KernelMapChild{b.lower, inner != 0 ? inner - 1 : (kLeafFlag | start), b.upper,
                                  inner != 0 ? 0u : count};
          };
          nodes[i] = {child(first, left_size, left_box), child(i + 1, right_size, right_box)};
          node[first] = i + 1;
        }
        box[first] = merge(left_box, right_box);
        size[first] = size[last] = merged;
      });
    }
  }

  // The root: the node of the whole interval, or one leaf of every kernel.
  uint32_t root_node = 0;
  Aabb root_box;
  backend.copy_to_host(&root_node, node, sizeof(uint32_t));
  backend.copy_to_host(&root_box, box, sizeof(Aabb));
  map.root = {root_box.lower, root_node != 0 ? root_node - 1 : kLeafFlag, root_box.upper,
              root_node != 0 ? 0u : n};
  return map;
}

}  // namespace caustica
