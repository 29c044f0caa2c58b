#include "renderer/photon/photon_tracer.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

#include "renderer/accel/ray_queries.h"
#include "renderer/base/atomic.h"
#include "renderer/base/rng.h"
#include "renderer/material/fresnel.h"
#include "renderer/medium/medium.h"
#include "renderer/parallel/parallel_for.h"
#include "renderer/photon/differentials.h"
#include "renderer/resident/cutouts.h"
#include "renderer/resident/surface_bsdf.h"
#include "renderer/scene/scene_limits.h"

namespace caustica {
namespace {

// Workers per multiprocessor, chosen by measurement (docs/performance.md): about what a
// multiprocessor holds at once; many more only delay the late blocks' first paths to the end.
// The kernel asks for all of them to fit at once, which caps its registers at 64 (at 72 fewer
// fitted, and one block waited).
constexpr unsigned kWorkersPerMultiprocessor = 1024;

// Decorrelates photon streams from camera streams drawn with the same seed and pass.
constexpr uint32_t kPhotonDomain = 0x5f3759dfu;

enum : uint8_t { kNotStored = 0, kCausticPhoton = 1, kGlobalPhoton = 2, kVolumePhoton = 3 };

struct EmittedPhoton {
  Ray ray;
  Vec3f power;  // before division by the light's choice probability and the photon count
};

// Where a photon travelling along `travel` starts on a disk of the scene's radius facing it, just
// outside the scene's bounding sphere: `d` is the point on the unit disk.
CAUSTICA_HDI Vec3f from_disk_facing(Vec3f travel, Vec2f d, Vec3f scene_center, float scene_radius) {
  const Frame f = Frame::from_normal(travel);
  return scene_center - travel * (1.01f * scene_radius) + (f.s * d.x + f.t * d.y) * scene_radius;
}

CAUSTICA_HDI EmittedPhoton emit_from(const ResidentSceneView& scene, const DeviceLight& l,
                                     Sampler& s, Vec3f scene_center, float scene_radius) {
  EmittedPhoton e;
  float u0 = s.next_float(), u1 = s.next_float();
  switch (l.type) {
    case DeviceLightType::kPoint:
      e.ray.origin = l.position;
      e.ray.direction = sample_uniform_sphere(u0, u1);
      e.power = l.color * (4.0f * kPi);
      break;
    case DeviceLightType::kSpot: {
      Vec3f local = sample_uniform_cone(u0, u1, l.cos_outer);
      e.ray.origin = l.position;
      e.ray.direction = Frame::from_normal(l.direction).to_world(local);
      e.power = l.color * (spot_falloff(l, e.ray.direction) * 2.0f * kPi * (1.0f - l.cos_outer));
      break;
    }
    case DeviceLightType::kDirectional: {
      // A disk perpendicular to the light, covering the scene's bounding sphere from outside.
      e.ray.origin =
          from_disk_facing(l.direction, sample_uniform_disk(u0, u1), scene_center, scene_radius);
      e.ray.direction = l.direction;
      e.power = l.color * (kPi * scene_radius * scene_radius);
      break;
    }
    case DeviceLightType::kArea: {
      Vec2f b = sample_uniform_triangle(u0, u1);
      Vec3f p = l.position + l.edge1 * b.x + l.edge2 * b.y;
      Vec3f local = sample_cosine_hemisphere(s.next_float(), s.next_float());
      e.ray.direction = Frame::from_normal(l.direction).to_world(local);
      e.ray.origin = offset_origin(p, l.direction, e.ray.direction);
      e.power = area_light_radiance(scene, l, b) * (kPi * l.area);
      break;
    }
    case DeviceLightType::kEnvironment: {
      // A direction towards the environment by its luminance, then as a directional light's
      // photon from a disk facing it (pbrt-v4's ImageInfiniteLight::SampleLe).
      const EnvironmentSample from = scene.environment.sample(u0, u1);
      const Vec3f travel = -from.direction;
      // Drawn in named order: a function's arguments are evaluated in whatever order the
      // compiler picks, and the backends' compilers need not pick alike.
      const float v0 = s.next_float(), v1 = s.next_float();
      e.ray.origin =
          from_disk_facing(travel, sample_uniform_disk(v0, v1), scene_center, scene_radius);
      e.ray.direction = travel;
      e.power = from.pdf > 0.0f ? from.radiance * (kPi * scene_radius * scene_radius / from.pdf)
                                : Vec3f(0.0f);
      break;
    }
  }
  return e;
}

// A path state's room for differentials when the trace does not track them.
struct NoDifferentials {};

// Where one photon path stands between its hits; with kDifferentials, also its differentials.
template <bool kDifferentials>
struct PhotonPathState {
  Ray ray;
  Vec3f power;
  Sampler s;
  uint32_t path;
  uint32_t bounce;
  uint32_t specular_run;  // mirror and glass bounces since the last diffuse one (or emission)
  uint32_t medium;        // the one the path's ray travels in (medium.h), or kVacuum
  bool only_specular;  // no diffuse bounce or scattering in a medium yet on this path
  std::conditional_t<kDifferentials, PhotonDifferentials, NoDifferentials> differentials;

