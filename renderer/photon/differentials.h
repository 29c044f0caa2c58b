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
// Through participating media (Fabianowski 2011 sec. 7.2):
// - a photon that crosses a medium to a surface is one of the fraction tau that the free flights
//   let through, which acts as roulette does: its footprint grows by tau^(-1/2);
// - a photon stopped in a medium gains a third parameter, the free flight's number p3, and a
//   three-dimensional footprint whose third side runs along its direction with length
//   dt/dp3 = 1 / (sigma tau), the inverse of the free flight's density there;
// - scattering is an absorption and a re-emission by the phase function from a virtual point that
//   keeps the footprint's volume in expectation, after the albedo's roulette has grown each of the
//   three sides by alpha^(-1/3).
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

// Unit direction w in spherical coordinates about `axis`: the frame, the inclination p1 (its
// cosine at least `cos_floor`) and the azimuth p2, by cos and sin (azimuth 0 at the poles).
struct SphericalCoordinates {
  Frame frame;
  float cos_p1, sin_p1, cos_p2, sin_p2;
};

CAUSTICA_HDI SphericalCoordinates spherical_coordinates(Vec3f w, Vec3f axis,
                                                        float cos_floor = -1.0f) {
  SphericalCoordinates c{Frame::from_normal(axis), 0.0f, 0.0f, 1.0f, 0.0f};
  const Vec3f local(dot(w, c.frame.s), dot(w, c.frame.t), dot(w, c.frame.n));
  c.cos_p1 = max_f(local.z, cos_floor);
  c.sin_p1 = sqrtf(max_f(0.0f, 1.0f - c.cos_p1 * c.cos_p1));
  const float r = sqrtf(local.x * local.x + local.y * local.y);
  if (r > 1e-12f) {
    c.cos_p2 = local.x / r;
    c.sin_p2 = local.y / r;
  }
  return c;
}

// The differentials of a direction leaving along `c`: Fabianowski's eqs. 5.2 and 5.3, both scaled
// by `scale` (the second already divided by sin p1), from a virtual point `offset` behind the
// start along the direction (eqs. 5.28 and 5.29; 0 for a real point).
CAUSTICA_HDI PhotonDifferentials spherical_differentials(const SphericalCoordinates& c, float scale,
                                                         float offset) {
  PhotonDifferentials d;
  d.dw1 = c.frame.to_world(Vec3f(c.cos_p2 * c.cos_p1, c.sin_p2 * c.cos_p1, -c.sin_p1)) * scale;
  d.dw2 = c.frame.to_world(Vec3f(-c.sin_p2, c.cos_p2, 0.0f)) * scale;
  d.dz1 = d.dw1 * offset;
  d.dz2 = d.dw2 * offset;
  return d;
}

}  // namespace detail

// A photon leaving a point (or spot) light along `w` (unit), drawn uniformly among the directions
// within acos(cos_max) of `axis` (cos_max = -1 for a point light): eqs. 5.9 and 5.10.
CAUSTICA_HDI PhotonDifferentials emitted_from_point(Vec3f w, Vec3f axis, float cos_max) {
  return detail::spherical_differentials(detail::spherical_coordinates(w, axis),
                                         sqrtf(0.5f * (1.0f - cos_max)), 0.0f);
}

// A photon leaving a diffuse surface with unit normal `n` (on the side it leaves) along the
// cosine-distributed `w`, re-emitted from a virtual point `offset` behind the surface along -w so
// that its footprint there is spread as it arrives: eqs. 5.25 (third component -sin p1', as
// corrected) and 5.26, moved by eqs. 5.28 and 5.29.
CAUSTICA_HDI PhotonDifferentials reemitted_diffusely(Vec3f w, Vec3f n, float offset) {
  const detail::SphericalCoordinates c = detail::spherical_coordinates(w, n, 1e-6f);
  return detail::spherical_differentials(c, sqrtf(0.25f / c.cos_p1), offset);
}

