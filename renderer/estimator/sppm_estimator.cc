#include "renderer/estimator/sppm_estimator.h"

#include <algorithm>

#include "renderer/render/visible_points.h"

namespace caustica {

SppmEstimator::SppmEstimator(Backend& backend, const EstimatorOptions& options)
    : options_(options), points_(backend, 0), light_(backend, 0), pixels_(backend, 0) {}

void SppmEstimator::prepare(Backend& backend, const ResidentScene&, const TracedPhotons& photons,
                            uint32_t pass) {
  map_.reset();
  // Every stored photon in one map: the visible points gather caustic and global light alike.
  Buffer<Photon> all(backend, photons.caustic.size() + photons.global.size());
  if (!photons.caustic.empty())
    backend.copy_on_device(all.data(), photons.caustic.data(), photons.caustic.bytes());
  if (!photons.global.empty())
    backend.copy_on_device(all.data() + photons.caustic.size(), photons.global.data(),
                           photons.global.bytes());
  const uint32_t per_leaf =
      options_.photons_per_leaf != 0 ? options_.photons_per_leaf : kDefaultPhotonsPerLeaf;
  map_ = build_photon_map(backend, all, per_leaf);
  map_pass_ = pass;
}

void SppmEstimator::render(Backend& backend, const ResidentScene& scene,
                           const PinholeCamera& camera, const ShadingSettings& shading,
                           Film& film) {
  const size_t pixels = size_t(camera.width) * camera.height;
  if (pixels_.size() != pixels) {  // a new resolution, so a new film at its first pass
    points_.resize_discard(pixels);
    light_.resize_discard(pixels);
    pixels_.resize_discard(pixels);
  }
  if (film.passes() == 0) {  // the statistics start again with the film
    light_.fill_zero();
    pixels_.fill_zero();
  }
  trace_visible_points(backend, scene, camera,
                       {shading.max_depth, shading.area_light_samples, shading.seed, shading.pass,
                        shading.ray_queues, shading.near_specular_alpha},
                       points_.data(), light_.data());
  SppmGather gather;
  gather.alpha = options_.sppm_alpha;
  gather.rule = options_.sppm_radius;
  gather.initial_nearest = options_.k_nearest;
  gather.max_radius = shading.max_radius;
  gather.global_shrink = float(sppm_global_shrink(film.passes() + 1, options_.sppm_alpha));
  sppm_gather(backend, map_->view(), points_.data(), light_.data(), pixels_.data(),
              film.accumulator(), PixelBlocks(camera.width, camera.height), gather);
  film.add_pass();
  map_.reset();
}

}  // namespace caustica
