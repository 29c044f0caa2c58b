#include "renderer/estimator/vkde_estimator.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "renderer/estimator/knn_gather.h"
#include "renderer/parallel/parallel_for.h"
#include "renderer/photon/vkde_photons.h"

namespace caustica {
namespace {

// The least cosine between a kernel's normal and a query's for the kernel to count: back faces
// (-1) never do, but the walls of a corner (0, or a little below where they are not quite square)
// do, as the k nearest photons of a corner come from both walls. A support that reaches past a
// corner loses flux on its own wall and lends as much to the other (vkde_thickness_squared);
// without the loan, corners were 10% too dark (docs/convergence.md, "VKDE").
constexpr float kVkdeFacing = -0.25f;

}  // namespace

VkdeSettings vkde_settings(const EstimatorOptions& options, float scene_radius) {
  VkdeSettings s;
  s.spread = options.vkde_spread > 0.0f ? options.vkde_spread
                                        : std::sqrt(float(options.k_nearest) / (2.0f * kPi));
  s.pivot = scene_radius;
  s.max_axis = scene_radius / 8.0f;
  return s;
}

VolumeKernelSettings volume_kernel_settings(float scene_radius, const Aabb& scene_bounds,
                                            uint32_t photons) {
  VolumeKernelSettings s;
  s.spread = std::cbrt(3.0f * float(kVolumeNearest) / (4.0f * kPi));
  s.pivot = kVolumePivotScale * scene_radius;
  s.max_bandwidth = volume_bandwidth_cap(scene_bounds);
  s.photons = photons;
  return s;
}

void VkdeGather::gather(Backend& backend, const GatherRequests& requests,
                        const ShadingSettings& settings, Vec3f* gathered) const {
  const KernelMapView map = map_.view();
  const GatherRequests r = requests;
  const DensityKernel profile = settings.kernel;
  parallel_for(backend, "gather_vkde", r.count, [=] CAUSTICA_HD(size_t t) {
    const GatherRequest q = r.requests[r.by_code[t]];
    Vec3f sum(0.0f);
    visit_kernels_at(map, q.position, [&](uint32_t, const VkdeKernel& k) {
      const float d2 = vkde_distance_squared(k, q.position);
      // The kernel's normal, M x m1, faces the side its photon arrived from.
      const Vec3f g = cross(k.major, k.minor);
      if (d2 < 1.0f && dot(g, q.normal) > kVkdeFacing * length(g))
        sum += k.flux * kernel_weight(profile, d2);
    });
    // Flux over pi |M x m1| is irradiance; times the weight (throughput and albedo) over pi.
    gathered[r.pixel_offsets[q.pixel] + q.order] = q.weight * sum * (kInvPi * kInvPi);
  });
}

void VkdeEstimator::prepare(Backend& backend, const ResidentScene& scene,
                            const TracedPhotons& photons, uint32_t pass) {
  map_.reset();  // frees the old maps before the new ones are allocated
  volume_.reset();
  const VkdeSettings settings = vkde_settings(options_, scene.radius());
  const VkdeKernels made = make_vkde_kernels(backend, photons, settings);
  // Fabianowski's n_auto unless the leaf size is set (a benchmark's knob).
  const uint32_t leaf_size =
      options_.photons_per_leaf != 0
          ? options_.photons_per_leaf
          : kernel_leaf_size(made.support_area, scene.surface_area(), kVkdeLeafScale);
  map_ = build_kernel_map(backend, made.kernels, leaf_size);
  // The collisions' leaves as the knn estimator's (the leaf-size knob is the kernels').
  const uint32_t per_leaf = photons_per_leaf_for(backend.kind(), options_.k_nearest);
  volume_ = build_volume_map(
      backend, photons.volume, photons.volume_footprints, per_leaf,
      volume_kernel_settings(scene.radius(), scene.bounds(), std::max(photons.emitted, 1u)));
  map_pass_ = pass;
}

void VkdeEstimator::render(Backend& backend, const ResidentScene& scene,
                           const PinholeCamera& camera, const ShadingSettings& shading,
                           Film& film) {
  const std::optional<KernelMap> map = std::move(map_);
  const std::optional<VolumeMap> volume = std::move(volume_);
  map_.reset();
  volume_.reset();
  ShadingSettings with_volume = shading;
  with_volume.volume = volume->view();
  render_pass(backend, scene, camera, with_volume, VkdeGather(*map), film);
}

}  // namespace caustica
