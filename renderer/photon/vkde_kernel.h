// The a-priori anisotropic kernel of a stored photon for variable kernel density estimation
// (Fabianowski 2011 sec. 5.2): a skewed ellipsoid around the photon spanned by its footprint
// (differentials.h) and the surface normal. The footprint's longer spanning vector, times a spread
// factor s, is the semimajor axis M, the shorter the semiminor m1, and a third axis m2 lies along
// the normal (vkde_thickness); a query point x weighs the photon by the density kernel at |d|,
// d the image of x - z under the map taking the ellipsoid to the unit sphere. The VKDE estimator
// gathers them from their hierarchy (kernel_map.h), queried by point.
//
// The rules that make the kernels usable:
// - degenerate footprints, whose height is below a fraction f of their base, are discarded;
// - adaptation is dampened: both differentials are scaled so that the longer one's length l
//   becomes l^(1/4) (relative to the scene's size here), compressing the range of kernel sizes
//   without changing their shapes;
// - every semiprincipal axis is clamped to h_max;
// - the photon's flux is stored divided by |M x m1| (the kernel's area over pi), so that an
//   estimate sums kernel weights times flux with no per-kernel normalisation.
#pragma once

#include <cmath>

#include "renderer/base/aabb.h"
#include "renderer/base/hd.h"
#include "renderer/base/vec.h"
#include "renderer/photon/photon.h"

namespace caustica {

struct VkdeSettings {
  float spread = 16.0f;               // s
  float max_axis = INFINITY;          // h_max
  float degenerate_fraction = 0.05f;  // f = 1 / 20
  // The differential length the dampening keeps: l becomes pivot (l / pivot)^(1/4). Fabianowski
  // dampens lengths in his scenes' units, which ties the spread to the scene's size; dampened
  // relative to the scene's radius, one spread suits every scene (docs/convergence.md, "VKDE").
  float pivot = 1.0f;
};

// Nine floats evaluate the kernel, as in Fabianowski's storage, but the centre z, M and m1 rather
// than z, M and m' = m1 x n: the normal he recovers as m' x M vanishes where the footprint is not
// skewed (m' is then parallel to M), while M x m1 never does for a kept footprint.
struct VkdeKernel {
  Vec3f center;
  Vec3f major;  // M, in the surface's plane
  Vec3f minor;  // m1, in the surface's plane; (M, m1, normal) right-handed
  Vec3f flux;   // the photon's flux / |M x m1|
};

// The kernel of `photon` landed with `footprint` (spanning vectors dp dz1, dp dz2, dp the
// differentials' `spacing`) on a surface of unit `normal` (on the side the photon arrived from);
// false when its footprint is degenerate and the photon is discarded.
CAUSTICA_HDI bool vkde_kernel(const Photon& photon, const PhotonFootprint& footprint, Vec3f normal,
                              float spacing, const VkdeSettings& s, VkdeKernel& out) {
  Vec3f a = footprint.span1, b = footprint.span2;
  float la = length(a), lb = length(b);
  if (la < lb) {
    const Vec3f t = a;
    a = b;
    b = t;
    const float tl = la;
    la = lb;
    lb = tl;
  }
  if (!(la > 0.0f)) return false;
  // The parallelogram's height over its base against the fraction f (his eq. 5.33).
  if (length(cross(a, b)) < s.degenerate_fraction * la * la) return false;
  // Dampening on the differentials themselves (dz = span / dp): the longer one's length l
  // becomes pivot (l / pivot)^(1/4), the other scaled by the same factor.
  const float dz_long = la / (spacing * s.pivot);
  const float damp = powf(dz_long, 0.25f) / dz_long;
  Vec3f major = a * (damp * s.spread);
  Vec3f m1 = b * (damp * s.spread);
  const float major_length = length(major), m1_length = length(m1);
  if (major_length > s.max_axis) major = major * (s.max_axis / major_length);
  if (m1_length > s.max_axis) m1 = m1 * (s.max_axis / m1_length);
  if (dot(cross(major, m1), normal) < 0.0f) m1 = -m1;
  const float area = length(cross(major, m1));
  if (!(area > 0.0f)) return false;
  out = {photon.position, major, m1, photon.power / area};
  return true;
}

// The kernel's normal (its surface's): M x m1 points along it.
CAUSTICA_HDI Vec3f vkde_normal(const VkdeKernel& k) { return normalize(cross(k.major, k.minor)); }

// |m2|^2, the squared half-thickness along the normal: (2 / pi)^2 (|M|^2 + |m1|^2) / 2 rather than
// his |m1|^2. A support reaching past a corner loses flux on its own surface and lends it to the
// other wall, whose queries lie inside its thickness; for a radial profile the two balance,
// summed over the distances to the corner, when the thickness is 2 / pi of the in-plane
// semi-axis towards the wall (docs/convergence.md, "VKDE"), here that axis's RMS over directions.
CAUSTICA_HDI float vkde_thickness_squared(const VkdeKernel& k) {
  return (2.0f / (kPi * kPi)) * (dot(k.major, k.major) + dot(k.minor, k.minor));
}

// |d|^2 of query point `x` for kernel `k`, below 1 inside its support region: the coordinates
// (a, b, c) of x - z in the basis (M, m1, m2), m2 along the normal, by the dual basis of the plane
// and the height over it.
CAUSTICA_HDI float vkde_distance_squared(const VkdeKernel& k, Vec3f x) {
  const Vec3f delta = x - k.center;
  const Vec3f g = cross(k.major, k.minor);  // |M x m1| n
  const float g2 = dot(g, g);
  const float a = dot(cross(delta, k.minor), g) / g2;
  const float b = dot(cross(k.major, delta), g) / g2;
  // c = (delta . n) / |m2|, with n = g / |g|.
  const float c2 = dot(delta, g) * dot(delta, g) / (g2 * vkde_thickness_squared(k));
  return a * a + b * b + c2;
}

// The tightest box around the kernel's support region: the ellipsoid z + a M + b m1 + c m2,
// a^2 + b^2 + c^2 <= 1, reaches sqrt(M_i^2 + m1_i^2 + m2_i^2) along axis i (his AABB, sec. 5.2.1).
CAUSTICA_HDI Aabb vkde_bounds(const VkdeKernel& k) {
  const Vec3f m2 = vkde_normal(k) * sqrtf(vkde_thickness_squared(k));
  const Vec3f m1 = k.minor, M = k.major;
  const Vec3f extent(sqrtf(M.x * M.x + m1.x * m1.x + m2.x * m2.x),
                     sqrtf(M.y * M.y + m1.y * m1.y + m2.y * m2.y),
                     sqrtf(M.z * M.z + m1.z * m1.z + m2.z * m2.z));
  return Aabb{k.center - extent, k.center + extent};
}

}  // namespace caustica
