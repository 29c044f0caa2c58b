#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "renderer/accel/bvh8.h"
#include "renderer/accel/wide_sah_cost.h"
#include "renderer/base/atomic.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {
namespace {

// A child of the node being made: a binary subtree, whole.
struct WideChild {
  Aabb box;
  uint32_t id;    // kLeafFlag | sorted position, or a binary node
  uint32_t size;  // triangles
};

CAUSTICA_HDI WideChild child_of(const BvhNode& n, int c) {
  return {n.child[c].bounds(), n.child[c].index, n.child[c].unused};
}

// Whether `e` is opened into its two halves while a slot is free: always when it is too large
// for a leaf; a small one when its halves' boxes cost fewer triangle tests than its own box.
CAUSTICA_HDI bool worth_opening(const BvhNode* nodes, const WideChild& e) {
  if (is_leaf(e.id)) return false;
  if (e.size > kBvh8LeafTriangles) return true;
  const BvhNode n = nodes[e.id];
  const WideChild a = child_of(n, 0), b = child_of(n, 1);
  return float(a.size) * a.box.half_area() + float(b.size) * b.box.half_area() <
         float(e.size) * e.box.half_area();
}

// The child of e[0, m) with the largest box among those `eligible` takes, the first on ties; -1
// for none.
template <typename Eligible>
CAUSTICA_HDI int widest(const WideChild* e, int m, Eligible eligible) {
  int best = -1;
  float best_area = -1.0f;
  for (int i = 0; i < m; ++i) {
    if (eligible(e[i]) && e[i].box.half_area() > best_area) {
      best_area = e[i].box.half_area();
      best = i;
    }
  }
  return best;
}

// 2^e as a double, from its bits, for e in the normal range.
CAUSTICA_HDI double power_of_two(int e) {
  const uint64_t bits = uint64_t(e + 1023) << 52;
  double d;
  memcpy(&d, &bits, sizeof d);
  return d;
}

// The grid step on one axis: the smallest power of two 2^e with 255 steps covering `extent`,
// returned as e + 127 (a float's exponent bits), within a normal float's range.
CAUSTICA_HDI uint32_t grid_exponent(double extent) {
  if (!(extent > 0.0)) return 1;
  // The exponent of extent / 255 from its bits, then corrected by exact comparisons.
  const double x = extent / 255.0;
  uint64_t bits;
  memcpy(&bits, &x, sizeof bits);
  int e = int((bits >> 52) & 0x7ff) - 1023 + 1;
  if (e < -126) e = -126;
  if (e > 127) e = 127;
  while (e < 127 && 255.0 * power_of_two(e) < extent) ++e;
  while (e > -126 && 255.0 * power_of_two(e - 1) >= extent) --e;
  return uint32_t(e) + 127u;
}

// Slot assignment after Ylitie et al. sec. 3.1: slot s stands for the ray octant s (bit a set:
// negative along axis a), and takes the child that lies furthest back along that octant's
// diagonal from the node's centre, so that rays of that octant meet it first. Greedy: the
// cheapest (child, slot) pair left is taken, in index order on ties.
CAUSTICA_HDI void assign_slots(const WideChild* e, int m, const Aabb& box, int slot_of[8]) {
  const Vec3f centre = (box.lower + box.upper) * 0.5f;
  float cost[8][8];
  for (int i = 0; i < m; ++i) {
    const Vec3f d = (e[i].box.lower + e[i].box.upper) * 0.5f - centre;
    for (int s = 0; s < 8; ++s) {
      cost[i][s] = ((s & 1) ? -d.x : d.x) + ((s & 2) ? -d.y : d.y) + ((s & 4) ? -d.z : d.z);
    }
    slot_of[i] = -1;
  }
  bool taken[8] = {};
  for (int round = 0; round < m; ++round) {
    int best_i = -1, best_s = -1;
    float best = INFINITY;
    for (int i = 0; i < m; ++i) {
      if (slot_of[i] >= 0) continue;
      for (int s = 0; s < 8; ++s) {
        if (taken[s]) continue;
        if (best_i < 0 || cost[i][s] < best) {
          best = cost[i][s];
          best_i = i;
          best_s = s;
        }
      }
    }
    slot_of[best_i] = best_s;
    taken[best_s] = true;
  }
}

struct CollapseState {
  const BvhNode* binary;
  const uint32_t* leaf_pieces;     // per binary node
  const TriangleVertices* sorted;  // the binary tree's leaf order
  const uint32_t* sorted_ids;
  const Aabb* root_box;  // for a single-triangle tree, whose root is a leaf
  uint32_t* binary_ref;  // per wide node: the binary subtree it stands for
  Bvh8Node* nodes;
  TriangleVertices* triangles;  // leaf order
  uint32_t* triangle_ids;
  uint32_t* counters;  // [0] wide nodes handed out, [1] leaf triangles handed out
};

// Makes wide node `w` from the binary subtree it stands for: up to eight children, opened
// largest box first, then their slots, grid and triangles.
CAUSTICA_HDI void make_wide_node(const CollapseState& s, uint32_t w) {
  const uint32_t ref = s.binary_ref[w];
  WideChild e[8];
  int m = 0;
  if (is_leaf(ref)) {
    e[m++] = {*s.root_box, ref, 1};
  } else {
    const BvhNode n = s.binary[ref];
    e[m++] = child_of(n, 0);
    e[m++] = child_of(n, 1);
  }
  // Children larger than one node of leaves can hold are opened first, largest box first. Then
  // a child that fits in one node is dissolved into its leaves where the slots it frees hold
  // them all (else it becomes that one node); then small ones are split where slots are left.
  auto open = [&](int i) {
    const BvhNode n = s.binary[e[i].id];
    e[i] = child_of(n, 0);
    e[m++] = child_of(n, 1);
  };
  auto too_large = [](const WideChild& c) { return !is_leaf(c.id) && c.size > kBvh8NodeTriangles; };
  auto dissolvable = [&](const WideChild& c) {
    return !is_leaf(c.id) && c.size > kBvh8LeafTriangles && c.size <= kBvh8NodeTriangles &&
           m - 1 + int(s.leaf_pieces[c.id]) <= 8;
  };
  auto worth_splitting = [&](const WideChild& c) { return worth_opening(s.binary, c); };
  while (m < 8) {
    const int i = widest(e, m, too_large);
    if (i < 0) break;
    open(i);
  }
  while (m < 8) {
    const int i = widest(e, m, dissolvable);
    if (i < 0) break;
    // Split until none of its pieces (at i and from first_new on) is too large for a leaf.
    const int first_new = m;
    for (int at = i; at >= 0;) {
      open(at);
      at = -1;
      for (int k = 0; k < m; ++k) {
        if ((k == i || k >= first_new) && !is_leaf(e[k].id) && e[k].size > kBvh8LeafTriangles)
          at = k;
      }
    }
  }
  while (m < 8) {
    const int i = widest(e, m, worth_splitting);
    if (i < 0) break;
    open(i);
  }

  Aabb box;
  uint32_t internal = 0, leaf_triangles = 0;
  for (int i = 0; i < m; ++i) {
    box.extend(e[i].box);
    if (!is_leaf(e[i].id) && e[i].size > kBvh8LeafTriangles) {
      ++internal;
    } else {
      leaf_triangles += e[i].size;
    }
  }
  int slot_of[8];
  assign_slots(e, m, box, slot_of);
  int in_slot[8] = {-1, -1, -1, -1, -1, -1, -1, -1};
  for (int i = 0; i < m; ++i) in_slot[slot_of[i]] = i;

  Bvh8Node out;
  double inv_step[3];
  for (int a = 0; a < 3; ++a) {
    out.p[a] = box.lower[a];
    const uint32_t bits = grid_exponent(double(box.upper[a]) - double(box.lower[a]));
    out.exponent[a] = uint8_t(bits);
    inv_step[a] = power_of_two(127 - int(bits));
  }
  out.imask = 0;
  out.child_base = internal ? atomic_fetch_add(&s.counters[0], internal) : 0;
  out.triangle_base = leaf_triangles ? atomic_fetch_add(&s.counters[1], leaf_triangles) : 0;
  uint32_t rank = 0, offset = 0;
  uint8_t* lower[3] = {out.lower_x, out.lower_y, out.lower_z};
  uint8_t* upper[3] = {out.upper_x, out.upper_y, out.upper_z};
  for (int slot = 0; slot < 8; ++slot) {
    const int i = in_slot[slot];
    if (i < 0) {
      out.meta[slot] = 0;
      for (int a = 0; a < 3; ++a) {
        lower[a][slot] = 0xff;
        upper[a][slot] = 0;
      }
      continue;
    }
    const WideChild& c = e[i];
    // Rounded outwards, and further by a bound on the double differences' rounding (the planes
    // p + q 2^e are exact reals; a child near 0 in a node far from it loses bits in c - p): the
    // quantised box holds the child's.
    for (int a = 0; a < 3; ++a) {
      const double p = out.p[a], lower_c = c.box.lower[a], upper_c = c.box.upper[a];
      const double slack_lo = (fabs(lower_c) + fabs(p)) * 0x1p-50 * inv_step[a];
      const double slack_hi = (fabs(upper_c) + fabs(p)) * 0x1p-50 * inv_step[a];
      const double lo = floor((lower_c - p) * inv_step[a] - slack_lo);
      const double hi = ceil((upper_c - p) * inv_step[a] + slack_hi);
      lower[a][slot] = uint8_t(lo < 0.0 ? 0.0 : lo > 255.0 ? 255.0 : lo);
      upper[a][slot] = uint8_t(hi < 0.0 ? 0.0 : hi > 255.0 ? 255.0 : hi);
    }
    if (!is_leaf(c.id) && c.size > kBvh8LeafTriangles) {
      out.meta[slot] = uint8_t(0x38u | uint32_t(slot));
      out.imask |= uint8_t(1u << slot);
      s.binary_ref[out.child_base + rank++] = c.id;
      continue;
    }
    out.meta[slot] = uint8_t(((1u << c.size) - 1u) << 5 | offset);
    // The leaf's triangles, from its small subtree (at most two levels of binary nodes).
    uint32_t todo[kBvh8LeafTriangles + 1];
    int top = 0;
    todo[top++] = c.id;
    while (top > 0) {
      const uint32_t id = todo[--top];
      if (is_leaf(id)) {
        const uint32_t at = out.triangle_base + offset++;
        s.triangles[at] = s.sorted[leaf_index(id)];
        s.triangle_ids[at] = s.sorted_ids[leaf_index(id)];
      } else {
        todo[top++] = s.binary[id].child[1].index;
        todo[top++] = s.binary[id].child[0].index;
      }
    }
  }
  s.nodes[w] = out;
}

}  // namespace

