// Variable kernel density estimation (settings.estimator "vkde", Fabianowski 2011 ch. 5-6): the
// photons are traced with differentials, every stored photon whose footprint is not degenerate
// gets an anisotropic kernel shaped by it (photon/vkde_kernel.h), and one map over the kernels'
// supports (photon/kernel_map.h), caustic and global alike, answers each gather request with the
// kernels whose support holds it. In participating media, every collision's bandwidth comes from
// its differentials too (photon/volume_map.h), for the beam radiance estimate. Nothing lives
// across passes; the film averages them.
#pragma once

#include <optional>

#include "renderer/estimator/estimator.h"
#include "renderer/photon/kernel_map.h"
#include "renderer/photon/volume_map.h"

namespace caustica {

// The kernels' settings for a scene of radius `scene_radius` (docs/convergence.md, "VKDE"): the
// dampening pivots on the radius, axes are clamped to an eighth of it, and a spread of 0 takes
// sqrt(k / (2 pi)), whose kernels each cover k / 2 of their own photons' footprints.
VkdeSettings vkde_settings(const EstimatorOptions& options, float scene_radius);

// The dampening pivot of the collisions' bandwidths over the scene's radius, chosen by comparing
// the fog and smoke boxes with their path-traced references (docs/media.md, "Bandwidths from
// photon differentials").
constexpr float kVolumePivotScale = 0.05f;

// The collisions' bandwidths for a scene of radius `scene_radius` and `photons` emitted: the
// spread whose spheres each hold kVolumeNearest collisions where the differentials are exact, as
// the knn estimator's do, the dampening pivot kVolumePivotScale of the radius, and the knn
// estimator's cap.
VolumeKernelSettings volume_kernel_settings(float scene_radius, const Aabb& scene_bounds,
                                            uint32_t photons);

// The proportionality constant c of the hierarchy's leaf size n_auto here: Fabianowski's c = 8
// made leaves of about 300 kernels, which a GPU thread walks alone, and frames 2.4 times slower
// than c = 1/8, leaves of 5 (docs/convergence.md, "VKDE").
constexpr double kVkdeLeafScale = 0.125;

// The gather stage: each request's sum over the kernels that hold it and face it.
class VkdeGather final : public RadianceGather {
 public:
  explicit VkdeGather(const KernelMap& map) : map_(map) {}
  void gather(Backend& backend, const GatherRequests& requests, const ShadingSettings& settings,
              Vec3f* gathered) const override;

 private:
  const KernelMap& map_;
};

class VkdeEstimator final : public Estimator {
 public:
  explicit VkdeEstimator(const EstimatorOptions& options) : options_(options) {}
  bool needs_differentials() const override { return true; }
  void prepare(Backend& backend, const ResidentScene& scene, const TracedPhotons& photons,
               uint32_t pass) override;
  bool prepared_for(uint32_t pass) const override { return map_ && map_pass_ == pass; }
  void drop_maps() override {
    map_.reset();
    volume_.reset();
  }
  void render(Backend& backend, const ResidentScene& scene, const PinholeCamera& camera,
              const ShadingSettings& shading, Film& film) override;
  size_t map_bytes() const override {
    return (map_ ? map_->bytes() : 0) + (volume_ ? volume_->bytes() : 0);
  }
  size_t state_bytes() const override { return 0; }

 private:
  EstimatorOptions options_;
  std::optional<KernelMap> map_;
  std::optional<VolumeMap> volume_;  // empty without media
  uint32_t map_pass_ = 0;
};

}  // namespace caustica
