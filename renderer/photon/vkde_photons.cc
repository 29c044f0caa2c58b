#include "renderer/photon/vkde_photons.h"

#include <stdexcept>

#include "renderer/parallel/parallel_for.h"
#include "renderer/photon/differentials.h"

namespace caustica {

VkdeKernels make_vkde_kernels(Backend& backend, const TracedPhotons& photons,
                              const VkdeSettings& settings) {
  VkdeKernels out{Buffer<VkdeKernel>(backend, 0)};
  const uint32_t caustic = uint32_t(photons.caustic.size());
  const uint32_t n = caustic + uint32_t(photons.global.size());
  if (photons.caustic_footprints.size() != photons.caustic.size() ||
      photons.global_footprints.size() != photons.global.size()) {
    throw std::invalid_argument("make_vkde_kernels: photons traced without differentials");
  }
  if (n == 0) return out;
  const float spacing = differential_spacing(float(photons.emitted));
  const Photon* caustic_photon = photons.caustic.data();
  const Photon* global_photon = photons.global.data();
  const PhotonFootprint* caustic_footprint = photons.caustic_footprints.data();
  const PhotonFootprint* global_footprint = photons.global_footprints.data();
  Buffer<VkdeKernel> made(backend, n);
  Buffer<uint32_t> kept(backend, n);
  Buffer<float> areas(backend, n);
  VkdeKernel* kernel = made.data();
  uint32_t* keep = kept.data();
  float* area = areas.data();
  parallel_for(backend, "vkde_kernels", n, [=] CAUSTICA_HD(size_t i) {
    const bool is_caustic = i < caustic;
    const Photon& photon = is_caustic ? caustic_photon[i] : global_photon[i - caustic];
    const PhotonFootprint& footprint =
        is_caustic ? caustic_footprint[i] : global_footprint[i - caustic];
    // The footprint lies in the surface's plane; its normal faces where the photon came from.
    Vec3f normal = cross(footprint.span1, footprint.span2);
    if (dot(normal, photon.incoming) < 0.0f) normal = -normal;
    const float normal_length = length(normal);
    VkdeKernel k{};
    const bool ok = normal_length > 0.0f &&
                    vkde_kernel(photon, footprint, normal / normal_length, spacing, settings, k);
    kernel[i] = k;
    keep[i] = ok ? 1u : 0u;
    area[i] = ok ? kPi * length(cross(k.major, k.minor)) : 0.0f;
  });
  out.support_area = backend.reduce_sum(area, n);
  Buffer<uint32_t> slots(backend, n);
  uint32_t* slot = slots.data();
  const uint32_t total = backend.exclusive_scan(keep, slot, n);
  out.discarded = n - total;
  out.kernels.resize_discard(total);
  VkdeKernel* kept_kernel = out.kernels.data();
  parallel_for(backend, "vkde_kernels_kept", n, [=] CAUSTICA_HD(size_t i) {
    if (keep[i] != 0) kept_kernel[slot[i]] = kernel[i];
  });
  return out;
}

}  // namespace caustica