  // A diffuse bounce or a scattering in a medium: the path's later photons are global ones, and
  // its run of mirror and glass bounces starts again.
  CAUSTICA_HDI void scattered() {
    only_specular = false;
    specular_run = 0;
  }
};

// The differentials of photon `e` leaving `light`, chosen with probability `choice_pdf`.
CAUSTICA_HDI PhotonDifferentials emission_differentials(const DeviceLight& light,
                                                        const EmittedPhoton& e, float choice_pdf,
                                                        float scene_radius) {
  switch (light.type) {
    case DeviceLightType::kPoint:
      return emitted_from_point(e.ray.direction, Vec3f(0.0f, 0.0f, 1.0f), -1.0f);
    case DeviceLightType::kSpot:
      return emitted_from_point(e.ray.direction, light.direction, light.cos_outer);
    case DeviceLightType::kDirectional:
    case DeviceLightType::kEnvironment: {
      // Parallel photons from a disk of the scene's radius: each stands for its share of the disk,
      // pi r^2 / (n share) = (4 pi / n) |dz1 x dz2|. The environment's, from disks facing every
      // way, are given the same spread.
      const Frame f = Frame::from_normal(e.ray.direction);
      const float half = 0.5f * scene_radius / sqrtf(choice_pdf);
      return {f.s * half, f.t * half, Vec3f(0.0f), Vec3f(0.0f)};
    }
    case DeviceLightType::kArea:
      break;
  }
  return reemitted_diffusely(e.ray.direction, light.direction,
                             area_light_offset(light.area, choice_pdf));
}

// The derivatives of the shading normal at `hit` along `d`'s position differentials, zero where
// the triangle has no vertex normals, turned around with the normal where surface_at turned it.
CAUSTICA_HDI void normal_differentials(const ResidentSceneView& scene, const Hit& hit,
                                       const SurfaceHit& sh, const PhotonDifferentials& d,
                                       Vec3f& dn1, Vec3f& dn2) {
  dn1 = dn2 = Vec3f(0.0f);
  if (scene.corner_normals == nullptr) return;
  const Vec3f* n = scene.corner_normals + 3 * size_t(hit.triangle);
  const Vec3f unnormalized = n[0] * (1.0f - hit.u - hit.v) + n[1] * hit.u + n[2] * hit.v;
  if (!(length_squared(unnormalized) > 0.0f)) return;
  const TriangleVertices& t = scene.triangles[hit.triangle];
  shading_normal_differentials(n[0], n[1], n[2], unnormalized, t.p1 - t.p0, t.p2 - t.p0, d.dz1,
                               d.dz2, dn1, dn2);
  if (dot(unnormalized, sh.shading_normal) < 0.0f) {  // surface_at turned the normal around
    dn1 = -dn1;
    dn2 = -dn2;
  }
}

// Where a path's stored photons go: its first kSlotsPerPath in slots of its own (one per
// interaction from `first_slot_bounce`: a path stores nothing at its first surface hit, which
// shadow rays light, but may at its first collision in a medium), in path order with no atomics;
// the rare later ones (Russian roulette ends nearly every path sooner) appended to an overflow list
// with their path, kind and rank among the path's later photons of that kind, so that their place
// too follows from the paths alone.
constexpr uint32_t kSlotsPerPath = 7;

// A path counts its later stores of each kind in one word of its own, kLaterCountBits a kind.
constexpr uint32_t kLaterCountBits = 10;
constexpr uint32_t kLaterCountMask = (1u << kLaterCountBits) - 1;
static_assert(3 * kLaterCountBits <= 32 && kMaxPhotonBounces <= kLaterCountMask,
              "a path's later stores of every kind fit its word");

// Where an overflow entry's photon goes: its path, its kind and how many of the path's later
// photons of that kind came before it.
struct LaterStore {
  uint32_t path;
  uint16_t rank;
  uint8_t kind;
};

struct PhotonStores {
  Photon* slot;
  uint8_t* slot_kind;      // the kind of the slot's photon, or kNotStored
  uint32_t* later_counts;  // per path
  uint32_t slots_per_path;
  uint32_t first_slot_bounce;
  Photon* overflow;
  LaterStore* overflow_place;
  uint32_t* overflow_count;
  uint32_t* capped_count;           // paths that max_bounces ended, roulette not
  uint32_t* specular_capped_count;  // paths that max_specular_bounces ended
  uint32_t overflow_room;
  // With differentials: each stored photon's footprint beside it, a surface photon's spanning
  // vectors and a collision's volume.
  PhotonFootprint* slot_footprint;
  PhotonFootprint* overflow_footprint;
  float* slot_volume_footprint;  // null without media
  float* overflow_volume_footprint;

  CAUSTICA_HDI void store(uint32_t path, uint32_t bounce, const Photon& photon, uint8_t kind,
                          const PhotonFootprint& footprint) const {
    store_as(path, bounce, photon, kind, [&](bool in_slot, size_t at) {
      PhotonFootprint* to = in_slot ? slot_footprint : overflow_footprint;
      if (to != nullptr) to[at] = footprint;
    });
  }

  CAUSTICA_HDI void store_collision(uint32_t path, uint32_t bounce, const Photon& photon,
                                    float footprint_volume) const {
    store_as(path, bounce, photon, kVolumePhoton, [&](bool in_slot, size_t at) {
      float* to = in_slot ? slot_volume_footprint : overflow_volume_footprint;
      if (to != nullptr) to[at] = footprint_volume;
    });
  }

