#include "renderer/estimator/knn_estimator.h"

#include <utility>

#include "renderer/estimator/final_gather.h"
#include "renderer/estimator/knn_gather.h"

namespace caustica {

void KnnEstimator::prepare(Backend& backend, const ResidentScene& scene,
                           const TracedPhotons& photons, uint32_t pass) {
  maps_.reset();  // frees the old maps before the new ones are allocated
  const uint32_t per_leaf =
      photons_per_leaf_for(backend.kind(), options_.k_nearest, options_.photons_per_leaf);
  PhotonMapPair surface = build_photon_maps(backend, photons.caustic, photons.global, per_leaf);
  maps_ = Maps{pass, std::move(surface.first), std::move(surface.second),
               build_volume_map(backend, photons.volume, per_leaf, kVolumeNearest,
                                volume_bandwidth_cap(scene.bounds()))};
}

void KnnEstimator::render(Backend& backend, const ResidentScene& scene, const PinholeCamera& camera,
                          const ShadingSettings& shading, Film& film) {
  const std::optional<Maps> maps = std::move(maps_);
  maps_.reset();
  ShadingSettings with_volume = shading;
  with_volume.volume = maps->volume.view();
  if (options_.final_gather) {
    FinalGatherSettings gather;
    gather.rays = options_.final_gather_rays;
    gather.seeds = options_.final_gather_seeds;
    render_pass(backend, scene, camera, with_volume,
                FinalGather(scene, camera, maps->caustic, maps->global, gather), film);
  } else {
    render_pass(backend, scene, camera, with_volume, KnnGather(maps->caustic, maps->global), film);
  }
}

size_t KnnEstimator::map_bytes() const {
  return maps_ ? maps_->caustic.bytes() + maps_->global.bytes() + maps_->volume.bytes() : 0;
}

}  // namespace caustica
