// Closest and any hits in a kd-tree (kd_tree.h), by either of two walks that visit the same
// leaves in the same order, front to back, and so give the same hits:
// - with a stack of 8-byte entries (a node and the end of its ray interval; its start is the end
//   of the interval before it), choosing children by pbrt's rule;
// - stacklessly, by Fabianowski's flags register (his thesis, Alg. 4.1): one bit per level says
//   whether the walk from the root takes the near or the far child of a branching point next,
//   and adding the leaf's parent's bit after a leaf moves on to the next branch; restarts begin
//   at the push-down node, and a 4-entry short stack saves most of them.
// Both test a leaf's triangles against the nearest hit so far and end a closest-hit walk once
// that hit lies inside the leaf's interval; the triangle tests are triangle.h's, so the hits are
// brute force's bit for bit.
#pragma once

#include "renderer/accel/kd_tree.h"

namespace caustica {
namespace detail {

// The ray as the walks read it: origin, 1 / direction and, for a ray starting on a plane, which
// side counts as the near one: the side behind it. pbrt takes only the side ahead (near only when
// t_split <= 0), but a triangle lying in that plane, on the side behind, can still be hit at a t
// just above 0 by rounding, as brute force finds it; so at t_split exactly 0 both sides are
// walked, the one behind for the empty interval [t_a, 0] first.
struct KdRay {
  Vec3f origin, inv;
  bool below_first_on_plane[3];
};

CAUSTICA_HDI KdRay kd_ray(const Ray& ray) {
  KdRay r;
  r.origin = ray.origin;
  r.inv = safe_reciprocal(ray.direction);
  for (int a = 0; a < 3; ++a) r.below_first_on_plane[a] = ray.direction[a] > 0.0f;
  return r;
}

// The ray's interval [t_a, t_b] inside the tree's box within [t_min, t_max], widened by a bound
// on the rounding of the slab distances so that no triangle on the box's faces is missed; false
// when the ray misses the box.
CAUSTICA_HDI bool kd_root_interval(const Aabb& b, const KdRay& r, float t_min, float t_max,
                                   float& t_a, float& t_b) {
  float t_near = t_min, t_far = t_max;
  for (int a = 0; a < 3; ++a) {
    float t0 = (b.lower[a] - r.origin[a]) * r.inv[a];
    float t1 = (b.upper[a] - r.origin[a]) * r.inv[a];
    if (t0 > t1) {
      const float tmp = t0;
      t0 = t1;
      t1 = tmp;
    }
    // Each distance is a subtraction and a product, each rounded once: a few units in the last
    // place of itself.
    t0 -= fabsf(t0) * 0x1p-20f;
    t1 += fabsf(t1) * 0x1p-20f;
    t_near = max_f(t_near, t0);
    t_far = min_f(t_far, t1);
  }
  t_a = t_near;
  t_b = t_far;
  return t_near <= t_far;
}

// Where the walk goes at inner node `n` with interval [t_a, t_b]: the near child (the one the ray
// starts in) and the far one, and the distance to the plane.
struct KdStep {
  uint32_t near, far;
  float t_split;
};

CAUSTICA_HDI KdStep kd_step(const KdNode& n, const KdRay& r) {
  const int a = n.axis();
  const float o = r.origin[a];
  const bool below_first = o < n.split || (o == n.split && r.below_first_on_plane[a]);
  const uint32_t below = n.first_child();
  return {below_first ? below : below + 1, below_first ? below + 1 : below,
          (n.split - o) * r.inv[a]};
}

// Whether a hit at `t` is nearer than anything in nodes whose intervals start at `t_end`, the end
// of the current leaf's: with a margin for the rounding of the plane distance and the hit's.
CAUSTICA_HDI bool kd_hit_before(float t, float t_end) { return t < t_end - t_end * 0x1p-18f; }

// Walks the leaves along the ray front to back with a stack. `leaf(first, count, t_end)` tests
// a leaf's references and returns true to end the walk.
template <typename Leaf>
CAUSTICA_HDI void kd_walk_stack(const KdTreeStackView& tree, const Ray& ray, Leaf leaf) {
  if (tree.node_count == 0) return;
  const KdRay r = kd_ray(ray);
  float t_a, t_b;
  if (!kd_root_interval(tree.bounds, r, ray.t_min, ray.t_max, t_a, t_b)) return;
  struct Entry {
    uint32_t node;
    float t_end;
  };
  static_assert(sizeof(Entry) == 8, "8-byte stack entries");
  Entry stack[kKdMaxLeafDepth + 1];
  int top = 0;
  uint32_t node = 0;
  while (true) {
    KdNode n = tree.nodes[node];
    while (!n.leaf()) {
      const KdStep s = kd_step(n, r);
      if (s.t_split > t_b || s.t_split < 0.0f) {
        node = s.near;
      } else if (s.t_split < t_a) {
        node = s.far;
      } else {
        stack[top++] = {s.far, t_b};
        node = s.near;
        t_b = s.t_split;
      }
      n = tree.nodes[node];
    }
    if (leaf(n.first_ref(), n.ref_count(), t_b)) return;
    if (top == 0) return;
    --top;
    node = stack[top].node;
    t_a = t_b;
    t_b = stack[top].t_end;
  }
}

// Entries of the stackless walk's short stack; when full, a push drops the oldest.
constexpr int kKdShortStack = 4;

// Walks the same leaves in the same order without a stack (Alg. 4.1, with its errata applied:
// the near-only test is t_split > t_b, and it sets the level's flag too).
template <typename Leaf>
CAUSTICA_HDI void kd_walk_stackless(const KdTreeStacklessView& tree, const Ray& ray, Leaf leaf) {
  if (tree.node_count == 0) return;
  const KdRay r = kd_ray(ray);
  float root_a, root_b;
  if (!kd_root_interval(tree.bounds, r, ray.t_min, ray.t_max, root_a, root_b)) return;
  // The push-down node: the deepest node on the walks from the root below which all work that
  // is left lies; restarts begin there, with its interval and its level's flag.
  uint32_t restart_node = 0, restart_flag = 1u << 31;
  float restart_a = root_a, restart_b = root_b;
  uint32_t flags = 0;
  struct Entry {
    uint32_t node;
    float t_end;
  };
  Entry short_stack[kKdShortStack];
  int stacked = 0, top = 0;  // entries held, and the slot of the next push
  uint32_t node = restart_node, flag = restart_flag;
  float t_a = restart_a, t_b = restart_b;
  bool from_restart = true;
  while (true) {
    KdNode n = tree.nodes[node];
    while (!n.leaf()) {
      const KdStep s = kd_step(n, r);
      bool branched_near = false;
      if (s.t_split > t_b || s.t_split < 0.0f) {
        flags |= flag;
        node = s.near;
      } else if (s.t_split < t_a) {
        flags |= flag;
        node = s.far;
      } else if (flags & flag) {
        t_a = s.t_split;
        node = s.far;
      } else {
        short_stack[top] = {s.far, t_b};
        top = (top + 1) % kKdShortStack;
        stacked = stacked < kKdShortStack ? stacked + 1 : kKdShortStack;
        t_b = s.t_split;
        node = s.near;
        branched_near = true;
      }
      flag >>= 1;
      // Until the walk leaves a far child behind, everything left lies below the node it is at.
      if (branched_near) from_restart = false;
      if (from_restart) {
        restart_node = node;
        restart_flag = flag;
        restart_a = t_a;
        restart_b = t_b;
      }
      n = tree.nodes[node];
    }
    // Moves the walk past this leaf: the most recent branching point's flag goes to 1, and those
    // of the levels below it back to 0. With none left, the sum carries out of the register.
    flags += flag << 1;
    if (leaf(n.first_ref(), n.ref_count(), t_b) || flags == 0) return;
    if (stacked > 0) {
      // The far child of that branching point, one level below its flag, now the lowest set bit.
      top = (top + kKdShortStack - 1) % kKdShortStack;
      --stacked;
      node = short_stack[top].node;
      t_a = t_b;
      t_b = short_stack[top].t_end;
      flag = (flags & (0u - flags)) >> 1;
      // Branches above it may still wait: the push-down node stays where it is.
      from_restart = false;
    } else {
      node = restart_node;
      flag = restart_flag;
      t_a = restart_a;
      t_b = restart_b;
      from_restart = true;
    }
  }
}

template <KdTraversal kTraversal, typename Leaf>
CAUSTICA_HDI void kd_walk(const KdTreeView<kTraversal>& tree, const Ray& ray, Leaf leaf) {
  if constexpr (kTraversal == KdTraversal::kStack) {
    kd_walk_stack(tree, ray, leaf);
  } else {
    kd_walk_stackless(tree, ray, leaf);
  }
}

}  // namespace detail

template <KdTraversal kTraversal>
CAUSTICA_HDI Hit closest_hit(const KdTreeView<kTraversal>& tree, const Ray& ray) {
  Hit hit;
  const WatertightRay wray(ray);
  const float t_min = ray.t_min;
  float t_max = ray.t_max;
  detail::kd_walk(tree, ray, [&](uint32_t first, uint32_t count, float t_end) {
    for (uint32_t i = first; i < first + count; ++i) {
      const uint32_t triangle = tree.refs[i];
      float t, u, v;
      // A triangle in several leaves is tested again in each; it can only tie with itself.
      if (intersect_triangle(wray, tree.triangles[triangle], t_min, t_max, t, u, v)) {
        t_max = t;
        hit.t = t;
        hit.u = u;
        hit.v = v;
        hit.triangle = triangle;
      }
    }
    return hit.valid() && detail::kd_hit_before(hit.t, t_end);
  });
  return hit;
}

template <KdTraversal kTraversal>
CAUSTICA_HDI bool any_hit(const KdTreeView<kTraversal>& tree, const Ray& ray) {
  const WatertightRay wray(ray);
  const float t_min = ray.t_min, t_max = ray.t_max;
  bool blocked = false;
  detail::kd_walk(tree, ray, [&](uint32_t first, uint32_t count, float) {
    for (uint32_t i = first; i < first + count && !blocked; ++i) {
      blocked = triangle_blocks(wray, tree.triangles[tree.refs[i]], t_min, t_max);
    }
    return blocked;
  });
  return blocked;
}

}  // namespace caustica
