// Per-thread scratch memory handed to parallel_for_with_scratch's functor: `count` elements with
// element i at base[i * stride], so that on a GPU the threads of a block interleave their arrays
// in shared memory and each thread keeps to its own banks.
#pragma once

#include <cstddef>
#include <cstdint>

#include "renderer/base/hd.h"

namespace caustica {

template <typename T>
struct Scratch {
  T* base;
  uint32_t stride;
  // In 32 bits (i * stride < 2^32: scratch is small), which a GPU computes in one instruction.
  CAUSTICA_HDI T& operator[](uint32_t i) const { return base[i * stride]; }
};

}  // namespace caustica
