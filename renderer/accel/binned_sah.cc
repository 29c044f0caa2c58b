#include "renderer/accel/binned_sah.h"

#include <cfloat>
#include <stdexcept>

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

// Past this many data-parallel levels (a run of very uneven splits), the nodes still large are
// finished by the per-node stage.
constexpr int kMaxDataParallelLevels = 64;

// A node of the data-parallel stages: sorted positions [first, last], the box of its triangles and
// of their centroids, the slot that is to point to it (child `side` of internal node `parent`, or
// the root when parent is kNoParent), and the bins its stage gives it. Its bins' cells are
// cell[first] to cell[first + bins] (the huge bin last): a node has more triangles than bins, so
// the nodes of a level never share a cell.
struct LargeNode {
  uint32_t first, last;
  uint32_t parent, side;
  Aabb box, centroids;
  uint32_t bins;
};

// A triangle whose box has more than this share of its node's box area takes the node's last bin
// (its bins' count), whatever its centroid: a room's walls, binned by centroid among the
// furniture's triangles, widened every node they fell in to the size of the room down to their
// leaves, and rays entered all of those (docs/structures.md, "binned-sah"). The sweep's last
// candidate then splits the huge triangles from the rest. A node of K bins numbers its huge bin K.
constexpr float kHugeShare = 0.25f;

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
  uint32_t bins;

  CAUSTICA_HDI static BinMap of(const LargeNode& node) {
    const Vec3f e = node.centroids.extent();
    const int axis = e.x >= e.y && e.x >= e.z ? 0 : e.y >= e.z ? 1 : 2;
    // Zeidan's b = K (1 - eps) (c - low) / extent keeps the highest centroid in the last bin.
    return {axis, node.centroids.lower[axis], float(node.bins) * (1.0f - 1e-6f) / e[axis],
            node.bins};
  }
  // The bin of a triangle's box in a node whose box has half area `node_half_area`.
  CAUSTICA_HDI uint32_t bin(const Aabb& box, float node_half_area) const {
    if (box.half_area() > kHugeShare * node_half_area) return bins;
    const int b = int((box.center()[axis] - low) * scale);
    return b < 0 ? 0u : b < int(bins) ? uint32_t(b) : bins - 1;
  }
};

// Whether the centroids are too close together to bin: all at one point, or so near that the
// bin scale overflows.
CAUSTICA_HDI bool degenerate(const Aabb& centroids) {
  const Vec3f e = centroids.extent();
  const float longest = e.x >= e.y && e.x >= e.z ? e.x : e.y >= e.z ? e.y : e.z;
  return !(float(kMaxBinnedSahBins) / longest <= FLT_MAX);
}

// The triangles a thread has met in a row for one cell, flushed into it with one set of atomics.
struct RunningBin {
  uint32_t count = 0;
  Aabb box, centroids;

  CAUSTICA_HDI void add(const Aabb& b) {
    ++count;
    box.extend(b);
    centroids.extend(b.center());
  }
  CAUSTICA_HDI void flush_into(BinCell& cell) {
    atomic_fetch_add(&cell.count, count);
    for (int a = 0; a < 3; ++a) {
      atomic_min(&cell.lower[a], ordered_bits(box.lower[a]));
      atomic_max(&cell.upper[a], ordered_bits(box.upper[a]));
      atomic_min(&cell.centroid_lower[a], ordered_bits(centroids.lower[a]));
      atomic_max(&cell.centroid_upper[a], ordered_bits(centroids.upper[a]));
    }
    *this = RunningBin{};
  }
};

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

