// Photon differentials (Schjøth et al. 2007; Fabianowski 2011 sec. 5.1): the partial derivatives
// of a photon's position z and direction w with respect to the two parameters p1, p2 it was
// emitted (or last re-emitted) with. Scaled as Fabianowski scales them (his eqs. 5.9-5.11 and
// 5.25-5.27), every photon's neighbours lie the same distance dp = sqrt(4 pi / n) apart in
// parameter space, n the photons emitted, so a stored photon's footprint is spanned by
// dp dz/dp1 and dp dz/dp2 with no per-photon distances to track. The footprint defines the
// anisotropic kernel of variable kernel density estimation.
//
// What updates them, one function each:
// - emission from a point or spot light (direction sampled uniformly in a cone), and from an
//   area light (a point drawn uniformly on it, the direction cosine-weighted): the area light is
//   treated as a diffuse surface re-emitting what arrived on it, with the footprint its share of
//   the light's area (docs/convergence.md, "Photon differentials");
// - transfer along a ray to the next hit (Igehy 1999);
// - specular reflection and refraction, with the derivative of the shading normal where a mesh
//   interpolates vertex normals;
// - diffuse reflection, as an absorption and a re-emission from a virtual point behind the hit
//   that keeps the incoming footprint's area in expectation;
// - Russian roulette, whose survivors stand for 1 / rho as many photons, so their footprints grow
//   by rho^(-1/2) in each direction.
#pragma once

#include <cmath>

#include "renderer/base/hd.h"
#include "renderer/base/sampling.h"
#include "renderer/base/vec.h"

