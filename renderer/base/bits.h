// Bit tricks with one spelling for both backends.
#pragma once

#include <cstdint>

#include "renderer/base/hd.h"

namespace caustica {

// Count of leading zero bits; 32 for v == 0.
CAUSTICA_HDI int count_leading_zeros(uint32_t v) {
#if defined(__CUDA_ARCH__)
  return __clz(v);
#else
  return v == 0 ? 32 : __builtin_clz(v);
#endif
}

}  // namespace caustica
