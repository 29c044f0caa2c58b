// Participating media as kernels read them (docs/media.md): how far light travels before a
// particle stops it (free-flight sampling), how much of it gets through a segment
// (transmittance), and where it goes when scattered (the Henyey-Greenstein phase function).
//
// The seam where media vary: each DeviceMedium carries its kind, for the functions here to switch
// on once per segment, the way pbrt-v4 dispatches its media, never through a virtual call.
// Homogeneous media have closed forms. Grid media scale their coefficients by a NanoVDB density
// grid sampled trilinearly: free flights by delta tracking against the grid's largest value,
// transmittance by marching half-voxel steps (docs/media.md, "Density grids").
//
// Which medium a ray is in follows from where it started and the dielectric boundaries it has
// crossed since (medium_after_crossing): the scene-wide medium fills the scene's bounds outside
// every shape, and a closed shape holds the medium it names inside, or vacuum.
#pragma once

#include <nanovdb/NanoVDB.h>
#include <nanovdb/util/SampleFromVoxels.h>

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

enum class MediumKind : uint32_t { kHomogeneous = 0, kGrid = 1 };

// A grid medium's density: the grid in the backend's memory and where it stands.
struct DeviceGrid {
  const nanovdb::FloatGrid* grid = nullptr;
  float to_index[3][4];  // a scene point to the grid's index space
  Aabb bounds;           // outside it the density is 0
  float step;            // transmittance's marching step: half the shortest voxel edge

  CAUSTICA_HDI nanovdb::Vec3f index_of(Vec3f p) const {
    return nanovdb::Vec3f(
        to_index[0][0] * p.x + to_index[0][1] * p.y + to_index[0][2] * p.z + to_index[0][3],
        to_index[1][0] * p.x + to_index[1][1] * p.y + to_index[1][2] * p.z + to_index[1][3],
        to_index[2][0] * p.x + to_index[2][1] * p.y + to_index[2][2] * p.z + to_index[2][3]);
  }
};

// Trilinear density samples of one grid, through one accessor so that neighbouring samples
// reuse the nodes it cached.
class DensitySampler {
 public:
  CAUSTICA_HDI explicit DensitySampler(const DeviceGrid& g)
      : grid_(g), accessor_(g.grid->getAccessor()) {}
  CAUSTICA_HDI float operator()(Vec3f p) const {
    return nanovdb::SampleFromVoxels<Accessor, 1, false>(accessor_)(grid_.index_of(p));
  }

 private:
  using Accessor = nanovdb::DefaultReadAccessor<float>;
  const DeviceGrid& grid_;
  Accessor accessor_;
};

struct DeviceMedium {
  MediumKind kind;
  Vec3f sigma_s;    // scattering coefficient per channel (a grid's: per unit of density)
  Vec3f sigma_t;    // extinction: absorption plus scattering
  Vec3f albedo;     // sigma_s / sigma_t, 0 where sigma_t is 0
  float majorant;   // the largest extinction anywhere: free flights are drawn with it
  float g;          // Henyey-Greenstein asymmetry
  DeviceGrid grid;  // kGrid
};