// The cheapest of the node's candidate splits between its bins + 1 cells (the huge bin last) by
// SAH (left count x left area + right count x right area). A node whose centroids bin has at
// least two bins in use, so one exists, unless every triangle in it is huge. Only the right
// sides' costs are kept, and the cells read again, so that a thread's array stays small with
// many bins.
CAUSTICA_HDI NodeSplit sweep_bins(const LargeNode& node, const BinCell* cells) {
  const uint32_t cell_count = node.bins + 1;
  float right_area[kMaxBinnedSahBins + 1];
  Aabb right, box, centroids;
  uint32_t right_count = 0;
  for (uint32_t b = cell_count - 1; b > 0; --b) {
    read_bin(cells[b], box, centroids);
    right.extend(box);
    right_count += cells[b].count;
    right_area[b] = float(right_count) * right.half_area();
  }
  float best_cost = INFINITY;
  uint32_t best_bin = 0, best_left = 0, left_count = 0;
  Aabb left;
  const uint32_t n = node.last - node.first + 1;
  for (uint32_t b = 0; b + 1 < cell_count; ++b) {
    read_bin(cells[b], box, centroids);
    left.extend(box);
    left_count += cells[b].count;
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
  for (uint32_t b = 0; b < cell_count; ++b) {
    if (cells[b].count == 0) continue;
    read_bin(cells[b], box, centroids);
    if (b <= best_bin) {
      split.left.extend(box);
      split.left_centroids.extend(centroids);
    } else {
      split.right.extend(box);
      split.right_centroids.extend(centroids);
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
CAUSTICA_HDI bool stays_large(const BinnedSahSchedule& schedule, uint32_t size,
                              const Aabb& centroids, bool last_level) {
  return !last_level && size > schedule.per_node_limit() && !degenerate(centroids);
}

// Puts a level's (node << bits | bin) keys in order, and with them the elements' indices: stable,
// so each node's triangles keep their order within a bin, and both ways give the same order.
class BinOrder {
 public:
  BinOrder(Backend& backend, uint32_t capacity) : backend_(backend) {
    for (int b = 0; b < 2; ++b) {
      keys_[b] = Buffer<uint32_t>(backend, capacity);
      values_[b] = Buffer<uint32_t>(backend, capacity);
    }
  }
  uint32_t* keys() { return keys_[current_].data(); }
  uint32_t* values() { return values_[current_].data(); }

  // Sorts the first `m` keys, whose nodes (of `node_count`, in position order) are `nodes`.
  void sort(BinnedSahReorder reorder, const LargeNode* nodes, uint32_t node_count, uint32_t m,
            int key_bin_bits) {
    if (reorder == BinnedSahReorder::kRadixSort) {
      backend_.sort_pairs(keys(), values(), m, int(bits_for(node_count)) + key_bin_bits);
      return;
    }
    // Zeidan's segmented splits, least significant bit first: the keys' nodes are already in
    // order, so each pass is a stable split of every node's elements by one bit of the bin.
    node_start_.resize_discard(node_count);
    flags_.resize_discard(size_t(m) + 1);
    scan_.resize_discard(size_t(m) + 1);
    uint32_t* start = node_start_.data();
    {
      const uint32_t* key = keys();
      parallel_for(backend_, "binned_sah_node_starts", m, [=] CAUSTICA_HD(size_t i) {
        const uint32_t j = key[i] >> key_bin_bits;
        if (i == 0 || key[i - 1] >> key_bin_bits != j) start[j] = uint32_t(i);
      });
    }
    for (int bit = 0; bit < key_bin_bits; ++bit) {
      const uint32_t* key = keys();
      const uint32_t* value = values();
      uint32_t* key_out = keys_[current_ ^ 1].data();
      uint32_t* value_out = values_[current_ ^ 1].data();
      uint32_t* flag = flags_.data();
      uint32_t* ones = scan_.data();
      parallel_for(backend_, "binned_sah_split_flags", size_t(m) + 1,
                   [=] CAUSTICA_HD(size_t i) { flag[i] = i < m ? (key[i] >> bit) & 1u : 0u; });
      backend_.exclusive_scan(flag, ones, size_t(m) + 1);
      parallel_for(backend_, "binned_sah_split_scatter", m, [=] CAUSTICA_HD(size_t i) {
        const uint32_t j = key[i] >> key_bin_bits;
        const uint32_t s = start[j], n = nodes[j].last - nodes[j].first + 1;
        const uint32_t ones_before = ones[i] - ones[s];
        const uint32_t zeros = n - (ones[s + n] - ones[s]);
        const uint32_t to =
            (key[i] >> bit) & 1u ? s + zeros + ones_before : uint32_t(i) - ones_before;
        key_out[to] = key[i];
        value_out[to] = value[i];
      });
      current_ ^= 1;
    }
  }

 private:
  Backend& backend_;
  Buffer<uint32_t> keys_[2], values_[2];
  Buffer<uint32_t> node_start_{backend_, 0}, flags_{backend_, 0}, scan_{backend_, 0};
  int current_ = 0;
};

// What the stages of one build share, in the backend's memory and copied by value into their
// launches: per sorted position the triangle there (a position of the source) and its box, moved
// together as nodes sort; the tree's nodes; the word the root's index goes to (kNoNode while the
// per-node stage is to build the root); and the list of nodes left to the per-node stage.
struct StageArrays {
  uint32_t* order;
  Aabb* box;
  BvhNode* nodes;
  uint32_t* root;
  SmallSubtree* small;
  uint32_t* small_count;

  // Leaves the positions of `s` to the per-node stage.
  CAUSTICA_HDI void leave_small(const SmallSubtree& s) const {
    small[atomic_fetch_add(small_count, 1u)] = s;
  }
};

// The buffers behind a build's StageArrays.
struct StageBuffers {
  StageBuffers(Backend& backend, uint32_t count)
      : orders(backend, count),
        boxes(backend, count),
        root_word(backend, 1),
        small_list(backend, count / 2 + 1),
        small_counter(backend, 1) {}

  Buffer<uint32_t> orders;
  Buffer<Aabb> boxes;
  Buffer<uint32_t> root_word;
  Buffer<SmallSubtree> small_list;
  Buffer<uint32_t> small_counter;
};

// The arrays of `buffers` as a build starts: every sorted position holds its own triangle of
// `source` and that triangle's box, the root is unset and no node is left to the per-node stage.
StageArrays start_stages(Backend& backend, Bvh& bvh, const TriangleVertices* source,
                         StageBuffers& buffers) {
  const StageArrays a{buffers.orders.data(),     buffers.boxes.data(),
                      bvh.nodes.data(),          buffers.root_word.data(),
                      buffers.small_list.data(), buffers.small_counter.data()};
  uint32_t* order = a.order;
  Aabb* box = a.box;
  parallel_for(backend, "binned_sah_boxes", bvh.leaf_count, [=] CAUSTICA_HD(size_t i) {
    order[i] = uint32_t(i);
    box[i] = triangle_bounds(source[i]);
  });
  backend.fill_bytes(a.root, 0xff, sizeof(uint32_t));  // kNoNode
  backend.fill_bytes(a.small_count, 0, sizeof(uint32_t));
  return a;
}

// The `segment_count` segments in position order, for a build over `count` sorted triangles.
Buffer<SmallSubtree> sorted_segments(Backend& backend, const SmallSubtree* segments,
                                     uint32_t segment_count, uint32_t count) {
  Buffer<uint32_t> segment_keys(backend, segment_count), segment_index(backend, segment_count);
  uint32_t* seg_key = segment_keys.data();
  uint32_t* seg_index = segment_index.data();
  parallel_for(backend, "binned_sah_segment_keys", segment_count, [=] CAUSTICA_HD(size_t i) {
    seg_key[i] = segments[i].first;
    seg_index[i] = uint32_t(i);
  });
  backend.sort_pairs(seg_key, seg_index, segment_count, int(bits_for(count)));
  Buffer<SmallSubtree> sorted(backend, segment_count);
  SmallSubtree* seg = sorted.data();
  parallel_for(backend, "binned_sah_segment_order", segment_count,
               [=] CAUSTICA_HD(size_t i) { seg[i] = segments[seg_index[i]]; });
  return sorted;
}

// The box and the centroid box of the one segment `seg`, as a build from the root has, into its
// cell by two reductions: every chunk would flush into the one cell, and chunks long enough to
// keep those flushes few leave a GPU idle. Returns the segment's box.
Aabb reduce_only_segment(Backend& backend, const SmallSubtree* seg, const Aabb* box,
                         BinCell* seg_cell) {
  SmallSubtree only;
  backend.copy_to_host(&only, seg, sizeof(SmallSubtree));
  const uint32_t n = only.last - only.first + 1;
  Buffer<Aabb> centroid_boxes(backend, n);
  Aabb* centroid_box = centroid_boxes.data();
  const Aabb* range = box + only.first;
  parallel_for(backend, "binned_sah_root_centroids", n, [=] CAUSTICA_HD(size_t i) {
    const Vec3f c = range[i].center();
    centroid_box[i] = Aabb{c, c};
  });
  const Aabb b = backend.reduce_bounds(range, n), c = backend.reduce_bounds(centroid_box, n);
  BinCell cell;
  cell.count = n;
  for (int a = 0; a < 3; ++a) {
    cell.lower[a] = ordered_bits(b.lower[a]);
    cell.upper[a] = ordered_bits(b.upper[a]);
    cell.centroid_lower[a] = ordered_bits(c.lower[a]);
    cell.centroid_upper[a] = ordered_bits(c.upper[a]);
  }
  backend.copy_to_device(seg_cell, &cell, sizeof(BinCell));
  return b;
}

// The box and the centroid box of each of the `segment_count` segments `seg` (in position order)
// into its cell, reduced over chunks of the `count` sorted positions.
void reduce_segment_bins(Backend& backend, const SmallSubtree* seg, uint32_t segment_count,
                         uint32_t count, const Aabb* box, BinCell* seg_cell) {
  parallel_for(backend, "binned_sah_segment_clear", segment_count,
               [=] CAUSTICA_HD(size_t c) { clear_bin(seg_cell[c]); });
  // Segments hold at most the hybrid's cut of triangles, so short chunks flush into each cell a
  // few hundred times at most.
  const size_t chunks = (size_t(count) + kBinReductionChunk - 1) / kBinReductionChunk;
  parallel_for(backend, "binned_sah_segment_bounds", chunks, [=] CAUSTICA_HD(size_t c) {
    const uint32_t begin = uint32_t(c * kBinReductionChunk);
    const uint32_t end = begin + kBinReductionChunk < count ? begin + kBinReductionChunk : count;
    uint32_t run = kNoNode;
    RunningBin running;
    // The last segment starting at or before p, found once and then followed along the chunk.
    uint32_t last_started = node_holding(seg, segment_count, begin);
    for (uint32_t p = begin; p < end; ++p) {
      const uint32_t next = last_started == kNoNode ? 0u : last_started + 1;
      if (next < segment_count && seg[next].first <= p) last_started = next;
      const uint32_t j =
          last_started != kNoNode && p <= seg[last_started].last ? last_started : kNoNode;
      if (j != run) {
        if (run != kNoNode) running.flush_into(seg_cell[run]);
        run = j;
      }
      if (j != kNoNode) running.add(box[p]);
    }
    if (run != kNoNode) running.flush_into(seg_cell[run]);
  });
}

// Segments too small or too degenerate to bin go to the per-node stage at once; the others become
// the first level's nodes, in position order, in `level_nodes`. Returns how many those are.
uint32_t first_level_nodes(Backend& backend, const BinnedSahSchedule& schedule,
                           const SmallSubtree* seg, uint32_t segment_count, const BinCell* seg_cell,
                           const StageArrays& a, Buffer<LargeNode>& level_nodes) {
  Buffer<uint32_t> large_flags(backend, segment_count);
  uint32_t* large_slot = large_flags.data();
  parallel_for(backend, "binned_sah_segment_split", segment_count, [=] CAUSTICA_HD(size_t j) {
    Aabb b, centroids;
    read_bin(seg_cell[j], b, centroids);
    const SmallSubtree s = seg[j];
    large_slot[j] = stays_large(schedule, s.last - s.first + 1, centroids, false) ? 1u : 0u;
    if (!large_slot[j]) a.leave_small(s);
  });
  const uint32_t node_count = backend.exclusive_scan(large_slot, large_slot, segment_count);
  level_nodes.resize_discard(node_count);
  LargeNode* first_level = level_nodes.data();
  parallel_for(backend, "binned_sah_segment_nodes", segment_count, [=] CAUSTICA_HD(size_t j) {
    Aabb b, centroids;
    read_bin(seg_cell[j], b, centroids);
    const SmallSubtree s = seg[j];
    const uint32_t size = s.last - s.first + 1;
    if (stays_large(schedule, size, centroids, false))
      first_level[large_slot[j]] = {
          s.first, s.last, s.parent, s.side, b, centroids, schedule.bins_for(size)};
  });
  return node_count;
}

// The first data-parallel level's nodes from the segments, in `level_nodes`, the box and the
// centroid box of each segment reduced over its sorted positions (one bin per segment) deciding
// which start there. Returns the level's node count.
uint32_t start_from_segments(Backend& backend, Bvh& bvh, const SmallSubtree* segments,
                             uint32_t segment_count, bool root_listed,
                             const BinnedSahSchedule& schedule, const StageArrays& a,
                             Buffer<LargeNode>& level_nodes) {
  const Buffer<SmallSubtree> sorted =
      sorted_segments(backend, segments, segment_count, bvh.leaf_count);
  const SmallSubtree* seg = sorted.data();
  Buffer<BinCell> segment_cells(backend, segment_count);
  BinCell* seg_cell = segment_cells.data();
  if (segment_count == 1) {
    const Aabb b = reduce_only_segment(backend, seg, a.box, seg_cell);
    // When the root is that segment, its box is the tree's bounds.
    if (root_listed) bvh.bounds = b;
  } else {
    reduce_segment_bins(backend, seg, segment_count, bvh.leaf_count, a.box, seg_cell);
  }
  return first_level_nodes(backend, schedule, seg, segment_count, seg_cell, a, level_nodes);
}

// The low bits of a level's (node << bits | bin) keys, which number a node's bins, the huge one
// included. Throws std::invalid_argument when the keys of `count` triangles need more than 32 bits.
int key_bin_bits_for(const BinnedSahSchedule& schedule, uint32_t count) {
  const int key_bin_bits = int(bits_for(schedule.max_bins() + 1));
  // A level's nodes are disjoint and each holds more than the per-node limit, which bounds their
  // number and so the key's node bits.
  const uint32_t most_nodes = count / (schedule.per_node_limit() + 1) + 1;
  if (int(bits_for(most_nodes)) + key_bin_bits > 32) {
    throw std::invalid_argument(
        "binned-sah stages " + binned_sah_stages_text(schedule) + ": " + std::to_string(count) +
        " triangles make more (node, bin) keys than 32 bits hold; raise the per-node limit or "
        "use fewer bins");
  }
  return key_bin_bits;
}

// One data-parallel level as its launches see it: its nodes, in position order, the sorted
// positions of their triangles (`m` of them), and the bits of a key that number a node's bins.
struct Level {
  const LargeNode* nodes;
  uint32_t node_count;
  uint32_t* pos;
  uint32_t m;
  int key_bin_bits;
  bool last;  // past it the nodes still large go to the per-node stage
};

// The positions of the first level's nodes' triangles, in order, into `element_pos` (a position's
// node follows from it, node_holding, which saves a second compaction per level); returns how
// many.
uint32_t first_level_elements(Backend& backend, const LargeNode* first_level, uint32_t first_count,
                              uint32_t count, uint8_t* kept, uint32_t* element_pos) {
  parallel_for(backend, "binned_sah_elements", count, [=] CAUSTICA_HD(size_t p) {
    const uint32_t j = node_holding(first_level, first_count, uint32_t(p));
    kept[p] = j != kNoNode && p <= first_level[j].last;
  });
  return uint32_t(backend.select_flagged(nullptr, kept, count, element_pos));
}

// Bins each node's triangles along its longest centroid axis (the node's cells cleared on the way),
// then puts every node's triangles in bin order: a stable order, with nodes numbered in position
// order, so each node's triangles stay within its positions. The keys stay sorted in `bin_order`,
// the triangles and boxes in that order in `moved_order` and `moved_box`.
void bin_and_reorder(Backend& backend, const Level& level, BinnedSahReorder reorder,
                     BinOrder& bin_order, const StageArrays& a, BinCell* cell,
                     uint32_t* moved_order, Aabb* moved_box) {
  const LargeNode* level_node = level.nodes;
  const uint32_t node_count = level.node_count, m = level.m;
  const int key_bin_bits = level.key_bin_bits;
  const uint32_t* pos = level.pos;
  uint32_t* order = a.order;
  Aabb* box = a.box;
  {
    uint32_t* key = bin_order.keys();
    uint32_t* value = bin_order.values();
    parallel_for(backend, "binned_sah_bin_keys", m, [=] CAUSTICA_HD(size_t i) {
      const uint32_t p = pos[i];
      const uint32_t j = node_holding(level_node, node_count, p);
      const LargeNode& n = level_node[j];
      key[i] = j << key_bin_bits | BinMap::of(n).bin(box[p], n.box.half_area());
      value[i] = uint32_t(i);
      if (p - n.first <= n.bins) clear_bin(cell[p]);
    });
  }
  bin_order.sort(reorder, level_node, node_count, m, key_bin_bits);
  const uint32_t* value = bin_order.values();
  parallel_for(backend, "binned_sah_gather", m, [=] CAUSTICA_HD(size_t i) {
    moved_order[i] = order[pos[value[i]]];
    moved_box[i] = box[pos[value[i]]];
  });
  parallel_for(backend, "binned_sah_scatter", m, [=] CAUSTICA_HD(size_t i) {
    order[pos[i]] = moved_order[i];
    box[pos[i]] = moved_box[i];
  });
}

// The bins' counts and bounds, over chunks of the elements sorted by their keys `key`.
void reduce_level_bins(Backend& backend, const Level& level, const uint32_t* key,
                       const Aabb* moved_box, BinCell* cell) {
  const LargeNode* level_node = level.nodes;
  const uint32_t m = level.m;
  const int key_bin_bits = level.key_bin_bits;
  const uint32_t bin_mask = (1u << key_bin_bits) - 1u;
  auto cell_of = [=] CAUSTICA_HD(uint32_t k) {
    return level_node[k >> key_bin_bits].first + (k & bin_mask);
  };
  const size_t chunks = (m + kBinReductionChunk - 1) / kBinReductionChunk;
  parallel_for(backend, "binned_sah_bins", chunks, [=] CAUSTICA_HD(size_t c) {
    const uint32_t begin = uint32_t(c * kBinReductionChunk);
    const uint32_t end = begin + kBinReductionChunk < m ? begin + kBinReductionChunk : m;
    uint32_t run_key = key[begin];
    RunningBin running;
    for (uint32_t i = begin; i < end; ++i) {
      if (key[i] != run_key) {
        running.flush_into(cell[cell_of(run_key)]);
        run_key = key[i];
      }
      running.add(moved_box[i]);
    }
    running.flush_into(cell[cell_of(run_key)]);
  });
}

// Each node's split into `split_of`; its slot, leaf children and small children are written at
// once, and its large children counted in `more` for the next level.
void split_level_nodes(Backend& backend, const Level& level, const BinnedSahSchedule& schedule,
                       const BinCell* cell, const StageArrays& a, NodeSplit* split_of,
                       uint32_t* more) {
  const LargeNode* level_node = level.nodes;
  const bool last_level = level.last;
  BvhNode* nodes = a.nodes;
  uint32_t* root = a.root;
  parallel_for(backend, "binned_sah_split", level.node_count, [=] CAUSTICA_HD(size_t j) {
    const LargeNode n = level_node[j];
    const NodeSplit s = sweep_bins(n, cell + n.first);
    split_of[j] = s;
    more[j] = 0;
    if (!s.binned) {
      // The root stays unset, which tells the host that the per-node stage builds it.
      if (n.parent != kNoParent)
        nodes[n.parent].child[n.side] = BvhChild{n.box.lower, kNoNode, n.box.upper};
      a.leave_small({n.parent, n.side, n.first, n.last});
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
      if (stays_large(schedule, size, child_centroids[side], last_level)) {
        ++large;
      } else if (size == 1) {
        nodes[s.mid].child[side] = BvhChild{b.lower, kLeafFlag | first[side], b.upper};
      } else {
        // The per-node stage reads the range's box from its slot.
        nodes[s.mid].child[side] = BvhChild{b.lower, kNoNode, b.upper};
        a.leave_small({s.mid, side, first[side], last[side]});
      }
    }
    more[j] = large;
  });
}

// The next level's nodes, the large children in position order, into `next_nodes`, each placed by
// the scan of the counts in `more`; `child_next` gets each child's index among them, or kNoNode.
// Returns how many there are.
uint32_t next_level_nodes(Backend& backend, const Level& level, const BinnedSahSchedule& schedule,
                          const NodeSplit* split_of, uint32_t* more, Buffer<LargeNode>& next_nodes,
                          Buffer<uint32_t>& child_next) {
  const LargeNode* level_node = level.nodes;
  const uint32_t node_count = level.node_count;
  const bool last_level = level.last;
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
      if (stays_large(schedule, size, child_centroids[side], last_level)) {
        next_node_list[slot] = {first[side],
                                last[side],
                                s.mid,
                                side,
                                child_box[side],
                                child_centroids[side],
                                schedule.bins_for(size)};
        child_index[2 * j + side] = slot++;
      } else {
        child_index[2 * j + side] = kNoNode;
      }
    }
  });
  return next_count;
}

// The positions of the large children's elements, in position order, into `next_pos`; returns how
// many.
uint32_t partition_elements(Backend& backend, const Level& level, const uint32_t* key,
                            const NodeSplit* split_of, const uint32_t* child_index, uint8_t* kept,
                            uint32_t* next_pos) {
  const uint32_t* pos = level.pos;
  const int key_bin_bits = level.key_bin_bits;
  parallel_for(backend, "binned_sah_partition", level.m, [=] CAUSTICA_HD(size_t i) {
    const uint32_t j = key[i] >> key_bin_bits;
    const uint32_t side = pos[i] <= split_of[j].mid ? 0u : 1u;
    kept[i] = child_index[2 * j + side] != kNoNode;
  });
  return uint32_t(backend.select_flagged(level.pos, kept, level.m, next_pos));
}

// The data-parallel levels over `count` sorted triangles, from the first level's `node_count`
// nodes in `level_nodes` until every node has gone to a leaf or to the per-node stage.
void data_parallel_levels(Backend& backend, uint32_t count, const BinnedSahSchedule& schedule,
                          const StageArrays& a, Buffer<LargeNode>& level_nodes,
                          uint32_t node_count) {
  // Per element of the stage (a triangle of a large node): its position.
  Buffer<uint32_t> element_pos(backend, count);
  Buffer<uint32_t> next_pos(backend, count);
  Buffer<uint8_t> keep(backend, count);
  uint32_t element_count = first_level_elements(backend, level_nodes.data(), node_count, count,
                                                keep.data(), element_pos.data());
  Buffer<uint32_t> moved_orders(backend, count);
  Buffer<Aabb> moved_boxes(backend, count);
  // A node's cells start at its first position (LargeNode), so one cell a position covers every
  // level.
  Buffer<BinCell> cells(backend, count);
  Buffer<NodeSplit> splits(backend, 0);
  Buffer<uint32_t> continuing(backend, 0), child_next(backend, 0);
  Buffer<LargeNode> next_nodes(backend, 0);
  const int key_bin_bits = key_bin_bits_for(schedule, count);
  BinOrder bin_order(backend, count);
  for (int l = 0; node_count > 0; ++l) {
    const Level level{level_nodes.data(), node_count,   element_pos.data(),
                      element_count,      key_bin_bits, l + 1 >= kMaxDataParallelLevels};
    bin_and_reorder(backend, level, schedule.reorder, bin_order, a, cells.data(),
                    moved_orders.data(), moved_boxes.data());
    reduce_level_bins(backend, level, bin_order.keys(), moved_boxes.data(), cells.data());
    splits.resize_discard(node_count);
    continuing.resize_discard(node_count);
    split_level_nodes(backend, level, schedule, cells.data(), a, splits.data(), continuing.data());
    const uint32_t next_count = next_level_nodes(backend, level, schedule, splits.data(),
                                                 continuing.data(), next_nodes, child_next);
    element_count = partition_elements(backend, level, bin_order.keys(), splits.data(),
                                       child_next.data(), keep.data(), next_pos.data());
    std::swap(element_pos, next_pos);
    std::swap(level_nodes, next_nodes);
    node_count = next_count;
  }
}

// The triangles of `source` and their ids (`source_ids`, or their positions there when null) in
// leaf order into `out_triangles` and `out_ids`, then the small nodes finished by the per-node
// stage, the root among them when it is listed and no data-parallel level split it.
void emit_leaves(Backend& backend, Bvh& bvh, const TriangleVertices* source,
                 const uint32_t* source_ids, bool root_listed, const StageArrays& a,
                 Buffer<TriangleVertices>& out_triangles, Buffer<uint32_t>& out_ids) {
  const uint32_t count = bvh.leaf_count;
  out_triangles.resize_discard(count);
  out_ids.resize_discard(count);
  TriangleVertices* sorted = out_triangles.data();
  uint32_t* ids = out_ids.data();
  const uint32_t* order = a.order;
  parallel_for(backend, "binned_sah_leaf_order", count, [=] CAUSTICA_HD(size_t p) {
    sorted[p] = source[order[p]];
    ids[p] = source_ids != nullptr ? source_ids[order[p]] : order[p];
  });
  uint32_t small_count = 0;
  backend.copy_to_host(&small_count, a.small_count, sizeof(uint32_t));
  bool root_small = false;
  if (root_listed) {
    uint32_t root_node = kNoNode;
    backend.copy_to_host(&root_node, a.root, sizeof(uint32_t));
    // Unset when the root went to the per-node stage, which then sets it.
    root_small = root_node == kNoNode;
    if (!root_small) bvh.root = root_node;
  }
  rebuild_small_subtrees(backend, bvh, a.small, small_count, out_triangles, out_ids, root_small);
}

// The data-parallel stages and then the per-node stage over `segment_count` disjoint subtrees of
// `bvh` (rebuild_subtrees_by_binned_sah), whose triangles at sorted position p are source[p] with
// original index source_ids[p] (p itself when source_ids is null). Writes the triangles and their
// ids in the new leaf order to `out_triangles` and `out_ids`, and, when the root is listed, the
// root and the bounds to `bvh`.
void binned_sah_stages(Backend& backend, Bvh& bvh, const TriangleVertices* source,
                       const uint32_t* source_ids, const SmallSubtree* segments,
                       uint32_t segment_count, bool root_listed, const BinnedSahSchedule& schedule,
                       Buffer<TriangleVertices>& out_triangles, Buffer<uint32_t>& out_ids) {
  StageBuffers buffers(backend, bvh.leaf_count);
  const StageArrays a = start_stages(backend, bvh, source, buffers);
  Buffer<LargeNode> level_nodes(backend, 0);
  uint32_t node_count = 0;
  if (segment_count > 0) {
    node_count = start_from_segments(backend, bvh, segments, segment_count, root_listed, schedule,
                                     a, level_nodes);
  }
  if (node_count > 0)
    data_parallel_levels(backend, bvh.leaf_count, schedule, a, level_nodes, node_count);
  emit_leaves(backend, bvh, source, source_ids, root_listed, a, out_triangles, out_ids);
}

}  // namespace