// A photon leaving a surface along unit `w`, drawn from a scattering model's density `pdf` (per
// steradian), `n` the normal on w's side: the diffuse re-emission's differentials with the
// model's density in place of cos / pi, so that the neighbours' spacing in parameter space stays
// the global one, from the virtual point `offset` behind the surface.
CAUSTICA_HDI PhotonDifferentials reemitted_by_density(Vec3f w, Vec3f n, float pdf, float offset) {
  const detail::SphericalCoordinates c = detail::spherical_coordinates(w, n, 1e-6f);
  return detail::spherical_differentials(c, 1.0f / sqrtf(4.0f * kPi * pdf), offset);
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
// the ratio of the transmitted to the incident index (material/fresnel.h's convention), `t` the
// unit refracted direction: t = w / eta - mu n with mu = cos_t - cos_i / eta, cos_i = -w.n,
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

// Propagation by `t` along unit `w` to a collision in a medium, where no surface turns the
// footprint: eqs. 7.4 and 7.5.
CAUSTICA_HDI void propagate(PhotonDifferentials& d, float t) {
  d.dz1 = d.dz1 + d.dw1 * t;
  d.dz2 = d.dz2 + d.dw2 * t;
}

// The volume of the footprint of a photon stopped in a medium, travelling along unit `w`, among
// `photons` emitted: (4 pi / n) |<dz1, dz2, dz3>| with dz3 = w / flight_density (eqs. 7.6, 7.7 and
// 7.26), flight_density = sigma tau the density the free flight was drawn from at the collision.
// The inverse of the collisions' density there.
CAUSTICA_HDI float footprint_volume(const PhotonDifferentials& d, Vec3f w, float flight_density,
                                    float photons) {
  return 4.0f * kPi / photons * fabsf(dot(cross(d.dz1, d.dz2), w)) / flight_density;
}

// The virtual offset of a photon scattered at a collision (along unit `w` before, the free
// flights having let through the fraction `tau` of photons up to it) that the albedo's roulette
// spared with probability `survive`: with the three sides grown by survive^(-1/3),
// t_v = sqrt(sigma V n / 4 pi) keeps the volume in expectation (sec. 7.2.2), where the sigma of
// the flight's density sigma tau cancels.
CAUSTICA_HDI float scattering_offset(const PhotonDifferentials& d, Vec3f w, float tau,
                                     float survive) {
  return sqrtf(fabsf(dot(cross(d.dz1, d.dz2), w)) / (tau * survive));
}

// A photon leaving a collision along unit `w`, drawn from the phase function `pdf` (per steradian,
// for w) around the direction it travelled in, `travel`, re-emitted from the virtual point `offset`
// behind it: the spherical differentials of a point light (eqs. 5.2 and 5.3) about `travel`, each
// scaled by 1 / sqrt(4 pi pdf) so that the neighbours' spacing in parameter space is the global
// sqrt(4 pi / n) (eqs. 7.18 and 7.19, there for Schlick's phase function), then moved by eqs.
// 7.20 and 7.21.
CAUSTICA_HDI PhotonDifferentials scattered_in_medium(Vec3f w, Vec3f travel, float pdf,
                                                     float offset) {
  return detail::spherical_differentials(detail::spherical_coordinates(w, travel),
                                         1.0f / sqrtf(4.0f * kPi * pdf), offset);
}

// A photon that survived Russian roulette with probability `survive` stands for 1 / survive as
// many: its footprint grows by that factor in area (Fabianowski sec. 5.1.4). The same holds for
// the fraction tau of free flights that cross a medium to a surface (sec. 7.2.1.1).
CAUSTICA_HDI void survived_roulette(PhotonDifferentials& d, float survive) {
  const float s = 1.0f / sqrtf(survive);
  d.dz1 = d.dz1 * s;
  d.dz2 = d.dz2 * s;
  d.dw1 = d.dw1 * s;
  d.dw2 = d.dw2 * s;
}

}  // namespace caustica
