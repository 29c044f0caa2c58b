// Final gathering (settings.final_gather, Zeidan 2011 ch. 6 after Wang et al. 2009), an option of
// the k-nearest estimator's indirect term: instead of reading the global map at every diffuse hit
// of the camera paths, which shows its blotches, the pass
// - seeds gather points among the hits, adaptively, in a screen-space quadtree
//   (render/adaptive_seeds.h);
// - sends `rays` cosine-distributed gather rays from each seed, through mirrors and glass to a
//   diffuse hit, whose outgoing radiance is its direct light (a shadow ray) plus both photon maps'
//   estimate there; their mean times pi is the seed's irradiance, with its gradients
//   (estimator/irradiance_gradients.h);
// - interpolates each hit's irradiance from its nearest seeds that face its way, each carried
//   there by its gradients.
// Caustics are still estimated directly from the caustic map. Light the gather rays find on
// emitters is left out: it is the shadow rays' (direct) or the caustic map's (through mirrors).
#pragma once

#include <cstdint>

#include "renderer/photon/photon_map.h"
#include "renderer/render/camera.h"
#include "renderer/render/whitted.h"
#include "renderer/resident/resident_scene.h"

namespace caustica {

struct FinalGatherSettings {
  uint32_t rays = 256;  // gather rays per seed
  // Seeds per pass; 0 takes kDefaultSeeds, at most one a pixel (docs/convergence.md, "Final
  // gathering").
  uint32_t seeds = 0;
  uint32_t interpolated = 16;  // nearest seeds an irradiance is interpolated from
};

constexpr uint32_t kDefaultSeeds = 4096;

class FinalGather final : public RadianceGather {
 public:
  // Everything is borrowed: it outlives the gather.
  FinalGather(const ResidentScene& scene, const PinholeCamera& camera, const PhotonMap& caustic,
              const PhotonMap& global, const FinalGatherSettings& settings)
      : scene_(scene), camera_(camera), caustic_(caustic), global_(global), settings_(settings) {}
  void gather(Backend& backend, const GatherRequests& requests, const ShadingSettings& settings,
              Vec3f* gathered) const override;

 private:
  const ResidentScene& scene_;
  const PinholeCamera& camera_;
  const PhotonMap& caustic_;
  const PhotonMap& global_;
  FinalGatherSettings settings_;
};

}  // namespace caustica
