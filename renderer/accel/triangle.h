// Watertight ray/triangle intersection (Woop, Benthin, Wald, "Watertight Ray/Triangle
// Intersection", JCGT 2013): rays are sheared so they run along +z, edge functions are evaluated
// in 2D, and edges shared by two triangles never let a ray slip through.
#pragma once

#include <cfloat>

#include "renderer/base/aabb.h"
#include "renderer/base/ray.h"

namespace caustica {

struct TriangleVertices {
  Vec3f p0, p1, p2;
};

// Per-ray constants of the shear; computed once per ray and reused for every triangle.
struct WatertightRay {
  Vec3f origin;
  int kx, ky, kz;
  float sx, sy, sz;

  CAUSTICA_HD explicit WatertightRay(const Ray& ray) : origin(ray.origin) {
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
  }
};

// Two-sided test. On a hit inside (t_min, t_max) returns true with t and the barycentrics of p1
// (u) and p2 (v).
CAUSTICA_HDI bool intersect_triangle(const WatertightRay& r, const TriangleVertices& tri,
                                     float t_min, float t_max, float& t_out, float& u_out,
                                     float& v_out) {
  const Vec3f a = tri.p0 - r.origin, b = tri.p1 - r.origin, c = tri.p2 - r.origin;
  // The shear as fused multiply-adds: a vertex's sheared coordinates depend on the vertex and the
  // ray alone, so two triangles sharing an edge still see the same edge. The edge functions below
  // must not fuse: a * b - c * d with both products rounded is exactly -(c * d - a * b), which is
  // what keeps a shared edge watertight.
  float ax = fmaf(-r.sx, a[r.kz], a[r.kx]), ay = fmaf(-r.sy, a[r.kz], a[r.ky]);
  float bx = fmaf(-r.sx, b[r.kz], b[r.kx]), by = fmaf(-r.sy, b[r.kz], b[r.ky]);
  float cx = fmaf(-r.sx, c[r.kz], c[r.kx]), cy = fmaf(-r.sy, c[r.kz], c[r.ky]);
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
  float det = u + v + w;
  if (det == 0.0f) return false;
  float az = r.sz * a[r.kz], bz = r.sz * b[r.kz], cz = r.sz * c[r.kz];
  float t_scaled = fmaf(w, cz, fmaf(v, bz, u * az));
  float inv_det = 1.0f / det;
  float t = t_scaled * inv_det;
  if (!((t > t_min) & (t < t_max))) return false;
  t_out = t;
  u_out = v * inv_det;
  v_out = w * inv_det;
  return true;
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

}  // namespace caustica
