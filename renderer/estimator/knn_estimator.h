// The k-nearest-neighbour estimator (settings.estimator "knn", the default): fresh caustic and
// global maps every pass, each diffuse hit of the camera's specular trees estimated from its k
// nearest photons in both (render/whitted.h), or with final gathering for the indirect light
// (final_gather.h), the passes averaged by the film; camera rays through participating media
// gather from a volume map (volume_map.h). Nothing lives across passes.
#pragma once

#include <optional>

#include "renderer/estimator/estimator.h"
#include "renderer/photon/photon_map.h"
#include "renderer/photon/volume_map.h"

namespace caustica {

class KnnEstimator final : public Estimator {
 public:
  explicit KnnEstimator(const EstimatorOptions& options) : options_(options) {}
  void prepare(Backend& backend, const ResidentScene& scene, const TracedPhotons& photons,
               uint32_t pass) override;
  bool prepared_for(uint32_t pass) const override { return maps_ && maps_->pass == pass; }
  void drop_maps() override { maps_.reset(); }
  void render(Backend& backend, const ResidentScene& scene, const PinholeCamera& camera,
              const ShadingSettings& shading, Film& film) override;
  size_t map_bytes() const override;
  size_t state_bytes() const override { return 0; }

 private:
  struct Maps {
    uint32_t pass;
    PhotonMap caustic, global;
    VolumeMap volume;  // empty without media
  };
  EstimatorOptions options_;
  std::optional<Maps> maps_;
};

}  // namespace caustica
