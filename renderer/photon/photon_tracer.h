// Photon emission and tracing (Jensen 2001; Zeidan 2011 ch. 6): a light is chosen in proportion
// to its power, photons bounce off mirrors and through glass and are stored at diffuse surfaces,
// with Russian roulette on the average albedo and per-channel flux rescaling. Paths L S+ D go to
// the caustic map; paths with a diffuse bounce before their last hit go to the global map; direct
// hits (L D) are left to shadow rays.
#pragma once

#include <cstdint>

#include "renderer/photon/photon.h"
#include "renderer/resident/resident_scene.h"

namespace caustica {

struct PhotonTraceSettings {
  uint32_t photon_count = 0;  // paths emitted
  uint32_t max_bounces = 64;  // surface interactions per path, a cap behind Russian roulette
  uint32_t seed = 1;
  uint32_t pass = 0;
  // A share of a pass split over devices: paths [first_path, first_path + photon_count) of
  // `total_paths` (0: photon_count, the whole pass). Each path's samples follow from its index in
  // the whole pass and its power from the whole count, so the shares' photons, concatenated in
  // order, are the whole pass's.
  uint32_t first_path = 0;
  uint32_t total_paths = 0;
  // Trace the paths in waves of batched closest hits even where the structure answers single
  // rays; structures that answer batches only always do. The photons are the same either way.
  bool ray_queues = false;
  // Track photon differentials (differentials.h) and give every stored photon its footprint.
  bool differentials = false;
  // Mirror and glass bounces in a row that end a path (RenderSettings).
  uint32_t max_specular_bounces = 64;
  bool operator==(const PhotonTraceSettings&) const = default;
};

struct TracedPhotons {
  Buffer<Photon> caustic;
  Buffer<Photon> global;
  // Collisions in participating media: where the photon was stopped, the flux scattered there
  // and the direction back along the way it came. Empty without media.
  Buffer<Photon> volume;
  // With PhotonTraceSettings::differentials, each stored photon's footprint, in the same order.
  Buffer<PhotonFootprint> caustic_footprints;
  Buffer<PhotonFootprint> global_footprints;
  // With differentials, each collision's footprint volume (differentials.h): the inverse of the
  // collisions' density there.
  Buffer<float> volume_footprints;
  uint32_t emitted = 0;
  // The paths that max_bounces ended where Russian roulette would have let them go on: what the
  // cap cost, in light that never reached the maps (docs/performance.md, "The light change").
  uint32_t capped_paths = 0;
  // The paths that max_specular_bounces ended (within max_bounces): light trapped in glass.
  uint32_t specular_capped_paths = 0;
  // Each kind's photons come in two runs: those from the paths' first stores, in path order, then
  // the later stores of the few long paths, in path and bounce order. These are the first runs'
  // lengths, which merge_traced_photons (photon_shares.h) needs.
  size_t caustic_from_slots = 0, global_from_slots = 0, volume_from_slots = 0;
};

// Pass `pass` of `photons` paths, capped and seeded as `settings` say: every setting the photons
// depend on, so that two settings trace the same photons when these agree.
inline PhotonTraceSettings photon_trace_settings(const RenderSettings& settings, uint32_t photons,
                                                 uint32_t pass) {
  PhotonTraceSettings trace{photons, settings.max_photon_bounces, settings.seed, pass};
  trace.max_specular_bounces = settings.max_photon_specular_bounces;
  return trace;
}

TracedPhotons trace_photons(Backend& backend, const ResidentScene& scene,
                            const PhotonTraceSettings& settings);

}  // namespace caustica
