// The variable kernels of a pass's stored photons (vkde_kernel.h): one per photon whose footprint
// is not degenerate, made from the footprints the tracer gives with differentials on.
#pragma once

#include <cstdint>

#include "renderer/photon/photon_tracer.h"
#include "renderer/photon/vkde_kernel.h"

namespace caustica {

struct VkdeKernels {
  Buffer<VkdeKernel> kernels;  // caustic photons' kernels first, each map in its photons' order
  double support_area = 0;     // sum of pi |M x m1|, the kernels' cuts through their centres
  uint32_t discarded = 0;      // photons with degenerate footprints
};

// The kernels of every stored photon of `photons` (traced with differentials), caustic and global.
VkdeKernels make_vkde_kernels(Backend& backend, const TracedPhotons& photons,
                              const VkdeSettings& settings);

}  // namespace caustica
