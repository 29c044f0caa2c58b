#include "renderer/accel/binned_sah.h"

#include <cfloat>

#include "renderer/accel/sah_subtrees.h"
#include "renderer/base/atomic.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {
namespace {

constexpr uint32_t kNoNode = 0xffffffffu;

// Sorted triangles per thread when the bins' counts and bounds are reduced: a thread flushes its
// running bin into the node's table when the bin changes, so a chunk costs one set of atomics per
// bin it spans.
constexpr uint32_t kBinReductionChunk = 64;

// Sorted positions per thread when the segments' boxes are reduced before the first level: far
// fewer segments than positions, so long chunks keep the atomics on each segment's cell few (one
// root segment had every chunk of kBinReductionChunk flush into the same cell).
constexpr uint32_t kSegmentReductionChunk = 1024;

// Past this many data-parallel levels (a run of very uneven splits), the nodes still large are
// finished by the per-node stage.
constexpr int kMaxDataParallelLevels = 48;

// A node of the data-parallel stage: sorted positions [first, last], the box of its triangles and
// of their centroids, and the slot that is to point to it (child `side` of internal node
// `parent`, or the root when parent is kNoParent).
struct LargeNode {
  uint32_t first, last;
  uint32_t parent, side;
  Aabb box, centroids;
};

// A triangle whose box has more than this share of its node's box area takes the node's last bin
// (kHugeBin), whatever its centroid: a room's walls, binned by centroid among the furniture's
// triangles, widened every node they fell in to the size of the room down to their leaves, and
// rays entered all of those (docs/structures.md, "binned-sah"). The sweep's last candidate then
// splits the huge triangles from the rest.
constexpr float kHugeShare = 0.25f;
constexpr uint32_t kHugeBin = kBinnedSahBins;
// Bins per node, the huge one included, and the key bits that number them.
constexpr uint32_t kNodeBins = kBinnedSahBins + 1;
constexpr int kKeyBinBits = kBinnedSahLogBins + 1;

// One bin of one node, its bounds as ordered bits (atomic.h) so that atomics reduce them.
struct BinCell {
  uint32_t count;
  uint32_t lower[3], upper[3];
  uint32_t centroid_lower[3], centroid_upper[3];
};

// How a node splits: positions [first, mid] to the left, with each side's boxes; not `binned`
// when no candidate has triangles on both sides (every one of them huge), and the per-node stage
// splits it instead.
struct NodeSplit {
  uint32_t mid;
  Aabb left, right, left_centroids, right_centroids;
  bool binned = true;
};

// The axis a node bins along, and the affine map from a centroid coordinate to its bin.
struct BinMap {
  int axis;
  float low, scale;

