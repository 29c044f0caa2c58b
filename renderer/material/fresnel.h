// Scattering at a smooth dielectric boundary, shared by photon tracing, camera rays and the rough
// dielectric model: Fresnel reflectance (the exact unpolarised formula, pbrt-v4 FrDielectric) and
// Snell refraction.
#pragma once

#include "renderer/base/vec.h"

namespace caustica {

// Reflectance at a smooth boundary; cos_i measured against the normal on the incident side, eta
// the ratio of the transmitted to the incident index. Returns 1 for total internal reflection.
CAUSTICA_HDI float fresnel_dielectric(float cos_i, float eta) {
  float sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.0f) return 1.0f;
  float cos_t = sqrtf(1.0f - sin2_t);
  float r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return 0.5f * (r_parl * r_parl + r_perp * r_perp);
}

// Refracts unit `d` through a boundary whose unit normal `n` faces the incident side; false on
// total internal reflection.
CAUSTICA_HDI bool refract(Vec3f d, Vec3f n, float eta, Vec3f& out) {
  float cos_i = -dot(d, n);
  float sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.0f) return false;
  float cos_t = sqrtf(1.0f - sin2_t);
  out = normalize(d / eta + n * (cos_i / eta - cos_t));
  return true;
}

// The boundary as seen by a ray travelling along `d`: the normal on its side and the index ratio.
struct DielectricSide {
  Vec3f normal;
  float eta;
  float cos_i;
};

CAUSTICA_HDI DielectricSide dielectric_side(Vec3f d, Vec3f outward_normal, float ior) {
  float c = dot(d, outward_normal);
  if (c < 0.0f) return {outward_normal, ior, -c};  // entering
  return {-outward_normal, 1.0f / ior, c};         // leaving
}

}  // namespace caustica
