// The density kernels that weigh a photon by its distance in a radiance estimate: uniform, cone and
// Epanechnikov (Jensen 2001 sec. 7.2; Fabianowski 2011 sec. 5.3). Named DensityKernel in a code
// base where kernels also run on GPUs; the enum and its names are the scene's settings'
// (scene/setting_kinds.h).
#pragma once

#include <cmath>
#include <cstdint>

#include "renderer/base/hd.h"
#include "renderer/scene/setting_kinds.h"

namespace caustica {

// Kernel weight at normalised distance x = d / r in [0, 1], scaled so that it integrates to
// pi r^2 over the disk like the uniform kernel does.
CAUSTICA_HDI float kernel_weight(DensityKernel kernel, float x_squared) {
  switch (kernel) {
    case DensityKernel::kUniform:
      return 1.0f;
    case DensityKernel::kCone:  // Jensen's cone filter with k = 1: 1 - x, normalised by 1 / (1 -
                                // 2/3)
      return 3.0f * (1.0f - sqrtf(x_squared));
    case DensityKernel::kEpanechnikov:  // 1 - x^2, normalised by 2
      return 2.0f * (1.0f - x_squared);
  }
  return 1.0f;
}

}  // namespace caustica
