// Watertight ray/triangle intersection (Woop, Benthin, Wald, "Watertight Ray/Triangle
// Intersection", JCGT 2013): rays are sheared so they run along +z, edge functions are evaluated
// in 2D, and edges shared by two triangles never let a ray slip through.
#pragma once

#include <cfloat>
#include <cmath>

#include "renderer/base/aabb.h"
#include "renderer/base/ray.h"

namespace caustica {

struct TriangleVertices {
  Vec3f p0, p1, p2;
};

// Per-ray constants of the shear; computed once per ray and reused for every triangle.
struct WatertightRay {
  Vec3f origin_k;  // the origin's coordinates along kx, ky and kz
  int kx, ky, kz;
  float sx, sy, sz;

  CAUSTICA_HD explicit WatertightRay(const Ray& ray) {
    const Vec3f d = ray.direction;
    kz = max_dimension(abs(d));
    kx = kz == 2 ? 0 : kz + 1;
    ky = kx == 2 ? 0 : kx + 1;
    if (d[kz] < 0.0f) {  // keep the winding of the sheared triangle
      int tmp = kx;
      kx = ky;
      ky = tmp;
    }
    sx = d[kx] / d[kz];
    sy = d[ky] / d[kz];
    sz = 1.0f / d[kz];
    origin_k = Vec3f(ray.origin[kx], ray.origin[ky], ray.origin[kz]);
  }
};

// A ray's edge functions against one triangle: the weights v and w of p1 and p2, not yet divided
// by det (the sum of all three weights), and the hit distance times det. False when the sheared
// triangle misses the ray's line or is seen edge-on (det 0).
struct ShearedHit {
  float v, w, det, t_scaled;
};

CAUSTICA_HDI bool shear_and_test_edges(const WatertightRay& r, const TriangleVertices& tri,
                                       ShearedHit& h) {
  // Each vertex's coordinates along kx, ky and kz, relative to the origin, read from memory at
  // offsets chosen per ray: picking them out of the loaded vertices took two selects each, 18 of
  // a GPU's 85 instructions per test.
  static_assert(sizeof(TriangleVertices) == 9 * sizeof(float), "three vertices back to back");
  const float* coords = reinterpret_cast<const float*>(&tri);
  const float* vx = coords + r.kx;
  const float* vy = coords + r.ky;
  const float* vz = coords + r.kz;
  const float a_kx = vx[0] - r.origin_k.x, a_ky = vy[0] - r.origin_k.y, a_kz = vz[0] - r.origin_k.z;
  const float b_kx = vx[3] - r.origin_k.x, b_ky = vy[3] - r.origin_k.y, b_kz = vz[3] - r.origin_k.z;
  const float c_kx = vx[6] - r.origin_k.x, c_ky = vy[6] - r.origin_k.y, c_kz = vz[6] - r.origin_k.z;
  // The shear as fused multiply-adds: a vertex's sheared coordinates depend on the vertex and the
  // ray alone, so two triangles sharing an edge still see the same edge. The edge functions below
  // must not fuse: a * b - c * d with both products rounded is exactly -(c * d - a * b), which is
  // what keeps a shared edge watertight.
  float ax = fmaf(-r.sx, a_kz, a_kx), ay = fmaf(-r.sy, a_kz, a_ky);
  float bx = fmaf(-r.sx, b_kz, b_kx), by = fmaf(-r.sy, b_kz, b_ky);
  float cx = fmaf(-r.sx, c_kz, c_kx), cy = fmaf(-r.sy, c_kz, c_ky);
  float u = cx * by - cy * bx;  // weight of p0
  float v = ax * cy - ay * cx;  // weight of p1
  float w = bx * ay - by * ax;  // weight of p2
  // The conditions below are combined with | and &, not || and &&: evaluated whole they are a
  // few chained comparisons, where the short-circuit forms became branches on a GPU.
  if ((u == 0.0f) | (v == 0.0f) | (w == 0.0f)) {
    // Exactly on an edge in float: decide in double, as the paper prescribes.
    u = float(double(cx) * double(by) - double(cy) * double(bx));
    v = float(double(ax) * double(cy) - double(ay) * double(cx));
    w = float(double(bx) * double(ay) - double(by) * double(ax));
  }
  const bool some_negative = (u < 0.0f) | (v < 0.0f) | (w < 0.0f);
  const bool some_positive = (u > 0.0f) | (v > 0.0f) | (w > 0.0f);
  if (some_negative & some_positive) return false;
  h.det = u + v + w;
  if (h.det == 0.0f) return false;
  const float az = r.sz * a_kz, bz = r.sz * b_kz, cz = r.sz * c_kz;
  h.t_scaled = fmaf(w, cz, fmaf(v, bz, u * az));
  h.v = v;
  h.w = w;
  return true;
}

// Two-sided test. On a hit inside (t_min, t_max) returns true with t and the barycentrics of p1
// (u) and p2 (v).
CAUSTICA_HDI bool intersect_triangle(const WatertightRay& r, const TriangleVertices& tri,
                                     float t_min, float t_max, float& t_out, float& u_out,
                                     float& v_out) {
  ShearedHit h;
  if (!shear_and_test_edges(r, tri, h)) return false;
  const float inv_det = 1.0f / h.det;
  const float t = h.t_scaled * inv_det;
  if (!((t > t_min) & (t < t_max))) return false;
  t_out = t;
  u_out = h.v * inv_det;
  v_out = h.w * inv_det;
  return true;
}

// Whether the triangle meets the ray inside (t_min, t_max), with no division: t_scaled / det is
// compared with the bounds as t_scaled against t_min * det and t_max * det, det's sign moved onto
// t_scaled (the paper's test for shadow rays). Only the rounding of the quotient against that of
// the products can tell it apart from intersect_triangle, at a bound's last bit.
CAUSTICA_HDI bool triangle_blocks(const WatertightRay& r, const TriangleVertices& tri, float t_min,
                                  float t_max) {
  ShearedHit h;
  if (!shear_and_test_edges(r, tri, h)) return false;
  const float det = fabsf(h.det);
  const float t_scaled = h.det < 0.0f ? -h.t_scaled : h.t_scaled;
  return (t_scaled > t_min * det) & (t_scaled < t_max * det);
}

CAUSTICA_HDI Aabb triangle_bounds(const TriangleVertices& t) {
  Aabb b;
  b.extend(t.p0);
  b.extend(t.p1);
  b.extend(t.p2);
  return b;
}

CAUSTICA_HDI Vec3f geometric_normal(const TriangleVertices& tri) {
  return cross(tri.p1 - tri.p0, tri.p2 - tri.p0);
}

// The nearest hit along `ray` among the triangles a structure's walk hands out:
// `walk(t_max, test)` calls test(i) for triangle i of `triangles` (whose original index is
// ids[i]) in the order it reaches them, reading the shrinking t_max to skip what lies beyond.
template <typename Walk>
CAUSTICA_HDI Hit nearest_walked_hit(const TriangleVertices* triangles, const uint32_t* ids,
                                    const Ray& ray, Walk walk) {
  Hit hit;
  const WatertightRay wray(ray);
  const float t_min = ray.t_min;
  float t_max = ray.t_max;
  walk(t_max, [&](uint32_t i) {
    float t, u, v;
    if (intersect_triangle(wray, triangles[i], t_min, t_max, t, u, v)) {
      t_max = t;
      hit.t = t;
      hit.u = u;
      hit.v = v;
      hit.triangle = ids[i];
    }
    return false;
  });
  return hit;
}

// Whether any triangle a walk hands out blocks the open segment (t_min, t_max) of `ray`; the
// walk ends at the first that does.
template <typename Walk>
CAUSTICA_HDI bool walked_segment_blocked(const TriangleVertices* triangles, const Ray& ray,
                                         Walk walk) {
  const WatertightRay wray(ray);
  const float t_min = ray.t_min, t_max = ray.t_max;
  bool blocked = false;
  walk(t_max, [&](uint32_t i) {
    blocked = triangle_blocks(wray, triangles[i], t_min, t_max);
    return blocked;
  });
  return blocked;
}

}  // namespace caustica