Bvh8View Bvh8::view() const {
  float reach = 0.0f;
  for (int a = 0; a < 3; ++a) {
    // A grid reaches at most one node extent past its node's box.
    const float r =
        fmaxf(fabsf(bounds.lower[a]), fabsf(bounds.upper[a])) + (bounds.upper[a] - bounds.lower[a]);
    reach = fmaxf(reach, r);
  }
  return {nodes.data(), triangles.data(), triangle_ids.data(), count, bounds, reach};
}

Bvh8 collapse_to_bvh8(Backend& backend, const ClusteredTriangleBvh& binary) {
  Bvh8 out;
  out.nodes.bind(backend);
  out.triangles.bind(backend);
  out.triangle_ids.bind(backend);
  out.count = binary.count;
  out.bounds = binary.bounds;
  const uint32_t n = binary.count;
  if (n == 0) return out;

  // Every wide node but the root stands for a binary subtree of more than kBvh8LeafTriangles
  // triangles, so there are fewer than n of them; the array is trimmed at the end.
  Buffer<Bvh8Node> nodes(backend, n);
  Buffer<uint32_t> binary_ref(backend, n);
  out.triangles.resize_discard(n);
  out.triangle_ids.resize_discard(n);
  Buffer<uint32_t> counters(backend, 2);
  Buffer<Aabb> root_box(backend, 1);
  root_box.upload(std::vector<Aabb>{binary.bounds});
  const uint32_t start[2] = {1, 0};
  backend.copy_to_device(counters.data(), start, sizeof start);
  backend.copy_to_device(binary_ref.data(), &binary.root, sizeof(uint32_t));

  const CollapseState state{binary.nodes.data(),
                            binary.leaf_pieces.data(),
                            binary.triangles.data(),
                            binary.triangle_ids.data(),
                            root_box.data(),
                            binary_ref.data(),
                            nodes.data(),
                            out.triangles.data(),
                            out.triangle_ids.data(),
                            counters.data()};
  uint32_t begin = 0, end = 1;
  while (begin < end) {
    if (++out.depth > uint32_t(kBvh8StackSize / 2)) {
      throw DeviceError("bvh8: the tree is deeper than the traversal's stack allows (" +
                        std::to_string(kBvh8StackSize / 2) + " levels)");
    }
    parallel_for(backend, "bvh8_collapse_level", end - begin,
                 [=] CAUSTICA_HD(size_t i) { make_wide_node(state, begin + uint32_t(i)); });
    uint32_t handed_out = 0;
    backend.copy_to_host(&handed_out, counters.data(), sizeof(uint32_t));
    begin = end;
    end = handed_out;
  }
  out.nodes.resize_discard(end);
  backend.copy_on_device(out.nodes.data(), nodes.data(), size_t(end) * sizeof(Bvh8Node));
  return out;
}

Bvh8 build_bvh8(Backend& backend, const TriangleVertices* triangles, uint32_t count, Curve curve) {
  return collapse_to_bvh8(backend, build_hploc_bvh(backend, triangles, count, curve));
}

namespace {

// An 8-wide node's children's terms (wide_sah_cost), over the quantised boxes traversal tests.
struct Bvh8ChildrenTerms {
  CAUSTICA_HDI float operator()(const Bvh8Node& node, float inv_root) const {
    float sum = 0.0f;
    for (int s = 0; s < 8; ++s) {
      const uint8_t meta = node.meta[s];
      if (meta == 0) continue;
      const float area = bvh8_child_box(node, s).half_area() * inv_root;
      sum += bvh8_slot_is_internal(meta) ? area : float(bvh8_leaf_triangles(meta)) * area;
    }
    return sum;
  }
};

}  // namespace

double sah_cost(Backend& backend, const Bvh8& bvh) {
  return wide_sah_cost(backend, "bvh8_sah_cost_terms", bvh.nodes.data(), bvh.nodes.size(),
                       bvh.count, bvh.bounds.half_area(), Bvh8ChildrenTerms{});
}

}  // namespace caustica