 private:
  // Stores the photon and calls with_footprint(in a slot, index) for its footprint's place.
  template <typename WithFootprint>
  CAUSTICA_HDI void store_as(uint32_t path, uint32_t bounce, const Photon& photon, uint8_t kind,
                             WithFootprint with_footprint) const {
    if (bounce - first_slot_bounce < slots_per_path) {
      const size_t k = size_t(path) * slots_per_path + (bounce - first_slot_bounce);
      slot[k] = photon;
      with_footprint(true, k);
      slot_kind[k] = kind;
      return;
    }
    // Only the path's own worker touches its word, so it needs no atomics.
    const uint32_t shift = (kind - 1u) * kLaterCountBits;
    const uint32_t counts = later_counts[path];
    later_counts[path] = counts + (1u << shift);
    const uint32_t at = atomic_fetch_add(overflow_count, 1u);
    if (at >= overflow_room) return;  // counted: the trace runs again with room for all
    overflow[at] = photon;
    with_footprint(false, at);
    overflow_place[at] = {path, uint16_t(counts >> shift & kLaterCountMask), kind};
  }
};

// What every path's emission and bounces read, copied by value into kernels.
struct PhotonPathInputs {
  ResidentSceneView scene;
  Vec3f center;
  float radius;
  float inv_count;
  uint32_t seed, pass, max_bounces, max_specular_bounces;
  PhotonStores stores;
  float spacing;        // differential_spacing of the photon count
  float photons;        // the photon count
  uint32_t first_path;  // added to a path's index for its samples (PhotonTraceSettings)

  // Path `path`'s emission: its light, chosen by power, and its first ray.
  template <bool kDifferentials>
  CAUSTICA_HDI void start(PhotonPathState<kDifferentials>& p, uint32_t path) const {
    p.path = path;
    p.s = Sampler(seed, first_path + path, pass);
    uint32_t li =
        ResidentSceneView::sample_cdf(scene.light_cdf, scene.light_count, p.s.next_float());
    const DeviceLight& light = scene.lights[li];
    float choice_pdf = light_power(light, radius) / scene.total_power;
    EmittedPhoton e = emit_from(scene, light, p.s, center, radius);
    p.ray = e.ray;
    p.power = e.power * (inv_count / choice_pdf);
    p.only_specular = true;
    p.bounce = 0;
    p.specular_run = 0;
    p.medium = scene.media.scene_medium;  // lights stand outside every shape
    if constexpr (kDifferentials)
      p.differentials = emission_differentials(light, e, choice_pdf, radius);
  }

