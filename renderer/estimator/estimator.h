// The seam where density estimators vary (settings.estimator), in the shape of pbrt-v4's
// CreateAccelerator: a small interface, one implementation per EstimatorKind, chosen at run time
// by make_estimator. Each estimator owns what differs between them:
// - its photon maps: which photons go in which map, and the maps' leaf policy;
// - the state that lives across passes, started again whenever it renders a film's first pass
//   (every change the epochs count clears the film);
// - its gather stage and how a pass reaches the film.
// Photon tracing is common to all of them; the engine traces each pass's photons and hands them
// to prepare(). Dispatch is once per pass on the host: inside a pass every launch is one
// estimator's own.
#pragma once

#include <cstdint>
#include <memory>

#include "renderer/parallel/backend.h"
#include "renderer/photon/photon_tracer.h"
#include "renderer/render/camera.h"
#include "renderer/render/film.h"
#include "renderer/render/whitted.h"
#include "renderer/resident/resident_scene.h"
#include "renderer/scene/setting_kinds.h"

namespace caustica {

struct EstimatorOptions {
  EstimatorKind kind = EstimatorKind::kKnn;
  uint32_t k_nearest = 64;
  // Photons per leaf of the maps' hierarchy, a tuning knob; 0 takes the estimator's own choice.
  uint32_t photons_per_leaf = 0;
  float sppm_alpha = 0.7f;
  SppmRadius sppm_radius = SppmRadius::kPixel;
  // VKDE's spread factor s; 0 takes sqrt(k_nearest / (2 pi)), whose kernels each cover about
  // k_nearest / 2 of their photons' footprints.
  float vkde_spread = 0.0f;
  // knn: the indirect light by final gathering (final_gather.h), with this many rays per seed.
  bool final_gather = false;
  uint32_t final_gather_rays = 256;
  uint32_t final_gather_seeds = 0;  // 0: the default (final_gather.h)

  // Every option compared, so that a new one cannot be left out of the engine's test of whether
  // a settings change needs a new estimator.
  bool operator==(const EstimatorOptions&) const = default;
};

class Estimator {
 public:
  virtual ~Estimator() = default;

  // Whether its photons must be traced with differentials (PhotonTraceSettings::differentials).
  virtual bool needs_differentials() const { return false; }
  // Builds the photon maps for pass `pass` from its photons, traced in `scene`, replacing any
  // built before.
  virtual void prepare(Backend& backend, const ResidentScene& scene, const TracedPhotons& photons,
                       uint32_t pass) = 0;
  // Whether maps are ready for pass `pass`.
  virtual bool prepared_for(uint32_t pass) const = 0;
  // Frees the maps prepared.
  virtual void drop_maps() = 0;
  // Adds pass `shading.pass` to the film (whose passes() it is) from the maps prepared for it,
  // which it then frees.
  virtual void render(Backend& backend, const ResidentScene& scene, const PinholeCamera& camera,
                      const ShadingSettings& shading, Film& film) = 0;
  virtual size_t map_bytes() const = 0;    // the maps prepared
  virtual size_t state_bytes() const = 0;  // what lives across passes
};

std::unique_ptr<Estimator> make_estimator(Backend& backend, const EstimatorOptions& options);

}  // namespace caustica
