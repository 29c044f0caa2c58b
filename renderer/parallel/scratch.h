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
  uint32_t stride_bytes;  // between element i and i + 1
  CAUSTICA_HDI Scratch(T* first, uint32_t stride) : base(first), stride_bytes(stride * sizeof(T)) {}
  // The offset in bytes in 32 bits (scratch is small), so that a GPU forms the address in one
  // multiply-add where an element stride took two (docs/performance.md has the render pass's
  // figures).
  CAUSTICA_HDI T& operator[](uint32_t i) const {
    return *reinterpret_cast<T*>(reinterpret_cast<char*>(base) + i * stride_bytes);
  }
};

}  // namespace caustica
