// Atomics for single-source kernels: CUDA's intrinsics on the device, std::atomic_ref on the host.
#pragma once

#include <cstdint>

#include "renderer/base/hd.h"

#if !defined(__CUDA_ARCH__)
#include <atomic>
#endif

namespace caustica {

// Stores `v` in `*p` and returns the old value, with acquire-release ordering: a thread that sees
// another's store also sees that thread's earlier writes (bottom-up tree builds rely on it).
CAUSTICA_HDI uint32_t atomic_exchange(uint32_t* p, uint32_t v) {
#if defined(__CUDA_ARCH__)
  __threadfence();
  uint32_t old = atomicExch(p, v);
  __threadfence();
  return old;
#else
  return std::atomic_ref<uint32_t>(*p).exchange(v, std::memory_order_acq_rel);
#endif
}

}  // namespace caustica