void rebuild_subtrees_by_binned_sah(Backend& backend, BinaryTriangleBvh& tree,
                                    const SmallSubtree* segments, uint32_t segment_count,
                                    bool root_listed, const BinnedSahSchedule& schedule) {
  if (segment_count == 0) return;
  Buffer<TriangleVertices> triangles(backend, 0);
  Buffer<uint32_t> ids(backend, 0);
  binned_sah_stages(backend, tree.bvh, tree.triangles.data(), tree.triangle_ids.data(), segments,
                    segment_count, root_listed, schedule, triangles, ids);
  tree.triangles = std::move(triangles);
  tree.triangle_ids = std::move(ids);
}

BinaryTriangleBvh build_binned_sah_bvh(Backend& backend, const TriangleVertices* triangles,
                                       uint32_t count, const BinnedSahSchedule& schedule) {
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
  binned_sah_stages(backend, out.bvh, triangles, nullptr, root_segment.data(), 1, true, schedule,
                    out.triangles, out.triangle_ids);
  return out;
}

BinnedSahSchedule parse_binned_sah_schedule(std::string_view text, BinnedSahReorder reorder) {
  BinnedSahSchedule schedule;
  schedule.reorder = reorder;
  if (std::optional<std::string> problem = parse_binned_sah_stages(text, schedule))
    throw std::invalid_argument("binned-sah stages: " + *problem);
  return schedule;
}

}  // namespace caustica
