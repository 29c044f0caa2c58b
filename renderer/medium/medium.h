// Participating media as kernels read them (docs/media.md): how far light travels before a
// particle stops it (free-flight sampling), how much of it gets through a segment
// (transmittance), and where it goes when scattered (the Henyey-Greenstein phase function).
//
// The seam where media vary: each DeviceMedium carries its kind, for the functions here to switch
// on once per segment, the way pbrt-v4 dispatches its media, never through a virtual call.
// Homogeneous media are the only kind so far, so the functions compute their closed forms.
//
// Which medium a ray is in follows from where it started and the dielectric boundaries it has
// crossed since (medium_after_crossing): the scene-wide medium fills the scene's bounds outside
// every shape, and a closed shape holds the medium it names inside, or vacuum.
#pragma once

#include <cfloat>
#include <cstdint>

#include "renderer/base/aabb.h"
#include "renderer/base/ray.h"
#include "renderer/base/sampling.h"
#include "renderer/base/vec.h"

namespace caustica {

// A medium index that is none (scene.h's kNoMedium, repeated here so kernels need not include the
// scene model).
constexpr uint32_t kVacuum = 0xffffffffu;

enum class MediumKind : uint32_t { kHomogeneous = 0 };

struct DeviceMedium {
  MediumKind kind;
  Vec3f sigma_s;   // scattering coefficient per channel
  Vec3f sigma_t;   // extinction: absorption plus scattering
  Vec3f albedo;    // sigma_s / sigma_t, 0 where sigma_t is 0
  float majorant;  // the largest channel of sigma_t: free flights are drawn with it
  float g;         // Henyey-Greenstein asymmetry
};

// What kernels read of the scene's media.
struct MediaView {
  const DeviceMedium* media = nullptr;
  const uint32_t* triangle_medium = nullptr;  // per triangle: the medium its mesh encloses
  uint32_t count = 0;
  uint32_t scene_medium = kVacuum;  // the medium outside every shape
  Aabb bounds;                      // where the scene-wide medium ends: the scene's bounds

  CAUSTICA_HDI bool any() const { return count > 0; }
};

// The medium a ray is in after passing through triangle `triangle` (whose geometric normal is
// `ng`, wound outwards) along `d`: the one the triangle's shape encloses when it goes in, the
// scene's when it comes out. Shapes do not nest media.
CAUSTICA_HDI uint32_t medium_after_crossing(const MediaView& media, uint32_t triangle, Vec3f d,
                                            Vec3f ng) {
  if (!media.any()) return kVacuum;
  return dot(d, ng) < 0.0f ? media.triangle_medium[triangle] : media.scene_medium;
}

// The part [t0, t1] of a ray's stretch [0, t_end] that lies in `medium`: all of it for a medium
// inside a shape, its part within the scene's bounds for the scene-wide one. Empty (t1 <= t0) in
// vacuum.
struct MediumSpan {
  float t0 = 0.0f, t1 = 0.0f;
  CAUSTICA_HDI float length() const { return t1 > t0 ? t1 - t0 : 0.0f; }
};

CAUSTICA_HDI MediumSpan medium_span(const MediaView& media, uint32_t medium, Vec3f origin,
                                    Vec3f direction, float t_end) {
  MediumSpan span;
  if (medium == kVacuum) return span;
  span.t1 = t_end;
  if (medium != media.scene_medium) return span;
  for (int a = 0; a < 3; ++a) {
    const float o = origin[a], d = direction[a];
    const float lo = media.bounds.lower[a], hi = media.bounds.upper[a];
    if (d == 0.0f) {
      if (o < lo || o > hi) return MediumSpan{};
      continue;
    }
    const float inv = 1.0f / d;
    float near = (lo - o) * inv, far = (hi - o) * inv;
    if (near > far) {
      const float swap = near;
      near = far;
      far = swap;
    }
    span.t0 = max_f(span.t0, near);
    span.t1 = min_f(span.t1, far);
  }
  return span.t1 > span.t0 ? span : MediumSpan{};
}

CAUSTICA_HDI Vec3f exp_negative(Vec3f x) { return {expf(-x.x), expf(-x.y), expf(-x.z)}; }

// The fraction of light per channel that crosses `distance` of medium `m` unscattered.
CAUSTICA_HDI Vec3f transmittance(const DeviceMedium& m, float distance) {
  return exp_negative(m.sigma_t * distance);
}

// Transmittance along `direction` from `origin` over [0, t_end], in whichever medium the ray is.
CAUSTICA_HDI Vec3f transmittance_along(const MediaView& media, uint32_t medium, Vec3f origin,
                                       Vec3f direction, float t_end) {
  const MediumSpan span = medium_span(media, medium, origin, direction, t_end);
  if (!(span.length() > 0.0f)) return Vec3f(1.0f);
  return transmittance(media.media[medium], span.length());
}

// A free flight drawn over a span: either a collision at `t` (its weight turns the majorant's
// density into each channel's extinction density, sigma_t Tr / (majorant e^(-majorant t))), or
// none before the span's end (its weight turns the majorant's escape probability into each
// channel's transmittance). Both weights are 1 in a grey medium, the flight then exactly analog.
struct FreeFlight {
  bool collided;
  float t;       // from the span's ray origin, where collided
  Vec3f weight;  // per channel
};

CAUSTICA_HDI FreeFlight sample_free_flight(const DeviceMedium& m, const MediumSpan& span, float u) {
  FreeFlight f{false, span.t1, Vec3f(1.0f)};
  const float length = span.length();
  if (!(length > 0.0f) || !(m.majorant > 0.0f)) return f;
  const float s = -log1pf(-u) / m.majorant;  // u in [0, 1): s finite
  if (s < length) {
    f.collided = true;
    f.t = span.t0 + s;
    f.weight = m.sigma_t * exp_negative(m.sigma_t * s) / (m.majorant * expf(-m.majorant * s));
  } else {
    f.weight = exp_negative(m.sigma_t * length) / expf(-m.majorant * length);
  }
  return f;
}

// The Henyey-Greenstein phase function for the angle between the direction light travelled in
// and the one it leaves in (g > 0 scatters forwards), per steradian.
CAUSTICA_HDI float henyey_greenstein(float cos_theta, float g) {
  const float denom = 1.0f + g * g - 2.0f * g * cos_theta;
  return kInvPi * 0.25f * (1.0f - g * g) / (denom * sqrtf(max_f(denom, 1e-12f)));
}

// A direction drawn from the phase function around `travel` (the direction light travelled in),
// with pdf henyey_greenstein(dot(travel, result), g) (pbrt-v4's SampleHenyeyGreenstein, with
// directions of travel on both sides).
CAUSTICA_HDI Vec3f sample_henyey_greenstein(Vec3f travel, float g, float u0, float u1) {
  float cos_theta;
  if (fabsf(g) < 1e-3f) {
    cos_theta = 1.0f - 2.0f * u0;
  } else {
    const float q = (1.0f - g * g) / (1.0f + g - 2.0f * g * u0);
    cos_theta = (1.0f + g * g - q * q) / (2.0f * g);
  }
  cos_theta = fminf(1.0f, fmaxf(-1.0f, cos_theta));
  const float sin_theta = sqrtf(max_f(0.0f, 1.0f - cos_theta * cos_theta));
  const float phi = 2.0f * kPi * u1;
  return Frame::from_normal(travel).to_world(
      Vec3f(sin_theta * cosf(phi), sin_theta * sinf(phi), cos_theta));
}

}  // namespace caustica