namespace caustica {

struct PhotonDifferentials {
  Vec3f dz1, dz2;  // d position / d p1, d p2
  Vec3f dw1, dw2;  // d direction / d p1, d p2
};

// The distance between neighbouring photons in parameter space once the differentials are scaled
// as here, for `photons` emitted.
CAUSTICA_HDI float differential_spacing(float photons) { return sqrtf(4.0f * kPi / photons); }

// The footprint area of a photon with these differentials among `photons` emitted.
CAUSTICA_HDI float footprint_area(const PhotonDifferentials& d, float photons) {
  return 4.0f * kPi / photons * length(cross(d.dz1, d.dz2));
}

namespace detail {

// Direction differentials of a direction with inclination p1, azimuth p2 in `frame` (cos and sin
// of each given), each scaled by `scale1`, `scale2`: Fabianowski's eqs. 5.2 and 5.3 with his
// scalings applied (the second already divided by sin p1).
CAUSTICA_HDI void spherical_direction_differentials(const Frame& frame, float cos_p1, float sin_p1,
                                                    float cos_p2, float sin_p2, float scale1,
                                                    float scale2, Vec3f& dw1, Vec3f& dw2) {
  dw1 = frame.to_world(Vec3f(cos_p2 * cos_p1, sin_p2 * cos_p1, -sin_p1)) * scale1;
  dw2 = frame.to_world(Vec3f(-sin_p2, cos_p2, 0.0f)) * scale2;
}

// cos and sin of the azimuth of `local` (a unit vector in a frame), 1 and 0 at the poles.
CAUSTICA_HDI void azimuth_of(Vec3f local, float& cos_p2, float& sin_p2) {
  const float r = sqrtf(local.x * local.x + local.y * local.y);
  if (r > 1e-12f) {
    cos_p2 = local.x / r;
    sin_p2 = local.y / r;
  } else {
    cos_p2 = 1.0f;
    sin_p2 = 0.0f;
  }
}

}  // namespace detail

// A photon leaving a point (or spot) light along `w` (unit), drawn uniformly among the directions
// within acos(cos_max) of `axis` (cos_max = -1 for a point light): eqs. 5.9 and 5.10.
CAUSTICA_HDI PhotonDifferentials emitted_from_point(Vec3f w, Vec3f axis, float cos_max) {
  const Frame frame = Frame::from_normal(axis);
  const Vec3f local(dot(w, frame.s), dot(w, frame.t), dot(w, frame.n));
  const float cos_p1 = local.z, sin_p1 = sqrtf(max_f(0.0f, 1.0f - local.z * local.z));
  float cos_p2, sin_p2;
  detail::azimuth_of(local, cos_p2, sin_p2);
  const float scale = sqrtf(0.5f * (1.0f - cos_max));
  PhotonDifferentials d{Vec3f(0.0f), Vec3f(0.0f), Vec3f(0.0f), Vec3f(0.0f)};
  detail::spherical_direction_differentials(frame, cos_p1, sin_p1, cos_p2, sin_p2, scale, scale,
                                            d.dw1, d.dw2);
  return d;
}

// A photon leaving a diffuse surface with unit normal `n` (on the side it leaves) along the
// cosine-distributed `w`, re-emitted from a virtual point `offset` behind the surface along -w so
// that its footprint there is spread as it arrives: eqs. 5.25 (third component -sin p1', as
// corrected) and 5.26, moved by eqs. 5.28 and 5.29.
CAUSTICA_HDI PhotonDifferentials reemitted_diffusely(Vec3f w, Vec3f n, float offset) {
  const Frame frame = Frame::from_normal(n);
  const Vec3f local(dot(w, frame.s), dot(w, frame.t), dot(w, frame.n));
  const float cos_p1 = max_f(local.z, 1e-6f), sin_p1 = sqrtf(max_f(0.0f, 1.0f - cos_p1 * cos_p1));
  float cos_p2, sin_p2;
  detail::azimuth_of(local, cos_p2, sin_p2);
  const float scale = sqrtf(0.25f / cos_p1);
  PhotonDifferentials d;
  detail::spherical_direction_differentials(frame, cos_p1, sin_p1, cos_p2, sin_p2, scale, scale,
                                            d.dw1, d.dw2);
  d.dz1 = d.dw1 * offset;
  d.dz2 = d.dw2 * offset;
  return d;
}

// The virtual offset that keeps a footprint's area in expectation through a diffuse re-emission:
// t_v = sqrt(2 |dz1 x dz2|) of the differentials arriving (E[A'] = t_v^2 2 pi / n = A).
CAUSTICA_HDI float reemission_offset(const PhotonDifferentials& arriving) {
  return sqrtf(2.0f * length(cross(arriving.dz1, arriving.dz2)));
}

// The virtual offset of a photon leaving an area light of `area` that emits the share
// `light_share` of all photons (its power over the total): the light as a diffuse surface on which
// each of its photons arrived with a footprint of area / (n light_share), so
// t_v^2 2 pi / n = area / (n light_share).
CAUSTICA_HDI float area_light_offset(float area, float light_share) {
  return sqrtf(area / (2.0f * kPi * light_share));
}

// Transfer (Igehy 1999): the photon moves from its position along unit `w` by `t` to a surface of
// unit normal `n`; the position differentials follow the plane of the hit, the direction's stay.
CAUSTICA_HDI void transfer(PhotonDifferentials& d, Vec3f w, float t, Vec3f n) {
  const float wn = dot(w, n);
  if (fabsf(wn) < 1e-12f) return;
  auto moved = [&](Vec3f dz, Vec3f dw) {
    const Vec3f along = dz + dw * t;
    return along - w * (dot(along, n) / wn);
  };
  d.dz1 = moved(d.dz1, d.dw1);
  d.dz2 = moved(d.dz2, d.dw2);
}

// The derivatives of the unit shading normal n = normalize(n0 + u (n1 - n0) + v (n2 - n0)) of a
// triangle with edges e1 = v1 - v0, e2 = v2 - v0 along position differentials dz1, dz2 in its
// plane (Fabianowski's eqs. 5.12 and 5.13, the barycentric derivative taken from the edges instead
// of from the Wald test's projection): dn1, dn2. `unnormalized` is n0 + u (n1 - n0) + v (n2 - n0).
CAUSTICA_HDI void shading_normal_differentials(Vec3f n0, Vec3f n1, Vec3f n2, Vec3f unnormalized,
                                               Vec3f e1, Vec3f e2, Vec3f dz1, Vec3f dz2, Vec3f& dn1,
                                               Vec3f& dn2) {
  // The dual basis of (e1, e2) in the triangle's plane: du = dz . a1, dv = dz . a2.
  const Vec3f g = cross(e1, e2);
  const float g2 = dot(g, g);
  if (!(g2 > 0.0f)) {
    dn1 = dn2 = Vec3f(0.0f);
    return;
  }
  const Vec3f a1 = cross(e2, g) / g2, a2 = cross(g, e1) / g2;
  const float len = length(unnormalized);
  const Vec3f n = unnormalized / len;
  // d n / d u and d n / d v: the change of the interpolation with its radial part removed.
  const Vec3f m1 = n1 - n0, m2 = n2 - n0;
  const Vec3f dn_du = (m1 - n * dot(m1, n)) / len, dn_dv = (m2 - n * dot(m2, n)) / len;
  dn1 = dn_du * dot(dz1, a1) + dn_dv * dot(dz1, a2);
  dn2 = dn_du * dot(dz2, a1) + dn_dv * dot(dz2, a2);
}

// Specular reflection of unit `w` about unit `n` (either side), with the normal's derivatives
// dn1, dn2 at the hit (zero on a flat facet): r = w - 2 (w.n) n, so
// dr = dw - 2 ((w.n) dn + (dw.n + w.dn) n), Igehy's form (with dw.n, as corrected).
CAUSTICA_HDI void reflect_differentials(PhotonDifferentials& d, Vec3f w, Vec3f n, Vec3f dn1,
                                        Vec3f dn2) {
  const float wn = dot(w, n);
  d.dw1 = d.dw1 - (dn1 * wn + n * (dot(d.dw1, n) + dot(w, dn1))) * 2.0f;
  d.dw2 = d.dw2 - (dn2 * wn + n * (dot(d.dw2, n) + dot(w, dn2))) * 2.0f;
}

// Refraction of unit `w` through a boundary whose unit normal `n` faces the incident side, `eta`
// the ratio of the transmitted to the incident index (scattering.h's convention), `t` the unit
// refracted direction: t = w / eta - mu n with mu = cos_t - cos_i / eta, cos_i = -w.n,
// cos_t = -t.n, so dt = dw / eta - (dmu n + mu dn) with
// dmu = (-1 / eta - (w.n) / (eta^2 (t.n))) d(w.n), d(w.n) = dw.n + w.dn (Igehy 1999, eq. 14).
CAUSTICA_HDI void refract_differentials(PhotonDifferentials& d, Vec3f w, Vec3f n, float eta,
                                        Vec3f t, Vec3f dn1, Vec3f dn2) {
  const float inv_eta = 1.0f / eta;
  const float wn = dot(w, n), tn = dot(t, n);
  const float mu = -tn + inv_eta * wn;  // cos_t - cos_i / eta
  if (fabsf(tn) < 1e-12f) return;
  const float dmu_dwn = inv_eta - inv_eta * inv_eta * wn / tn;
  auto refracted = [&](Vec3f dw, Vec3f dn) {
    const float dwn = dot(dw, n) + dot(w, dn);
    return dw * inv_eta - (n * (dmu_dwn * dwn) + dn * mu);
  };
  d.dw1 = refracted(d.dw1, dn1);
  d.dw2 = refracted(d.dw2, dn2);
}

// A photon that survived Russian roulette with probability `survive` stands for 1 / survive as
// many: its footprint grows by that factor in area (Fabianowski sec. 5.1.4).
CAUSTICA_HDI void survived_roulette(PhotonDifferentials& d, float survive) {
  const float s = 1.0f / sqrtf(survive);
  d.dz1 = d.dz1 * s;
  d.dz2 = d.dz2 * s;
  d.dw1 = d.dw1 * s;
  d.dw2 = d.dw2 * s;
}

}  // namespace caustica