  // The path's hit `hit` of its current ray: stores a photon at a diffuse surface and moves the
  // path on; false when the path ends there. kNormalMaps: surface_at's.
  template <bool kDifferentials, bool kNormalMaps = true>
  CAUSTICA_HDI bool bounce(PhotonPathState<kDifferentials>& p, const Hit& hit) const {
    // Nothing to carry: a photon from where an emission map is black, or filtered out by colours.
    if (is_black(p.power)) return false;
    if (p.medium != kVacuum) {
      // A collision in the medium before the surface: a volume photon there with the flux the
      // medium scatters (the extinguished flux times the albedo, Fabianowski 2011 eq. 7.1), then
      // Russian roulette on the albedo and a new direction from the phase function.
      const DeviceMedium& md = scene.media.media[p.medium];
      const MediumSpan span =
          medium_span(scene.media, p.medium, p.ray.origin, p.ray.direction, hit.t);
      const FreeFlight flight = sample_free_flight(md, p.ray.origin, p.ray.direction, span,
                                                   [&] { return p.s.next_float(); });
      p.power *= flight.weight;
      [[maybe_unused]] FlightOdds odds{};
      if constexpr (kDifferentials) {
        if (span.length() > 0.0f)
          odds = flight_odds(md, p.ray.origin, p.ray.direction, span.t0, flight.t);
      }
      if (flight.collided) {
        const Vec3f x = p.ray.origin + p.ray.direction * flight.t;
        float volume = 0.0f;
        if constexpr (kDifferentials) {
          propagate(p.differentials, flight.t);
          volume = footprint_volume(p.differentials, p.ray.direction, odds.rate * odds.survival,
                                    photons);
        }
        stores.store_collision(p.path, p.bounce, Photon{x, p.power * md.albedo, -p.ray.direction},
                               volume);
        const float survive = average(md.albedo);
        if (!(p.s.next_float() < survive)) return false;
        p.power = p.power * md.albedo / survive;
        const Vec3f travel = p.ray.direction;
        p.ray.origin = x;
        p.ray.direction =
            sample_henyey_greenstein(travel, md.g, p.s.next_float(), p.s.next_float());
        p.ray.t_min = 0.0f;
        p.ray.t_max = FLT_MAX;
        p.scattered();
        if constexpr (kDifferentials) {
          p.differentials = scattered_in_medium(
              p.ray.direction, travel, henyey_greenstein(dot(travel, p.ray.direction), md.g),
              scattering_offset(p.differentials, travel, odds.survival, survive));
        }
        return next_bounce(p);
      }
      // Through to the surface: one of the share of flights the medium let through.
      if constexpr (kDifferentials) {
        if (span.length() > 0.0f) survived_roulette(p.differentials, odds.survival);
      }
    }
    if (!hit.valid()) return false;
    SurfaceHit sh = surface_at<kNormalMaps>(scene, hit);
    const DeviceMaterial& m = scene.materials[sh.material];
    Vec3f d = p.ray.direction;
    Vec3f next_dir;
    if (m.type == MaterialType::kEmissive) return false;  // lights have black surfaces
    if constexpr (kDifferentials) transfer(p.differentials, d, hit.t, sh.geometric_normal);
    if (is_sampled_model(m)) {
      const SurfaceBsdf bsdf =
          SurfaceBsdf::at_hit(scene, m, hit, sh, d, 0.0f, Transport::kImportance);
      // Stored with the base's factor for the way it came (surface_bsdf.h), so that a gather
      // weighing the density by the base's albedo towards the viewer has the base's light.
      if (p.bounce > 0 && bsdf.has_base()) {
        PhotonFootprint footprint{};
        if constexpr (kDifferentials)
          footprint = {p.differentials.dz1 * spacing, p.differentials.dz2 * spacing};
        stores.store(p.path, p.bounce, Photon{sh.position, p.power * bsdf.base_in(-d), -d},
                     p.only_specular ? kCausticPhoton : kGlobalPhoton, footprint);
      }
      const float uc = p.s.next_float(), u0 = p.s.next_float();
      const SurfaceSample b = bsdf.sample(-d, uc, u0, p.s.next_float());
      if (!b.valid()) return false;
      next_dir = b.wi;
      const bool transmits = (b.flags & kBsdfTransmission) != 0;
      if ((dot(next_dir, sh.geometric_normal) * dot(d, sh.geometric_normal) < 0.0f) == transmits)
        return false;
      // A glossy bounce counts as a specular one: its photons are caustics, and a run of them is
      // capped as mirrors' and glass's are.
      if ((b.flags & kBsdfDiffuse) != 0) {
        p.scattered();
      } else if (!specular_bounce_allowed(p)) {
        return false;
      }
      const Vec3f weight = b.weight;
      const float survive = min_f(1.0f, average(weight));
      if (!(p.s.next_float() < survive)) return false;
      p.power = p.power * weight / survive;
      if (transmits)
        p.medium = medium_after_crossing(scene.media, hit.triangle, d, sh.geometric_normal);
      if constexpr (kDifferentials) {
        survived_roulette(p.differentials, survive);
        const Vec3f n =
            dot(next_dir, sh.geometric_normal) > 0.0f ? sh.geometric_normal : -sh.geometric_normal;
        p.differentials =
            reemitted_by_density(next_dir, n, b.pdf, reemission_offset(p.differentials));
      }
    } else if (m.type == MaterialType::kDiffuse) {
      if (p.bounce > 0) {
        PhotonFootprint footprint{};
        if constexpr (kDifferentials)
          footprint = {p.differentials.dz1 * spacing, p.differentials.dz2 * spacing};
        stores.store(p.path, p.bounce, Photon{sh.position, p.power, -d},
                     p.only_specular ? kCausticPhoton : kGlobalPhoton, footprint);
      }
      // A photon lands on one point: the finest level of a map is the colour there.
      const Vec3f color = surface_color(scene, m, hit, d, 0.0f);
      float survive = average(color);
      if (p.s.next_float() >= survive) return false;
      p.power = p.power * color / survive;
      Vec3f n = dot(d, sh.shading_normal) < 0.0f ? sh.shading_normal : -sh.shading_normal;
      next_dir = Frame::from_normal(n).to_world(
          sample_cosine_hemisphere(p.s.next_float(), p.s.next_float()));
      p.scattered();
      if constexpr (kDifferentials) {
        survived_roulette(p.differentials, survive);
        p.differentials = reemitted_diffusely(next_dir, n, reemission_offset(p.differentials));
      }
    } else if (m.type == MaterialType::kMirror) {
      if (!specular_bounce_allowed(p)) return false;
      const Vec3f color = surface_color(scene, m, hit, d, 0.0f);
      float survive = average(color);
      if (p.s.next_float() >= survive) return false;
      p.power = p.power * color / survive;
      next_dir = reflect(d, sh.shading_normal);
      if constexpr (kDifferentials) {
        Vec3f dn1, dn2;
        normal_differentials(scene, hit, sh, p.differentials, dn1, dn2);
        survived_roulette(p.differentials, survive);
        reflect_differentials(p.differentials, d, sh.shading_normal, dn1, dn2);
      }
    } else {  // dielectric: reflect or refract in proportion to Fresnel, weight 1
      if (!specular_bounce_allowed(p)) return false;
      DielectricSide side = dielectric_side(d, sh.shading_normal, m.ior);
      float fr = fresnel_dielectric(side.cos_i, side.eta);
      const bool reflects = p.s.next_float() < fr || !refract(d, side.normal, side.eta, next_dir);
      if (reflects) {
        next_dir = reflect(d, side.normal);
      } else {
        p.medium = medium_after_crossing(scene.media, hit.triangle, d, sh.geometric_normal);
      }
      if constexpr (kDifferentials) {
        Vec3f dn1, dn2;
        normal_differentials(scene, hit, sh, p.differentials, dn1, dn2);
        if (dot(side.normal, sh.shading_normal) < 0.0f) {  // the normal of the side left from
          dn1 = -dn1;
          dn2 = -dn2;
        }
        if (reflects) {
          reflect_differentials(p.differentials, d, side.normal, dn1, dn2);
        } else {
          refract_differentials(p.differentials, d, side.normal, side.eta, next_dir, dn1, dn2);
        }
      }
    }
    p.ray.origin = offset_origin(sh.position, sh.geometric_normal, next_dir);
    p.ray.direction = next_dir;
    p.ray.t_min = 0.0f;
    p.ray.t_max = FLT_MAX;
    return next_bounce(p);
  }

