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
  // Trace the paths in waves of batched closest hits even where the structure answers single
  // rays; structures that answer batches only always do. The photons are the same either way.
  bool ray_queues = false;
  // Track photon differentials (differentials.h) and give every stored photon its footprint.
  bool differentials = false;
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
};

TracedPhotons trace_photons(Backend& backend, const ResidentScene& scene,
                            const PhotonTraceSettings& settings);

}  // namespace caustica
