// Stochastic progressive photon mapping (settings.estimator "sppm", photon/sppm.h): one map of
// every stored photon per pass, caustic and global alike; per pixel a visible point each pass
// (render/visible_points.h) and statistics that live until the film restarts, so that the image
// converges as passes accumulate instead of keeping the blur of a fixed k.
#pragma once

#include <optional>

#include "renderer/estimator/estimator.h"
#include "renderer/photon/sppm.h"

namespace caustica {

class SppmEstimator final : public Estimator {
 public:
  SppmEstimator(Backend& backend, const EstimatorOptions& options);
  void prepare(Backend& backend, const ResidentScene& scene, const TracedPhotons& photons,
               uint32_t pass) override;
  bool prepared_for(uint32_t pass) const override { return map_ && map_pass_ == pass; }
  void drop_maps() override { map_.reset(); }
  void render(Backend& backend, const ResidentScene& scene, const PinholeCamera& camera,
              const ShadingSettings& shading, Film& film) override;
  size_t map_bytes() const override { return map_ ? map_->bytes() : 0; }
  size_t state_bytes() const override { return points_.bytes() + light_.bytes() + pixels_.bytes(); }

 private:
  EstimatorOptions options_;
  std::optional<PhotonMap> map_;
  uint32_t map_pass_ = 0;
  Buffer<VisiblePoint> points_;
  Buffer<Vec3f> light_;  // per pixel, emitted and direct light summed over the passes
  Buffer<SppmPixel> pixels_;
};

}  // namespace caustica
