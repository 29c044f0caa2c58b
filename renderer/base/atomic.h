// Atomics for single-source kernels: CUDA's intrinsics on the device, std::atomic_ref on the host.
#pragma once

#include <cstdint>
#include <cstring>

#include "renderer/base/hd.h"

#if defined(__CUDACC__)
#include <cuda/atomic>
#endif
#include <atomic>

namespace caustica {

// Stores `v` in `*p` and returns the old value, with acquire-release ordering: a thread that sees
// another's store also sees that thread's earlier writes (bottom-up tree builds rely on it).
CAUSTICA_HDI uint32_t atomic_exchange(uint32_t* p, uint32_t v) {
#if defined(__CUDA_ARCH__)
  // One acquire-release exchange at device scope: half the cost of a plain exchange between two
  // full fences, which the LBVH build paid at every level it climbed.
  return cuda::atomic_ref<uint32_t, cuda::thread_scope_device>(*p).exchange(
      v, cuda::memory_order_acq_rel);
#else
  return std::atomic_ref<uint32_t>(*p).exchange(v, std::memory_order_acq_rel);
#endif
}

// Adds `v` to `*p` and returns the old value; relaxed, for counters that hand out work.
CAUSTICA_HDI uint32_t atomic_fetch_add(uint32_t* p, uint32_t v) {
#if defined(__CUDA_ARCH__)
  return atomicAdd(p, v);
#else
  return std::atomic_ref<uint32_t>(*p).fetch_add(v, std::memory_order_relaxed);
#endif
}

// Lowers `*p` to `v` when `v` is smaller, and raises it when larger; relaxed, for reductions
// whose result is read only after the launch that made them.
#if !defined(__CUDA_ARCH__)
namespace detail {
// Stores `v` in `*p` while `replaces(v, old)` holds for the value there.
template <typename Replaces>
inline void store_while(uint32_t* p, uint32_t v, Replaces replaces) {
  std::atomic_ref<uint32_t> a(*p);
  uint32_t old = a.load(std::memory_order_relaxed);
  while (replaces(v, old) && !a.compare_exchange_weak(old, v, std::memory_order_relaxed)) {
  }
}
}  // namespace detail
#endif

CAUSTICA_HDI void atomic_min(uint32_t* p, uint32_t v) {
#if defined(__CUDA_ARCH__)
  atomicMin(p, v);
#else
  detail::store_while(p, v, [](uint32_t a, uint32_t b) { return a < b; });
#endif
}

CAUSTICA_HDI void atomic_max(uint32_t* p, uint32_t v) {
#if defined(__CUDA_ARCH__)
  atomicMax(p, v);
#else
  detail::store_while(p, v, [](uint32_t a, uint32_t b) { return a > b; });
#endif
}

// A float's bits mapped to an unsigned integer of the same order (every float but NaN), so that
// integer atomics take minima and maxima of floats.
CAUSTICA_HDI uint32_t ordered_bits(float f) {
  uint32_t bits;
  memcpy(&bits, &f, sizeof bits);
  return bits ^ ((bits >> 31) != 0 ? 0xffffffffu : 0x80000000u);
}

CAUSTICA_HDI float from_ordered_bits(uint32_t ordered) {
  const uint32_t bits = ordered ^ ((ordered >> 31) != 0 ? 0x80000000u : 0xffffffffu);
  float f;
  memcpy(&f, &bits, sizeof f);
  return f;
}

}  // namespace caustica