// What kernels read of the scene's media.
struct MediaView {
  const DeviceMedium* media = nullptr;
  const uint32_t* triangle_medium = nullptr;  // per triangle: the medium its mesh encloses
  uint32_t count = 0;
  uint32_t scene_medium = kVacuum;  // the medium outside every shape
  Aabb bounds;                      // where the scene-wide medium ends: the scene's bounds
  bool grids = false;               // whether any medium is a grid

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
// inside a shape, its part within the scene's bounds for the scene-wide one, and for a grid
// medium no more than its part within the grid's bounds. Empty (t1 <= t0) in vacuum.
struct MediumSpan {
  float t0 = 0.0f, t1 = 0.0f;
  CAUSTICA_HDI float length() const { return t1 > t0 ? t1 - t0 : 0.0f; }
};

// `span` cut to the part of the ray (origin, direction) inside `box`.
CAUSTICA_HDI MediumSpan clip_span(MediumSpan span, const Aabb& box, Vec3f origin, Vec3f direction) {
  for (int a = 0; a < 3; ++a) {
    const float o = origin[a], d = direction[a];
    const float lo = box.lower[a], hi = box.upper[a];
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

CAUSTICA_HDI MediumSpan medium_span(const MediaView& media, uint32_t medium, Vec3f origin,
                                    Vec3f direction, float t_end) {
  MediumSpan span;
  if (medium == kVacuum) return span;
  span.t1 = t_end;
  if (medium == media.scene_medium) span = clip_span(span, media.bounds, origin, direction);
  const DeviceMedium& m = media.media[medium];
  if (m.kind == MediumKind::kGrid) span = clip_span(span, m.grid.bounds, origin, direction);
  return span;
}

CAUSTICA_HDI Vec3f exp_negative(Vec3f x) { return {expf(-x.x), expf(-x.y), expf(-x.z)}; }

// The fraction of light per channel that crosses `distance` of homogeneous medium `m` unscattered.
CAUSTICA_HDI Vec3f transmittance(const DeviceMedium& m, float distance) {
  return exp_negative(m.sigma_t * distance);
}

// The most samples one march takes: a stretch across more than twice as many voxels is marched
// with longer steps.
constexpr int kMaxMarchSteps = 2048;

// The integral of a grid's density over [t0, t1] of the ray (origin, direction), by the midpoint
// rule on steps of at most half a voxel.
CAUSTICA_HDI float density_integral(const DeviceGrid& grid, const DensitySampler& density,
                                    Vec3f origin, Vec3f direction, float t0, float t1) {
  const float length = t1 - t0;
  if (!(length > 0.0f)) return 0.0f;
  const int steps = int(min_f(ceilf(length / grid.step), float(kMaxMarchSteps)));
  const float dt = length / float(steps > 1 ? steps : 1);
  float sum = 0.0f;
  for (int i = 0; i < steps; ++i)
    sum += density(origin + direction * (t0 + (float(i) + 0.5f) * dt));
  return sum * dt;
}

// Transmittance over `span` of the ray (origin, direction) through medium `m`.
CAUSTICA_HDI Vec3f span_transmittance(const DeviceMedium& m, Vec3f origin, Vec3f direction,
                                      const MediumSpan& span) {
  if (!(span.length() > 0.0f)) return Vec3f(1.0f);
  if (m.kind == MediumKind::kHomogeneous) return transmittance(m, span.length());
  const DensitySampler density(m.grid);
  return exp_negative(m.sigma_t *
                      density_integral(m.grid, density, origin, direction, span.t0, span.t1));
}

// Transmittance along `direction` from `origin` over [0, t_end], in whichever medium the ray is.
CAUSTICA_HDI Vec3f transmittance_along(const MediaView& media, uint32_t medium, Vec3f origin,
                                       Vec3f direction, float t_end) {
  const MediumSpan span = medium_span(media, medium, origin, direction, t_end);
  if (!(span.length() > 0.0f)) return Vec3f(1.0f);
  return span_transmittance(media.media[medium], origin, direction, span);
}

// Optical depth along one stretch, for a beam estimate that asks for the transmittance to many
// points of it: the density integral at evenly spaced knots, linear between them.
struct OpticalDepth {
  static constexpr int kKnots = 32;
  float t0 = 0.0f, inv_dt = 0.0f;
  float depth[kKnots + 1];  // density integrals from t0 to each knot

  CAUSTICA_HDI OpticalDepth(const DeviceGrid& grid, Vec3f origin, Vec3f direction,
                            const MediumSpan& span)
      : t0(span.t0) {
    depth[0] = 0.0f;
    const float dt = span.length() / float(kKnots);
    if (!(dt > 0.0f)) {
      for (int k = 1; k <= kKnots; ++k) depth[k] = 0.0f;
      return;
    }
    inv_dt = 1.0f / dt;
    const DensitySampler density(grid);
    for (int k = 1; k <= kKnots; ++k) {
      depth[k] = depth[k - 1] + density_integral(grid, density, origin, direction,
                                                 t0 + float(k - 1) * dt, t0 + float(k) * dt);
    }
  }
  // The density integral from the span's start to t.
  CAUSTICA_HDI float at(float t) const {
    const float x = min_f(max_f((t - t0) * inv_dt, 0.0f), float(kKnots));
    const int k = int(x) < kKnots ? int(x) : kKnots - 1;
    return depth[k] + (depth[k + 1] - depth[k]) * (x - float(k));
  }
};

// A free flight drawn over a span: either a collision at `t` (its weight turns the majorant's
// density into each channel's extinction density, sigma_t Tr / (majorant e^(-majorant t))), or
// none before the span's end (its weight turns the majorant's escape probability into each
// channel's transmittance). Both weights are 1 in a grey medium, the flight then exactly analog.
struct FreeFlight {
  bool collided;
  float t;       // from the span's ray origin, where collided
  Vec3f weight;  // per channel
};

// A homogeneous medium's free flight, from one uniform number u in [0, 1).
CAUSTICA_HDI FreeFlight homogeneous_free_flight(const DeviceMedium& m, const MediumSpan& span,
                                                float u) {
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

// The tentative collisions one delta-tracked flight may take before it gives up as escaped; a
// safety net far beyond any real flight (majorant times span of a few hundred).
constexpr int kMaxTentativeCollisions = 1 << 16;

// A free flight over `span` of the ray (origin, direction) through `m`, drawing uniform numbers
// from next_float(). In a grid, delta tracking with spectral weights (Kutz et al. 2017): tentative
// collisions at the majorant's rate, each real with the probability of the channels' mean
// extinction, the weights making every channel's estimate unbiased; exactly analog in a grey
// medium.
template <typename NextFloat>
CAUSTICA_HDI FreeFlight sample_free_flight(const DeviceMedium& m, Vec3f origin, Vec3f direction,
                                           const MediumSpan& span, NextFloat&& next_float) {
  if (m.kind == MediumKind::kHomogeneous) return homogeneous_free_flight(m, span, next_float());
  FreeFlight f{false, span.t1, Vec3f(1.0f)};
  if (!(span.length() > 0.0f) || !(m.majorant > 0.0f)) return f;
  const DensitySampler density(m.grid);
  const float mean_sigma_t = average(m.sigma_t);
  float t = span.t0;
  for (int i = 0; i < kMaxTentativeCollisions; ++i) {
    t += -log1pf(-next_float()) / m.majorant;
    if (!(t < span.t1)) return f;
    const float d = density(origin + direction * t);
    const float real = d * mean_sigma_t / m.majorant;  // <= 1: the majorant bounds every channel
    if (next_float() < real) {
      f.collided = true;
      f.t = t;
      f.weight = f.weight * (m.sigma_t / mean_sigma_t);
      return f;
    }
    f.weight = f.weight * ((Vec3f(m.majorant) - m.sigma_t * d) / (m.majorant * (1.0f - real)));
  }
  return f;
}

// What photon differentials need of the free flights through `m` along the ray (origin,
// direction) from t0, a span's start, to t: the rate at which the flights stop at t (the density
// they are drawn from there, divided by the survival) and the fraction of them that get from t0 to
// t unstopped. Not any one channel's: a homogeneous medium's flights run at the majorant, and a
// grid's real collisions at the channels' mean extinction times the density.
struct FlightOdds {
  float rate;
  float survival;
};

CAUSTICA_HDI FlightOdds flight_odds(const DeviceMedium& m, Vec3f origin, Vec3f direction, float t0,
                                    float t) {
  if (m.kind == MediumKind::kHomogeneous) return {m.majorant, expf(-m.majorant * (t - t0))};
  const DensitySampler density(m.grid);
  const float mean_sigma_t = average(m.sigma_t);
  return {mean_sigma_t * density(origin + direction * t),
          expf(-mean_sigma_t * density_integral(m.grid, density, origin, direction, t0, t))};
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
