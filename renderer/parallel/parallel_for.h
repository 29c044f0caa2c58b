// parallel_for(backend, name, n, f): runs f(i) for i in [0, n) on the backend's device. `f` is a
// CAUSTICA_HD lambda or functor capturing only values and backend pointers, so one body serves
// both backends. `name`, a snake_case string literal saying what the launch does, is what the
// backend's launch timing (Backend::set_launch_timing) files its time under. Under a host compiler
// only the CPU path exists; translation units that must also launch on CUDA are compiled by nvcc,
// which adds the kernel path (cuda/launch.cuh).
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstddef>
#include <vector>

#include "renderer/parallel/backend.h"
#include "renderer/parallel/scratch.h"

#if defined(__CUDACC__)
#include "renderer/parallel/cuda/launch.cuh"
#endif

namespace caustica {

namespace detail {

template <unsigned kResidentThreads, typename F>
void run_parallel_for(Backend& backend, size_t n, F& f) {
  if (backend.kind() == DeviceKind::kCuda) {
#if defined(__CUDACC__)
    launch_on_cuda<kResidentThreads>(backend, n, f);
    return;
#else
    // The loop below would dereference device pointers on the host.
    throw DeviceError("parallel_for on the CUDA backend from code not compiled by nvcc");
#endif
  }
  // Grain 256 keeps scheduling overhead small next to the per-element work (rays, photons).
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 256),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i != r.end(); ++i) f(i);
                    });
}

template <typename T, unsigned kMaxRegisters, unsigned kBlockWarps, typename F>
bool run_parallel_for_with_scratch(Backend& backend, size_t n, uint32_t scratch_count, F& f) {
  if (backend.kind() == DeviceKind::kCuda) {
#if defined(__CUDACC__)
    return launch_with_scratch_on_cuda<T, kMaxRegisters, kBlockWarps>(backend, n, scratch_count, f);
#else
    throw DeviceError("parallel_for on the CUDA backend from code not compiled by nvcc");
#endif
  }
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 256),
                    [&](const tbb::blocked_range<size_t>& r) {
                      std::vector<T> scratch(scratch_count);
                      for (size_t i = r.begin(); i != r.end(); ++i)
                        f(i, Scratch<T>{scratch.data(), 1});
                    });
  return true;
}

}  // namespace detail

// kResidentThreads: on a GPU, the threads that must fit on a multiprocessor at once (0: one
// block); more than a block caps the kernel's registers (launch.cuh).
template <unsigned kResidentThreads = 0, typename F>
void parallel_for(Backend& backend, const char* name, size_t n, F f) {
  if (n == 0) return;
  // Written out rather than through Backend::timed_launch: no host lambda around the launch of
  // an extended device lambda, and one branch when timing is off.
  if (backend.launch_timing()) [[unlikely]] {
    const uint64_t mark = backend.launch_began(name);
    detail::run_parallel_for<kResidentThreads>(backend, n, f);
    backend.launch_ended(name, mark);
    return;
  }
  detail::run_parallel_for<kResidentThreads>(backend, n, f);
}

// parallel_for with `scratch_count` elements of T of per-thread scratch: runs f(i, Scratch<T>).
// On a GPU the scratch is in shared memory; an array private to the thread would be in local
// memory, which is cached in L1 and L2 and, for the gather's neighbour heaps, was 100 GB of L2
// traffic a frame. On the CPU each task reuses one buffer. Returns false, running nothing, when
// the GPU's shared memory cannot hold one block's scratch; the caller then falls back to
// parallel_for with a private array. kMaxRegisters caps the GPU kernel's registers per thread
// (255, the most a thread may have, leaves the choice to the compiler); kBlockWarps fixes the
// warps per GPU block (0: those that let the most warps share a multiprocessor, launch.cuh).
template <typename T, unsigned kMaxRegisters = 255, unsigned kBlockWarps = 0, typename F>
bool parallel_for_with_scratch(Backend& backend, const char* name, size_t n, uint32_t scratch_count,
                               F f) {
  if (n == 0) return true;
  if (backend.launch_timing()) [[unlikely]] {
    const uint64_t mark = backend.launch_began(name);
    const bool launched = detail::run_parallel_for_with_scratch<T, kMaxRegisters, kBlockWarps>(
        backend, n, scratch_count, f);
    backend.launch_ended(name, mark, launched);
    return launched;
  }
  return detail::run_parallel_for_with_scratch<T, kMaxRegisters, kBlockWarps>(backend, n,
                                                                              scratch_count, f);
}

}  // namespace caustica