  CAUSTICA_HDI static BinMap of(const Aabb& centroids) {
    const Vec3f e = centroids.extent();
    const int axis = e.x >= e.y && e.x >= e.z ? 0 : e.y >= e.z ? 1 : 2;
    // Zeidan's b = K (1 - eps) (c - low) / extent keeps the highest centroid in the last bin.
    return {axis, centroids.lower[axis], float(kBinnedSahBins) * (1.0f - 1e-6f) / e[axis]};
  }
  // The bin of a triangle's box in a node whose box has half area `node_half_area`.
  CAUSTICA_HDI uint32_t bin(const Aabb& box, float node_half_area) const {
    if (box.half_area() > kHugeShare * node_half_area) return kHugeBin;
    const int b = int((box.center()[axis] - low) * scale);
    return b < 0 ? 0u : b < int(kBinnedSahBins) ? uint32_t(b) : kBinnedSahBins - 1;
  }
};

// Whether the centroids are too close together to bin: all at one point, or so near that the
// bin scale overflows.
CAUSTICA_HDI bool degenerate(const Aabb& centroids) {
  const Vec3f e = centroids.extent();
  const float longest = e.x >= e.y && e.x >= e.z ? e.x : e.y >= e.z ? e.y : e.z;
  return !(float(kBinnedSahBins) / longest <= FLT_MAX);
}

// The bin table entry of a sort key: node j's bins are kNodeBins consecutive cells.
CAUSTICA_HDI uint32_t cell_of(uint32_t key) {
  return (key >> kKeyBinBits) * kNodeBins + (key & ((1u << kKeyBinBits) - 1u));
}

CAUSTICA_HDI void flush_bin(BinCell& cell, uint32_t count, const Aabb& box, const Aabb& centroids) {
  atomic_fetch_add(&cell.count, count);
  for (int a = 0; a < 3; ++a) {
    atomic_min(&cell.lower[a], ordered_bits(box.lower[a]));
    atomic_max(&cell.upper[a], ordered_bits(box.upper[a]));
    atomic_min(&cell.centroid_lower[a], ordered_bits(centroids.lower[a]));
    atomic_max(&cell.centroid_upper[a], ordered_bits(centroids.upper[a]));
  }
}

CAUSTICA_HDI void clear_bin(BinCell& b) {
  b.count = 0;
  for (int a = 0; a < 3; ++a) {
    b.lower[a] = b.centroid_lower[a] = ordered_bits(FLT_MAX);
    b.upper[a] = b.centroid_upper[a] = ordered_bits(-FLT_MAX);
  }
}

CAUSTICA_HDI void read_bin(const BinCell& cell, Aabb& box, Aabb& centroids) {
  for (int a = 0; a < 3; ++a) {
    box.lower[a] = from_ordered_bits(cell.lower[a]);
    box.upper[a] = from_ordered_bits(cell.upper[a]);
    centroids.lower[a] = from_ordered_bits(cell.centroid_lower[a]);
    centroids.upper[a] = from_ordered_bits(cell.centroid_upper[a]);
  }
}

// The cheapest of the node's kNodeBins - 1 candidate splits by SAH (left count x left area + right
// count x right area). A node whose centroids bin has at least two bins in use, so one exists,
// unless every triangle in it is huge.
CAUSTICA_HDI NodeSplit sweep_bins(const LargeNode& node, const BinCell* cells) {
  Aabb box[kNodeBins], centroids[kNodeBins];
  uint32_t count[kNodeBins];
  for (uint32_t b = 0; b < kNodeBins; ++b) {
    count[b] = cells[b].count;
    read_bin(cells[b], box[b], centroids[b]);
  }
  float right_area[kNodeBins];
  Aabb right;
  uint32_t right_count = 0;
  for (int b = int(kNodeBins) - 1; b > 0; --b) {
    right.extend(box[b]);
    right_count += count[b];
    right_area[b] = float(right_count) * right.half_area();
  }
  float best_cost = INFINITY;
  uint32_t best_bin = 0, best_left = 0, left_count = 0;
  Aabb left;
  for (uint32_t b = 0; b + 1 < kNodeBins; ++b) {
    left.extend(box[b]);
    left_count += count[b];
    const uint32_t n = node.last - node.first + 1;
    if (left_count == 0 || left_count == n) continue;
    const float cost = float(left_count) * left.half_area() + right_area[b + 1];
    if (cost < best_cost) {
      best_cost = cost;
      best_bin = b;
      best_left = left_count;
    }
  }
  if (best_cost == INFINITY) return {node.first, Aabb{}, Aabb{}, Aabb{}, Aabb{}, false};
  NodeSplit split{node.first + best_left - 1, Aabb{}, Aabb{}, Aabb{}, Aabb{}};
  for (uint32_t b = 0; b < kNodeBins; ++b) {
    if (count[b] == 0) continue;
    if (b <= best_bin) {
      split.left.extend(box[b]);
      split.left_centroids.extend(centroids[b]);
    } else {
      split.right.extend(box[b]);
      split.right_centroids.extend(centroids[b]);
    }
  }
  return split;
}

CAUSTICA_HDI uint32_t bits_for(uint32_t values) {
  uint32_t bits = 0;
  while (bits < 32 && (uint64_t(1) << bits) < values) ++bits;
  return bits;
}

// The last of `nodes` (`count` of them, in position order, disjoint: LargeNodes or SmallSubtrees)
// that starts at or before position `p`, or kNoNode when none does.
template <typename Range>
CAUSTICA_HDI uint32_t node_holding(const Range* nodes, uint32_t count, uint32_t p) {
  uint32_t lo = 0, hi = count;  // the first node that starts after p is in [lo, hi]
  while (lo < hi) {
    const uint32_t mid = (lo + hi) / 2;
    if (nodes[mid].first <= p) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  return lo - 1;
}

// Whether a child of `size` triangles with these centroids goes on to the next data-parallel
// level (else: a leaf when it is one triangle, or the per-node stage).
CAUSTICA_HDI bool stays_large(uint32_t size, const Aabb& centroids, bool last_level) {
  return !last_level && size > kSahSubtreeTriangles && !degenerate(centroids);
}

// The data-parallel stage and then the per-node stage over `segment_count` disjoint subtrees of
// `bvh` (rebuild_subtrees_by_binned_sah), whose triangles at sorted position p are source[p] with
// original index source_ids[p] (p itself when source_ids is null). Writes the triangles and their
// ids in the new leaf order to `out_triangles` and `out_ids`, and, when the root is listed, the
// root and the bounds to `bvh`.
void binned_sah_stages(Backend& backend, Bvh& bvh, const TriangleVertices* source,
                       const uint32_t* source_ids, const SmallSubtree* segments,
                       uint32_t segment_count, bool root_listed,
                       Buffer<TriangleVertices>& out_triangles, Buffer<uint32_t>& out_ids) {
  const uint32_t count = bvh.leaf_count;
  // Per sorted position: the triangle there (a position of `source`) and its box, moved together
  // as nodes sort.
  Buffer<uint32_t> orders(backend, count);
  Buffer<Aabb> boxes(backend, count);
  uint32_t* order = orders.data();
  Aabb* box = boxes.data();
  parallel_for(backend, "binned_sah_boxes", count, [=] CAUSTICA_HD(size_t i) {
    order[i] = uint32_t(i);
    box[i] = triangle_bounds(source[i]);
  });

  BvhNode* nodes = bvh.nodes.data();
  Buffer<uint32_t> root_word(backend, 1);
  uint32_t* root = root_word.data();
  backend.fill_bytes(root, 0xff, sizeof(uint32_t));  // kNoNode
  Buffer<SmallSubtree> small_list(backend, count / 2 + 1);
  Buffer<uint32_t> small_counter(backend, 1);
  backend.fill_bytes(small_counter.data(), 0, sizeof(uint32_t));
  SmallSubtree* small = small_list.data();
  uint32_t* small_count_word = small_counter.data();

  // The segments in position order, with the box and the centroid box of each reduced over its
  // sorted positions (one bin per segment), decide which start the data-parallel stage.
  Buffer<LargeNode> level_nodes(backend, 0), next_nodes(backend, 0);
  uint32_t node_count = 0;
  if (segment_count > 0) {
    Buffer<uint32_t> segment_keys(backend, segment_count), segment_index(backend, segment_count);
    uint32_t* seg_key = segment_keys.data();
    uint32_t* seg_index = segment_index.data();
    parallel_for(backend, "binned_sah_segment_keys", segment_count, [=] CAUSTICA_HD(size_t i) {
      seg_key[i] = segments[i].first;
      seg_index[i] = uint32_t(i);
    });
    backend.sort_pairs(seg_key, seg_index, segment_count, int(bits_for(count)));
    Buffer<SmallSubtree> sorted_segments(backend, segment_count);
    SmallSubtree* seg = sorted_segments.data();
    parallel_for(backend, "binned_sah_segment_order", segment_count,
                 [=] CAUSTICA_HD(size_t i) { seg[i] = segments[seg_index[i]]; });
    Buffer<BinCell> segment_cells(backend, segment_count);
    BinCell* seg_cell = segment_cells.data();
    parallel_for(backend, "binned_sah_segment_clear", segment_count,
                 [=] CAUSTICA_HD(size_t c) { clear_bin(seg_cell[c]); });
    const size_t chunks = (size_t(count) + kSegmentReductionChunk - 1) / kSegmentReductionChunk;
    parallel_for(backend, "binned_sah_segment_bounds", chunks, [=] CAUSTICA_HD(size_t c) {
      const uint32_t begin = uint32_t(c * kSegmentReductionChunk);
      const uint32_t end =
          begin + kSegmentReductionChunk < count ? begin + kSegmentReductionChunk : count;
      uint32_t run = kNoNode, run_count = 0;
      Aabb run_box, run_centroids;
      // The last segment starting at or before p, found once and then followed along the chunk.
      uint32_t last_started = node_holding(seg, segment_count, begin);
      for (uint32_t p = begin; p < end; ++p) {
        const uint32_t next = last_started == kNoNode ? 0u : last_started + 1;
        if (next < segment_count && seg[next].first <= p) last_started = next;
        const uint32_t j =
            last_started != kNoNode && p <= seg[last_started].last ? last_started : kNoNode;
        if (j != run) {
          if (run != kNoNode) flush_bin(seg_cell[run], run_count, run_box, run_centroids);
          run = j;
          run_count = 0;
          run_box = run_centroids = Aabb{};
        }
        const Aabb b = box[p];
        ++run_count;
        run_box.extend(b);
        run_centroids.extend(b.center());
      }
      if (run != kNoNode) flush_bin(seg_cell[run], run_count, run_box, run_centroids);
    });
    if (root_listed) {
      // The root is the only segment: its box is the tree's bounds.
      BinCell root_cell;
      backend.copy_to_host(&root_cell, seg_cell, sizeof(BinCell));
      Aabb root_centroids;
      read_bin(root_cell, bvh.bounds, root_centroids);
    }
    // Segments too small or too degenerate to bin go to the per-node stage at once; the others
    // become the first level's nodes, in position order.
    Buffer<uint32_t> large_flags(backend, segment_count);
    uint32_t* large_slot = large_flags.data();
    parallel_for(backend, "binned_sah_segment_split", segment_count, [=] CAUSTICA_HD(size_t j) {
      Aabb b, centroids;
      read_bin(seg_cell[j], b, centroids);
      const SmallSubtree s = seg[j];
      large_slot[j] = stays_large(s.last - s.first + 1, centroids, false) ? 1u : 0u;
      if (!large_slot[j]) small[atomic_fetch_add(small_count_word, 1u)] = s;
    });
    node_count = backend.exclusive_scan(large_slot, large_slot, segment_count);
    level_nodes.resize_discard(node_count);
    LargeNode* first_level = level_nodes.data();
    parallel_for(backend, "binned_sah_segment_nodes", segment_count, [=] CAUSTICA_HD(size_t j) {
      Aabb b, centroids;
      read_bin(seg_cell[j], b, centroids);
      const SmallSubtree s = seg[j];
      if (stays_large(s.last - s.first + 1, centroids, false))
        first_level[large_slot[j]] = {s.first, s.last, s.parent, s.side, b, centroids};
    });
  }

  if (node_count > 0) {
    // Per element of the stage (a triangle of a large node): its position. Its node follows from
    // the position (node_holding), which saves a second compaction per level.
    Buffer<uint32_t> element_pos(backend, count);
    Buffer<uint32_t> keys(backend, count), values(backend, count), next_pos(backend, count);
    Buffer<uint8_t> keep(backend, count);
    uint32_t element_count = 0;
    {
      const LargeNode* first_level = level_nodes.data();
      const uint32_t first_count = node_count;
      uint8_t* kept = keep.data();
      parallel_for(backend, "binned_sah_elements", count, [=] CAUSTICA_HD(size_t p) {
        const uint32_t j = node_holding(first_level, first_count, uint32_t(p));
        kept[p] = j != kNoNode && p <= first_level[j].last;
      });
      element_count = uint32_t(backend.select_flagged(nullptr, kept, count, element_pos.data()));
    }
    Buffer<uint32_t> moved_orders(backend, count);
    Buffer<Aabb> moved_boxes(backend, count);
    Buffer<BinCell> cells(backend, 0);
    Buffer<NodeSplit> splits(backend, 0);
    Buffer<uint32_t> continuing(backend, 0), child_next(backend, 0);
    for (int level = 0; node_count > 0; ++level) {
      const bool last_level = level + 1 >= kMaxDataParallelLevels;
      const uint32_t m = element_count;
      const LargeNode* level_node = level_nodes.data();
      uint32_t* pos = element_pos.data();
      uint32_t* key = keys.data();
      uint32_t* value = values.data();

      // Bins along each node's longest centroid axis, then one sort puts every node's triangles in
      // bin order; the sort is stable and nodes are numbered in position order, so each node's
      // triangles stay within its positions.
      parallel_for(backend, "binned_sah_bin_keys", m, [=] CAUSTICA_HD(size_t i) {
        const uint32_t j = node_holding(level_node, node_count, pos[i]);
        const LargeNode& n = level_node[j];
        key[i] = j << kKeyBinBits | BinMap::of(n.centroids).bin(box[pos[i]], n.box.half_area());
        value[i] = uint32_t(i);
      });
      backend.sort_pairs(key, value, m, int(bits_for(node_count)) + kKeyBinBits);
      uint32_t* moved_order = moved_orders.data();
      Aabb* moved_box = moved_boxes.data();
      parallel_for(backend, "binned_sah_gather", m, [=] CAUSTICA_HD(size_t i) {
        moved_order[i] = order[pos[value[i]]];
        moved_box[i] = box[pos[value[i]]];
      });
      parallel_for(backend, "binned_sah_scatter", m, [=] CAUSTICA_HD(size_t i) {
        order[pos[i]] = moved_order[i];
        box[pos[i]] = moved_box[i];
      });

      // The bins' counts and bounds, over chunks of the sorted elements.
      cells.resize_discard(size_t(node_count) * kNodeBins);
      BinCell* cell = cells.data();
      parallel_for(backend, "binned_sah_clear_bins", cells.size(),
                   [=] CAUSTICA_HD(size_t c) { clear_bin(cell[c]); });
      const size_t chunks = (m + kBinReductionChunk - 1) / kBinReductionChunk;
      parallel_for(backend, "binned_sah_bins", chunks, [=] CAUSTICA_HD(size_t c) {
        const uint32_t begin = uint32_t(c * kBinReductionChunk);
        const uint32_t end = begin + kBinReductionChunk < m ? begin + kBinReductionChunk : m;
        uint32_t run_key = key[begin], run_count = 0;
        Aabb run_box, run_centroids;
        for (uint32_t i = begin; i < end; ++i) {
          if (key[i] != run_key) {
            flush_bin(cell[cell_of(run_key)], run_count, run_box, run_centroids);
            run_key = key[i];
            run_count = 0;
            run_box = run_centroids = Aabb{};
          }
          const Aabb b = moved_box[i];
          ++run_count;
          run_box.extend(b);
          run_centroids.extend(b.center());
        }
        flush_bin(cell[cell_of(run_key)], run_count, run_box, run_centroids);
      });

      // Each node's split; its slot, leaf children and small children are written at once, and
      // its large children counted for the next level.
      splits.resize_discard(node_count);
      continuing.resize_discard(node_count);
      NodeSplit* split_of = splits.data();
      uint32_t* more = continuing.data();
      parallel_for(backend, "binned_sah_split", node_count, [=] CAUSTICA_HD(size_t j) {
        const LargeNode n = level_node[j];
        const NodeSplit s = sweep_bins(n, cell + j * kNodeBins);
        split_of[j] = s;
        more[j] = 0;
        if (!s.binned) {
          // The root stays unset, which tells the host that the per-node stage builds it.
          if (n.parent != kNoParent)
            nodes[n.parent].child[n.side] = BvhChild{n.box.lower, kNoNode, n.box.upper};
          small[atomic_fetch_add(small_count_word, 1u)] = {n.parent, n.side, n.first, n.last};
          return;
        }
        if (n.parent == kNoParent) {
          *root = s.mid;
        } else {
          nodes[n.parent].child[n.side] = BvhChild{n.box.lower, s.mid, n.box.upper};
        }
        uint32_t large = 0;
        const uint32_t first[2] = {n.first, s.mid + 1}, last[2] = {s.mid, n.last};
        const Aabb child_box[2] = {s.left, s.right};
        const Aabb child_centroids[2] = {s.left_centroids, s.right_centroids};
        for (uint32_t side = 0; side < 2; ++side) {
          const uint32_t size = last[side] - first[side] + 1;
          const Aabb& b = child_box[side];
          if (stays_large(size, child_centroids[side], last_level)) {
            ++large;
          } else if (size == 1) {
            nodes[s.mid].child[side] = BvhChild{b.lower, kLeafFlag | first[side], b.upper};
          } else {
            // The per-node stage reads the range's box from its slot.
            nodes[s.mid].child[side] = BvhChild{b.lower, kNoNode, b.upper};
            small[atomic_fetch_add(small_count_word, 1u)] = {s.mid, side, first[side], last[side]};
          }
        }
        more[j] = large;
      });
      const uint32_t next_count = backend.exclusive_scan(more, more, node_count);
      next_nodes.resize_discard(next_count);
      child_next.resize_discard(2 * size_t(node_count));
      LargeNode* next_node_list = next_nodes.data();
      uint32_t* child_index = child_next.data();
      parallel_for(backend, "binned_sah_next_nodes", node_count, [=] CAUSTICA_HD(size_t j) {
        const LargeNode n = level_node[j];
        const NodeSplit s = split_of[j];
        if (!s.binned) {
          child_index[2 * j] = child_index[2 * j + 1] = kNoNode;
          return;
        }
        uint32_t slot = more[j];
        const uint32_t first[2] = {n.first, s.mid + 1}, last[2] = {s.mid, n.last};
        const Aabb child_box[2] = {s.left, s.right};
        const Aabb child_centroids[2] = {s.left_centroids, s.right_centroids};
        for (uint32_t side = 0; side < 2; ++side) {
          const uint32_t size = last[side] - first[side] + 1;
          if (stays_large(size, child_centroids[side], last_level)) {
            next_node_list[slot] = {first[side], last[side],      s.mid,
                                    side,        child_box[side], child_centroids[side]};
            child_index[2 * j + side] = slot++;
          } else {
            child_index[2 * j + side] = kNoNode;
          }
        }
      });
      // The elements of large children, in position order.
      uint8_t* kept = keep.data();
      parallel_for(backend, "binned_sah_partition", m, [=] CAUSTICA_HD(size_t i) {
        const uint32_t j = key[i] >> kKeyBinBits;
        const uint32_t side = pos[i] <= split_of[j].mid ? 0u : 1u;
        kept[i] = child_index[2 * j + side] != kNoNode;
      });
      element_count = uint32_t(backend.select_flagged(pos, kept, m, next_pos.data()));
      std::swap(element_pos, next_pos);
      std::swap(level_nodes, next_nodes);
      node_count = next_count;
    }
  }

  // The triangles in leaf order, then the small nodes finished by the per-node stage.
  out_triangles.resize_discard(count);
  out_ids.resize_discard(count);
  TriangleVertices* sorted = out_triangles.data();
  uint32_t* ids = out_ids.data();
  parallel_for(backend, "binned_sah_leaf_order", count, [=] CAUSTICA_HD(size_t p) {
    sorted[p] = source[order[p]];
    ids[p] = source_ids != nullptr ? source_ids[order[p]] : order[p];
  });
  uint32_t small_count = 0;
  backend.copy_to_host(&small_count, small_count_word, sizeof(uint32_t));
  bool root_small = false;
  if (root_listed) {
    uint32_t root_node = kNoNode;
    backend.copy_to_host(&root_node, root, sizeof(uint32_t));
    // Unset when the root went to the per-node stage, which then sets it.
    root_small = root_node == kNoNode;
    if (!root_small) bvh.root = root_node;
  }
  rebuild_small_subtrees(backend, bvh, small, small_count, out_triangles, out_ids, root_small);
}

}  // namespace

void rebuild_subtrees_by_binned_sah(Backend& backend, BinaryTriangleBvh& tree,
                                    const SmallSubtree* segments, uint32_t segment_count,
                                    bool root_listed) {
  if (segment_count == 0) return;
  Buffer<TriangleVertices> triangles(backend, 0);
  Buffer<uint32_t> ids(backend, 0);
  binned_sah_stages(backend, tree.bvh, tree.triangles.data(), tree.triangle_ids.data(), segments,
                    segment_count, root_listed, triangles, ids);
  tree.triangles = std::move(triangles);
  tree.triangle_ids = std::move(ids);
}

BinaryTriangleBvh build_binned_sah_bvh(Backend& backend, const TriangleVertices* triangles,
                                       uint32_t count) {
  BinaryTriangleBvh out;
  out.bvh.nodes.bind(backend);
  out.triangles.bind(backend);
  out.triangle_ids.bind(backend);
  out.bvh.leaf_count = count;
  if (count == 0) return out;
  if (count == 1) {
    out.triangles.resize_discard(1);
    backend.copy_on_device(out.triangles.data(), triangles, sizeof(TriangleVertices));
    out.triangle_ids.upload(std::vector<uint32_t>{0});
    TriangleVertices t;
    backend.copy_to_host(&t, triangles, sizeof(TriangleVertices));
    out.bvh.bounds = triangle_bounds(t);
    return out;
  }
  // The one-segment case: the whole input, in its own order, is the root's range.
  out.bvh.nodes.resize_discard(count - 1);
  Buffer<SmallSubtree> root_segment(backend, 1);
  root_segment.upload(std::vector<SmallSubtree>{{kNoParent, 0, 0, count - 1}});
  binned_sah_stages(backend, out.bvh, triangles, nullptr, root_segment.data(), 1, true,
                    out.triangles, out.triangle_ids);
  return out;
}

}  // namespace caustica