  // Counts a mirror or glass bounce; false, counted in specular_capped_count, when the path has
  // taken max_specular_bounces of them in a row. Checked before the bounce draws a sample, so
  // that a cap no path reaches changes no photon.
  template <bool kDifferentials>
  CAUSTICA_HDI bool specular_bounce_allowed(PhotonPathState<kDifferentials>& p) const {
    if (p.specular_run < max_specular_bounces) {
      ++p.specular_run;
      return true;
    }
    atomic_fetch_add(stores.specular_capped_count, 1u);
    return false;
  }

  // Counts the bounce; false, counted in capped_count, when it was the path's last by the cap.
  template <bool kDifferentials>
  CAUSTICA_HDI bool next_bounce(PhotonPathState<kDifferentials>& p) const {
    if (++p.bounce < max_bounces) return true;
    atomic_fetch_add(stores.capped_count, 1u);
    return false;
  }
};

// The paths as ray queues, for structures that answer batches only (and for any structure when
// asked): every live path's next ray in one batch of closest hits per wave, the paths that go on
// compacted for the next. Each path's samples and slots follow from its index alone, as in the
// per-thread trace, so the photons are the same.
template <bool kDifferentials, typename Structure>
void trace_photon_waves(Backend& backend, const Structure& structure,
                        const PhotonPathInputs& inputs, uint32_t count) {
  using PhotonPathState = caustica::PhotonPathState<kDifferentials>;
  Buffer<PhotonPathState> wave(backend, count), next(backend, count);
  Buffer<Ray> rays(backend, count);
  Buffer<Hit> hits(backend, count);
  Buffer<uint8_t> goes_on(backend, count);
  Buffer<uint32_t> going(backend, count);
  PhotonPathState* first = wave.data();
  const PhotonPathInputs in = inputs;
  parallel_for(backend, "photon_wave_start", count, [=] CAUSTICA_HD(size_t i) {
    PhotonPathState p{Ray{}, Vec3f(0.0f), Sampler(in.seed, 0, in.pass), 0, 0, 0, kVacuum, true, {}};
    in.start(p, uint32_t(i));
    first[i] = p;
  });
  size_t live = count;
  while (live > 0) {
    Ray* ray = rays.data();
    const PhotonPathState* current = wave.data();
    parallel_for(backend, "photon_wave_rays", live,
                 [=] CAUSTICA_HD(size_t i) { ray[i] = current[i].ray; });
    trace_closest_surfaces(backend, structure, in.scene, rays.data(), live, hits.data());
    PhotonPathState* state = wave.data();
    const Hit* hit = hits.data();
    uint8_t* on = goes_on.data();
    parallel_for(backend, "photon_wave_bounce", live, [=] CAUSTICA_HD(size_t i) {
      PhotonPathState p = state[i];
      on[i] = in.bounce(p, hit[i]) ? 1 : 0;
      state[i] = p;
    });
    const size_t kept = backend.select_flagged(nullptr, goes_on.data(), live, going.data());
    PhotonPathState* to = next.data();
    const uint32_t* index = going.data();
    parallel_for(backend, "photon_wave_compact", kept,
                 [=] CAUSTICA_HD(size_t i) { to[i] = state[index[i]]; });
    std::swap(wave, next);
    live = kept;
  }
}

// The paths one per thread (per worker on a GPU), each hit traced through the per-ray view.
// kSurfaceMaps: whether the scene has normal maps or cut-outs (surface_at's kNormalMaps and
// closest_surface_hit's kCutouts), since this kernel's registers are bounded for its occupancy.
template <bool kDifferentials, bool kSurfaceMaps, typename Structure>
void trace_photons_per_thread(Backend& backend, const Structure& structure,
                              const PhotonPathInputs& in, uint32_t count, bool regenerate,
                              uint32_t workers, uint32_t* next) {
  const auto trace_paths = [=] CAUSTICA_HD(size_t worker) {
    PhotonPathState<kDifferentials> p{
        Ray{}, Vec3f(0.0f), Sampler(in.seed, 0, in.pass), 0, 0, 0, kVacuum, true, {}};
    in.start(p, uint32_t(worker));
    // One loop over hits, not a loop over paths around a loop over hits, so that lanes whose paths
    // end do not wait at the inner loop's exit for the others.
    while (true) {
      const Hit hit = closest_surface_hit<kSurfaceMaps>(structure, in.scene, p.ray);
      if (in.template bounce<kDifferentials, kSurfaceMaps>(p, hit)) continue;
      if (!regenerate) return;
      const uint32_t path = atomic_fetch_add(next, 1u);
      if (path >= count) return;
      in.start(p, path);
    }
  };
  parallel_for<kWorkersPerMultiprocessor>(backend, "photon_trace", workers, trace_paths);
}

// The buffers behind a trace's PhotonStores, for `paths` paths of `slots_per_path` slots from
// bounce `first_bounce`: the slots with their kinds and the footprints beside them, each path's
// count of later stores, and the overflow list, its footprints and the trace's counters. Volume
// footprints exist with media only, footprints with differentials only.
struct PhotonStoreBuffers {
  PhotonStoreBuffers(Backend& backend, uint32_t paths, uint32_t slots_per_path,
                     uint32_t first_bounce, bool with_media, bool with_footprints)
      : paths(paths),
        slots(size_t(paths) * slots_per_path),
        per_path(slots_per_path),
        first_slot_bounce(first_bounce),
        media(with_media),
        footprints(with_footprints),
        slot_photons(backend, slots),
        slot_kinds(backend, slots),
        later_counts(backend, paths),
        slot_footprints(backend, footprints ? slots : 0),
        slot_volume_footprints(backend, footprints && media ? slots : 0),
        overflow(backend, 0),
        overflow_places(backend, 0),
        overflow_footprints(backend, 0),
        overflow_volume_footprints(backend, 0),
        counters(backend, 3) {}

