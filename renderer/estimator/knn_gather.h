// The k-nearest-neighbour gather stage of the render pass (render/whitted.h): every request
// estimated from its k nearest photons in a caustic and a global map (photon/knn_estimate.h),
// by counting on a GPU from k = 64 on (photon/binned_estimate.h), else with neighbour heaps.
#pragma once

#include "renderer/photon/photon_map.h"
#include "renderer/render/whitted.h"

namespace caustica {

// Photons per leaf of the photon maps for a pass's gathers at `k` on `device`: `requested` when not
// 0, else what suits the search: 16 where a GPU's estimates count (from k = 64 on), 8 where
// searches keep heaps (the CPU at every k, a GPU below 64). The estimates are the same at any leaf
// size; only their speed differs.
uint32_t photons_per_leaf_for(DeviceKind device, uint32_t k, uint32_t requested = 0);

class KnnGather final : public RadianceGather {
 public:
  // The maps are borrowed: they outlive the gather.
  KnnGather(const PhotonMap& caustic, const PhotonMap& global)
      : caustic_(caustic), global_(global) {}
  void gather(Backend& backend, const GatherRequests& requests, const ShadingSettings& settings,
              Vec3f* gathered) const override;

 private:
  const PhotonMap& caustic_;
  const PhotonMap& global_;
};

}  // namespace caustica
