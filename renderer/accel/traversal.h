// Stack traversal of a TriangleBvh: closest hit (near child first) and any hit (first found).
// One function body serves both backends.
#pragma once

#include "renderer/accel/triangle_bvh.h"

namespace caustica {

// Karras trees over 30-bit codes plus index tie-breaks are at most ~62 levels deep.
constexpr int kTraversalStackSize = 64;

namespace detail {

// Visits leaves along `ray` in near-first order; `on_leaf(sorted_index, t_max&)` tests one
// triangle, may shrink t_max, and returns true to stop the traversal (any hit).
template <typename OnLeaf>
CAUSTICA_HDI void traverse(const TriangleBvhView& bvh, const Ray& ray, float& t_max, OnLeaf on_leaf) {
  if (bvh.count == 0) return;
  Vec3f inv_dir = safe_reciprocal(ray.direction);
  if (intersect_slabs(bvh.bounds, ray.origin, inv_dir, ray.t_min, t_max) > t_max) return;
  if (bvh.count == 1) {
    on_leaf(0u, t_max);
    return;
  }
  uint32_t stack[kTraversalStackSize];
  int top = 0;
  uint32_t node = bvh.root;
  while (true) {
    const BvhNode& n = bvh.nodes[node];
    float t0 = intersect_slabs(n.child_bounds[0], ray.origin, inv_dir, ray.t_min, t_max);
    float t1 = intersect_slabs(n.child_bounds[1], ray.origin, inv_dir, ray.t_min, t_max);
    uint32_t c0 = n.child[0], c1 = n.child[1];
    bool hit0 = t0 <= t_max, hit1 = t1 <= t_max;
    // Leaves are tested at once; only internal children go on the path.
    if (hit0 && is_leaf(c0)) {
      if (on_leaf(leaf_index(c0), t_max)) return;
      hit0 = false;
      hit1 = hit1 && t1 <= t_max;
    }
    if (hit1 && is_leaf(c1)) {
      if (on_leaf(leaf_index(c1), t_max)) return;
      hit1 = false;
    }
    if (hit0 && hit1) {
      if (t1 < t0) {
        uint32_t c = c0;
        c0 = c1;
        c1 = c;
      }
      stack[top++] = c1;
      node = c0;
    } else if (hit0) {
      node = c0;
    } else if (hit1) {
      node = c1;
    } else {
      if (top == 0) return;
      node = stack[--top];
    }
  }
}

}  // namespace detail

CAUSTICA_HDI Hit closest_hit(const TriangleBvhView& bvh, const Ray& ray) {
  Hit hit;
  WatertightRay wray(ray);
  float t_max = ray.t_max;
  detail::traverse(bvh, ray, t_max, [&](uint32_t leaf, float& t_limit) {
    float t, u, v;
    if (intersect_triangle(wray, bvh.triangles[leaf], ray.t_min, t_limit, t, u, v)) {
      t_limit = t;
      hit.t = t;
      hit.u = u;
      hit.v = v;
      hit.triangle = bvh.triangle_ids[leaf];
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
  detail::traverse(bvh, ray, t_max, [&](uint32_t leaf, float& t_limit) {
    float t, u, v;
    blocked = intersect_triangle(wray, bvh.triangles[leaf], ray.t_min, t_limit, t, u, v);
    return blocked;
  });
  return blocked;
}

}  // namespace caustica