  // Clears the slots' kinds, the paths' counts and the counters, and makes room for
  // `overflow_room` later stores.
  void clear(size_t overflow_room) {
    slot_kinds.fill_zero();
    later_counts.fill_zero();
    counters.fill_zero();
    overflow.resize_discard(overflow_room);
    overflow_places.resize_discard(overflow_room);
    if (footprints) overflow_footprints.resize_discard(overflow_room);
    if (footprints && media) overflow_volume_footprints.resize_discard(overflow_room);
  }

  // The stores into these buffers, with room for `overflow_room` later stores (clear).
  PhotonStores stores(size_t overflow_room) {
    return {slot_photons.data(),
            slot_kinds.data(),
            later_counts.data(),
            per_path,
            first_slot_bounce,
            overflow.data(),
            overflow_places.data(),
            counters.data(),
            counters.data() + 1,
            counters.data() + 2,
            uint32_t(overflow_room),
            footprints ? slot_footprints.data() : nullptr,
            footprints ? overflow_footprints.data() : nullptr,
            footprints && media ? slot_volume_footprints.data() : nullptr,
            footprints && media ? overflow_volume_footprints.data() : nullptr};
  }

  // The maps a trace stores photons for: caustic and global, and volume with media.
  uint32_t kinds() const { return media ? 3 : 2; }

