// Bit counts on 32-bit words, one instruction on either backend.
#pragma once

#include <cstdint>

#include "renderer/base/hd.h"

namespace caustica {

CAUSTICA_HDI uint32_t popcount32(uint32_t x) {
#if defined(__CUDA_ARCH__)
  return uint32_t(__popc(x));
#else
  return uint32_t(__builtin_popcount(x));
#endif
}

// The index of the highest set bit of x, which must not be 0.
CAUSTICA_HDI uint32_t highest_bit32(uint32_t x) {
#if defined(__CUDA_ARCH__)
  return 31u - uint32_t(__clz(x));
#else
  return 31u - uint32_t(__builtin_clz(x));
#endif
}

// The index of the lowest set bit of x, which must not be 0.
CAUSTICA_HDI uint32_t lowest_bit32(uint32_t x) {
#if defined(__CUDA_ARCH__)
  return uint32_t(__ffs(x)) - 1u;
#else
  return uint32_t(__builtin_ctz(x));
#endif
}

}  // namespace caustica
