// Stack traversal of a TriangleBvh: closest hit (near child first) and any hit (first found).
// One function body serves both backends.
#pragma once

#include "renderer/accel/triangle_bvh.h"

namespace caustica {

// Each 4-wide node pushes at most three entries, and the collapsed tree is about half as deep as
// the binary one (at most ~62 levels for 30-bit codes plus index tie-breaks).
constexpr int kTraversalStackSize = 96;

namespace detail {

// Entry distances of the ray into the four child boxes of `n`; +infinity for a miss or an empty
// slot. Written as one loop over the structure-of-arrays fields so it vectorises.
CAUSTICA_HDI void intersect_children(const Bvh4Node& n, Vec3f origin, Vec3f inv_dir, float t_min,
                                     float t_max, float t_out[4]) {
  for (int c = 0; c < 4; ++c) {
    float tx0 = (n.lower_x[c] - origin.x) * inv_dir.x, tx1 = (n.upper_x[c] - origin.x) * inv_dir.x;
    float ty0 = (n.lower_y[c] - origin.y) * inv_dir.y, ty1 = (n.upper_y[c] - origin.y) * inv_dir.y;
    float tz0 = (n.lower_z[c] - origin.z) * inv_dir.z, tz1 = (n.upper_z[c] - origin.z) * inv_dir.z;
    float t_near = max_f(max_f(min_f(tx0, tx1), min_f(ty0, ty1)), max_f(min_f(tz0, tz1), t_min));
    float t_far = min_f(min_f(max_f(tx0, tx1), max_f(ty0, ty1)), min_f(max_f(tz0, tz1), t_max));
    t_out[c] = (t_near <= t_far * 1.00000024f && n.child[c] != kEmptyChild) ? t_near : INFINITY;
  }
}

// Chooses the next node: the internal children of `n` with t[c] <= t_limit, nearest first, the
// rest pushed on the stack; with none, the top of the stack. Returns false when the traversal is
// over. The four (distance, child) pairs go through a fixed sorting network, so that every index
// is known at compile time and the pairs stay in registers on a GPU (an insertion sort indexed
// by a running count put them in local memory).
CAUSTICA_HDI bool descend_near_first(const Bvh4Node& n, const float t[4], float t_limit,
                                     uint32_t* stack, int& top, uint32_t& node) {
  float key[4];
  uint32_t child[4];
  for (int c = 0; c < 4; ++c) {
    key[c] = t[c] <= t_limit ? t[c] : INFINITY;
    child[c] = n.child[c];
  }
  // Selects, not branches: which way each pair goes is data-dependent and would mispredict.
  auto order = [&](int a, int b) {
    const bool swap = key[b] < key[a];
    const float ka = key[a], kb = key[b];
    const uint32_t ca = child[a], cb = child[b];
    key[a] = swap ? kb : ka;
    key[b] = swap ? ka : kb;
    child[a] = swap ? cb : ca;
    child[b] = swap ? ca : cb;
  };
  order(0, 1);
  order(2, 3);
  order(0, 2);
  order(1, 3);
  order(1, 2);
  if (key[3] != INFINITY) stack[top++] = child[3];
  if (key[2] != INFINITY) stack[top++] = child[2];
  if (key[1] != INFINITY) stack[top++] = child[1];
  if (key[0] != INFINITY) {
    node = child[0];
    return true;
  }
  if (top == 0) return false;
  node = stack[--top];
  return true;
}

// Visits the triangles of the leaves along `ray`, nearer subtrees first;
// `on_triangle(sorted_index, t_max&)` tests one triangle, may shrink t_max, and returns true to
// stop the traversal (any hit), even in the middle of a leaf.
template <typename OnTriangle>
CAUSTICA_HDI void traverse(const TriangleBvhView& bvh, const Ray& ray, float& t_max,
                           OnTriangle on_triangle) {
  if (bvh.count == 0) return;
  Vec3f inv_dir = safe_reciprocal(ray.direction);
  if (intersect_slabs(bvh.bounds, ray.origin, inv_dir, ray.t_min, t_max) > t_max) return;
  if (bvh.count == 1) {
    on_triangle(0u, t_max);
    return;
  }
  uint32_t stack[kTraversalStackSize];
  int top = 0;
  uint32_t node = 0;
  while (true) {
    const Bvh4Node n = load_node(bvh.nodes + node);
    float t[4];
    intersect_children(n, ray.origin, inv_dir, ray.t_min, t_max, t);
    // Leaves first, so that their hits shrink t_max before the subtrees are ordered.
    for (int c = 0; c < 4; ++c) {
      if (t[c] <= t_max && is_leaf(n.child[c])) {
        const uint32_t first = leaf_first(n.child[c]), end = first + leaf_count(n.child[c]);
        for (uint32_t i = first; i < end; ++i) {
          if (on_triangle(i, t_max)) return;
        }
        t[c] = INFINITY;
      }
    }
    if (!descend_near_first(n, t, t_max, stack, top, node)) return;
  }
}

}  // namespace detail

CAUSTICA_HDI Hit closest_hit(const TriangleBvhView& bvh, const Ray& ray) {
  Hit hit;
  WatertightRay wray(ray);
  float t_max = ray.t_max;
  detail::traverse(bvh, ray, t_max, [&](uint32_t sorted, float& t_limit) {
    float t, u, v;
    if (intersect_triangle(wray, bvh.triangles[sorted], ray.t_min, t_limit, t, u, v)) {
      t_limit = t;
      hit.t = t;
      hit.u = u;
      hit.v = v;
      hit.triangle = bvh.triangle_ids[sorted];
    }
    return false;
  });
  return hit;
}

// True when anything blocks the open segment (t_min, t_max) of the ray: shadow rays.
CAUSTICA_HDI bool any_hit(const TriangleBvhView& bvh, const Ray& ray) {
  WatertightRay wray(ray);
  float t_max = ray.t_max;
  bool blocked = false;
  detail::traverse(bvh, ray, t_max, [&](uint32_t sorted, float& t_limit) {
    float t, u, v;
    blocked = intersect_triangle(wray, bvh.triangles[sorted], ray.t_min, t_limit, t, u, v);
    return blocked;
  });
  return blocked;
}

// The shadow ray for the open segment from `surface` (a lit point, already moved off its surface)
// to `light` (a point on a light), leaving out the `light_gap` fraction of its length next to the
// light, where an area light's own triangle lies. It starts at the light's end: a ray leaving a
// surface first opens every box around its origin, whose triangles never block it, while one
// arriving from the light meets an occluder first and stops there (dragon with a light above,
// 59% of rays blocked: 1111 -> 1520 Mrays/s on an H200, 3.4 -> 5.2 on two CPU cores).
CAUSTICA_HDI Ray shadow_ray(Vec3f surface, Vec3f light, float light_gap) {
  const Vec3f d = surface - light;
  const float length_d = length(d);
  // A segment of no length blocks nothing: (0, 0) is empty.
  return Ray{light, length_d > 0.0f ? d / length_d : Vec3f(0.0f, 0.0f, 1.0f), length_d * light_gap,
             length_d};
}

// True when anything blocks that segment.
CAUSTICA_HDI bool segment_blocked(const TriangleBvhView& bvh, Vec3f surface, Vec3f light,
                                  float light_gap) {
  return any_hit(bvh, shadow_ray(surface, light, light_gap));
}

}  // namespace caustica