  uint32_t paths;
  size_t slots;
  uint32_t per_path, first_slot_bounce;
  bool media, footprints;
  Buffer<Photon> slot_photons;
  Buffer<uint8_t> slot_kinds;
  Buffer<uint32_t> later_counts;
  Buffer<PhotonFootprint> slot_footprints;
  Buffer<float> slot_volume_footprints;
  Buffer<Photon> overflow;
  Buffer<LaterStore> overflow_places;
  Buffer<PhotonFootprint> overflow_footprints;
  Buffer<float> overflow_volume_footprints;
  // The later stores asked for room, and the paths max_bounces and max_specular_bounces ended.
  Buffer<uint32_t> counters;
};

// What every path of a trace reads, but for its stores, which each retry of the trace gives anew.
PhotonPathInputs path_inputs(const ResidentSceneView& scene, const ResidentScene& resident,
                             const PhotonTraceSettings& settings) {
  const Vec3f center = resident.bounds().center();
  const float radius = resident.radius();
  const uint32_t total = settings.total_paths != 0 ? settings.total_paths : settings.photon_count;
  const float inv_count = 1.0f / float(total);
  const uint32_t seed = settings.seed ^ kPhotonDomain, pass = settings.pass;
  return {scene,
          center,
          radius,
          inv_count,
          seed,
          pass,
          settings.max_bounces,
          settings.max_specular_bounces,
          PhotonStores{},
          differential_spacing(float(total)),
          float(total),
          settings.first_path};
}

// Traces every path once, with `workers` workers that take a new path as theirs ends when
// `regenerate`, from the index in `next` on. The differentials' two instantiations, and the
// per-thread trace's two for normal maps: a trace without them keeps the common trace's
// registers, which its occupancy depends on.
template <typename Structure>
void trace_paths(Backend& backend, const Structure& structure, const PhotonPathInputs& in,
                 const PhotonTraceSettings& settings, bool regenerate, uint32_t workers,
                 uint32_t* next) {
  const uint32_t count = settings.photon_count;
  const auto trace = [&](auto with_differentials) {
    constexpr bool kDifferentials = decltype(with_differentials)::value;
    if constexpr (StructureView<Structure>) {
      if (settings.ray_queues) {
        trace_photon_waves<kDifferentials>(backend, structure, in, count);
      } else {
        if (in.scene.has_normal_maps || in.scene.has_cutouts) {
          trace_photons_per_thread<kDifferentials, true>(backend, structure, in, count, regenerate,
                                                         workers, next);
        } else {
          trace_photons_per_thread<kDifferentials, false>(backend, structure, in, count,
                                                          regenerate, workers, next);
        }
      }
    } else {
      trace_photon_waves<kDifferentials>(backend, structure, in, count);
    }
  };
  if (settings.differentials) {
    trace(std::true_type{});
  } else {
    trace(std::false_type{});
  }
}

// What a trace counted: the later stores the overflow list holds, the paths that max_bounces
// ended where Russian roulette would have let them go on, and those max_specular_bounces ended.
struct TraceCounts {
  size_t overflowed = 0;
  uint32_t capped = 0;
  uint32_t specular_capped = 0;
};

// Where the photons of a trace go: each path's first photon of each run (a kind's photons from
// slots, then from the overflow list), as a place in the concatenation of all runs, and where
// each run starts; with the trace's counts, which come back in the same copy.
struct PhotonPlaces {
  Buffer<uint32_t> place;           // run r, path p at r paths + p; the total after the last
  std::vector<uint32_t> run_start;  // runs 2 kind and 2 kind + 1 (kinds from 0), then the total
  TraceCounts counted;
};

// Counts each path's photons of each run, and one scan over the counts, laid out run after run,
// gives every photon its place, so that no photon needs sorting or selecting. The run starts and
// the trace's counters come to the host in one copy.
PhotonPlaces place_photons(Backend& backend, const PhotonStoreBuffers& buffers) {
  const uint32_t paths = buffers.paths;
  const uint32_t per_path = buffers.per_path;
  const uint32_t kinds = buffers.kinds();
  const size_t runs = 2 * size_t(kinds);
  PhotonPlaces out{Buffer<uint32_t>(backend, runs * paths + 1), {}, {}};
  uint32_t* count = out.place.data();
  const uint8_t* slot_kind = buffers.slot_kinds.data();
  const uint32_t* later = buffers.later_counts.data();
  parallel_for(backend, "photon_store_counts", paths, [=] CAUSTICA_HD(size_t path) {
    uint32_t caustic = 0, global = 0, volume = 0;
    for (uint32_t j = 0; j < per_path; ++j) {
      const uint8_t kind = slot_kind[path * per_path + j];
      caustic += kind == kCausticPhoton;
      global += kind == kGlobalPhoton;
      volume += kind == kVolumePhoton;
    }
    const uint32_t later_of_path = later[path];
    count[path] = caustic;
    count[paths + path] = later_of_path & kLaterCountMask;
    count[2 * size_t(paths) + path] = global;
    count[3 * size_t(paths) + path] = later_of_path >> kLaterCountBits & kLaterCountMask;
    if (kinds == 3) {
      count[4 * size_t(paths) + path] = volume;
      count[5 * size_t(paths) + path] = later_of_path >> (2 * kLaterCountBits) & kLaterCountMask;
    }
    if (path == 0) count[runs * paths] = 0;  // its place: the total
  });
  backend.exclusive_scan(count, count, runs * paths + 1);
  // Where each run begins, the end of the last and the trace's counters, in one copy.
  Buffer<uint32_t> summary(backend, runs + 1 + 3);
  uint32_t* starts = summary.data();
  const uint32_t* at = out.place.data();
  const uint32_t* counters = buffers.counters.data();
  parallel_for(backend, "photon_store_runs", 1, [=] CAUSTICA_HD(size_t) {
    for (size_t r = 0; r <= runs; ++r) starts[r] = at[r * paths];
    for (size_t c = 0; c < 3; ++c) starts[runs + 1 + c] = counters[c];
  });
  out.run_start = summary.download();
  const uint32_t* counted = out.run_start.data() + runs + 1;
  out.counted = {counted[0], counted[1], counted[2]};
  out.run_start.resize(runs + 1);
  return out;
}

// Traces the paths of `in` into `buffers` until the overflow list has room for every later store,
// and places the photons.
template <typename Structure>
PhotonPlaces trace_until_stored(Backend& backend, const Structure& structure, PhotonPathInputs in,
                                const PhotonTraceSettings& settings, PhotonStoreBuffers& buffers) {
  const uint32_t count = settings.photon_count;
  // Paths end after anywhere from one to max_bounces hits (Russian roulette), so a warp tracing
  // one path per thread keeps its lanes waiting for its longest path, most of them idle. On the
  // GPU a fixed set of workers therefore takes the next path as soon as its current one ends, and
  // every lane traces a hit in every step. The result does not depend on which worker traced a
  // path: its samples and slots follow from its index alone.
  const bool regenerate = backend.kind() == DeviceKind::kCuda;
  const uint32_t workers =
      regenerate ? uint32_t(std::min<size_t>(
                       count, size_t(backend.info().compute_units) * kWorkersPerMultiprocessor))
                 : count;
  Buffer<uint32_t> next_path(backend, 1);
  uint32_t* next = next_path.data();
  // Room for the later stores: a path stores past its slots only when roulette spares it through
  // kSlotsPerPath diffuse bounces, a few in a hundred; a trace that finds too little room runs
  // again with exactly enough.
  size_t overflow_room = count / 8 + 64;
  while (true) {
    buffers.clear(overflow_room);
    parallel_for(backend, "photon_next_path", 1,
                 [=] CAUSTICA_HD(size_t) { *next = workers; });  // no host round trip
    in.stores = buffers.stores(overflow_room);
    trace_paths(backend, structure, in, settings, regenerate, workers, next);
    PhotonPlaces places = place_photons(backend, buffers);
    if (places.counted.overflowed <= overflow_room) return places;
    overflow_room = places.counted.overflowed;
  }
}

// Compaction into `out`: each kind's photons from the slots in path order, then its later photons
// in path and bounce order, and their footprints alike, each to the place `places` gives it.
void compact_photons(Backend& backend, const PhotonStoreBuffers& buffers,
                     const PhotonPlaces& places, TracedPhotons& out) {
  const uint32_t paths = buffers.paths;
  const uint32_t per_path = buffers.per_path;
  const uint8_t* slot_kind = buffers.slot_kinds.data();
  const uint32_t* at = places.place.data();
  const std::vector<uint32_t>& start = places.run_start;
  const size_t overflowed = places.counted.overflowed;
  const auto kind_size = [&](uint32_t kind) {
    return size_t(start[2 * kind + 2] - start[2 * kind]);
  };
  out.caustic.resize_discard(kind_size(0));
  out.global.resize_discard(kind_size(1));
  out.caustic_from_slots = start[1] - start[0];
  out.global_from_slots = start[3] - start[2];
  if (buffers.media) {
    out.volume.resize_discard(kind_size(2));
    out.volume_from_slots = start[5] - start[4];
  }
  const bool footprints = buffers.footprints;
  if (footprints) {
    out.caustic_footprints.resize_discard(kind_size(0));
    out.global_footprints.resize_discard(kind_size(1));
    if (buffers.media) out.volume_footprints.resize_discard(kind_size(2));
  }
  // Each kind's photons go to its own buffer, chosen by condition rather than from an array, which
  // a GPU would index in local memory.
  Photon* const caustic = out.caustic.data();
  Photon* const global = out.global.data();
  Photon* const volume = out.volume.data();
  PhotonFootprint* const caustic_footprint = footprints ? out.caustic_footprints.data() : nullptr;
  PhotonFootprint* const global_footprint = footprints ? out.global_footprints.data() : nullptr;
  float* const volume_footprint =
      footprints && buffers.media ? out.volume_footprints.data() : nullptr;
  const uint32_t global_start = start[2], volume_start = buffers.media ? start[4] : 0;
  const Photon* slot = buffers.slot_photons.data();
  const Photon* overflow = buffers.overflow.data();
  const LaterStore* later_place = buffers.overflow_places.data();
  const PhotonFootprint* slot_footprint = footprints ? buffers.slot_footprints.data() : nullptr;
  const PhotonFootprint* overflow_footprint =
      footprints ? buffers.overflow_footprints.data() : nullptr;
  const float* slot_volume_footprint =
      footprints && buffers.media ? buffers.slot_volume_footprints.data() : nullptr;
  const float* overflow_volume_footprint =
      footprints && buffers.media ? buffers.overflow_volume_footprints.data() : nullptr;
  // One thread per path for its slots, which it walks in order counting each kind's photons, then
  // one per overflow entry.
  parallel_for(backend, "photon_compact", paths + overflowed, [=] CAUSTICA_HD(size_t i) {
    // Photon `from` of the slots or of the overflow list, of kind `kind`, to its place `to`.
    const auto move = [&](bool from_slot, size_t from, uint8_t kind, size_t to) {
      const Photon& photon = from_slot ? slot[from] : overflow[from];
      if (kind == kVolumePhoton) {
        to -= volume_start;
        volume[to] = photon;
        if (footprints)
          volume_footprint[to] =
              from_slot ? slot_volume_footprint[from] : overflow_volume_footprint[from];
        return;
      }
      const bool is_caustic = kind == kCausticPhoton;
      if (!is_caustic) to -= global_start;
      (is_caustic ? caustic : global)[to] = photon;
      if (footprints) {  // not by a null test: an empty kind's buffer has none
        (is_caustic ? caustic_footprint : global_footprint)[to] =
            from_slot ? slot_footprint[from] : overflow_footprint[from];
      }
    };
    if (i >= paths) {
      const LaterStore p = later_place[i - paths];
      move(false, i - paths, p.kind, at[(2 * size_t(p.kind - 1) + 1) * paths + p.path] + p.rank);
      return;
    }
    const size_t path = i;
    uint32_t caustic_rank = 0, global_rank = 0, volume_rank = 0;
    for (uint32_t j = 0; j < per_path; ++j) {
      const size_t k = path * per_path + j;
      const uint8_t kind = slot_kind[k];
      if (kind == kNotStored) continue;
      const uint32_t rank = kind == kCausticPhoton  ? caustic_rank++
                            : kind == kGlobalPhoton ? global_rank++
                                                    : volume_rank++;
      move(true, k, kind, at[2 * size_t(kind - 1) * paths + path] + rank);
    }
  });
}

// trace_photons with the paths traced through `structure`, the view of the scene's structure.
template <typename Structure>
TracedPhotons trace_photons_through(const Structure& structure, Backend& backend,
                                    const ResidentScene& resident,
                                    const PhotonTraceSettings& settings) {
  TracedPhotons out;
  out.caustic.bind(backend);
  out.global.bind(backend);
  out.caustic_footprints.bind(backend);
  out.global_footprints.bind(backend);
  out.volume.bind(backend);
  out.volume_footprints.bind(backend);
  const ResidentSceneView scene = resident.view();
  // A photon is stored at a surface at its second hit at the earliest (first hits are direct
  // light), so without media a path of one hit stores nothing; in a medium its first collision is
  // stored.
  const bool media = scene.media.any();
  const uint32_t first_slot_bounce = media ? 0 : 1;
  if (settings.photon_count == 0 || settings.max_bounces < first_slot_bounce + 1 ||
      scene.light_count == 0 || scene.total_power <= 0)
    return out;
  out.emitted = settings.photon_count;

  // Slots for each path's first stores (a photon at every interaction from the first stored).
  const uint32_t per_path = std::min(settings.max_bounces - first_slot_bounce, kSlotsPerPath);
  PhotonStoreBuffers buffers(backend, settings.photon_count, per_path, first_slot_bounce, media,
                             settings.differentials);
  const PhotonPlaces places = trace_until_stored(
      backend, structure, path_inputs(scene, resident, settings), settings, buffers);
  compact_photons(backend, buffers, places, out);
  out.capped_paths = places.counted.capped;
  out.specular_capped_paths = places.counted.specular_capped;
  return out;
}

}  // namespace

TracedPhotons trace_photons(Backend& backend, const ResidentScene& resident,
                            const PhotonTraceSettings& settings) {
  if (settings.max_bounces > kMaxPhotonBounces)
    throw std::invalid_argument("trace_photons: max_bounces " +
                                std::to_string(settings.max_bounces) + " is over " +
                                std::to_string(kMaxPhotonBounces));
  return resident.structure().visit([&](const auto& structure) {
    return trace_photons_through(structure, backend, resident, settings);
  });
}

}  // namespace caustica
