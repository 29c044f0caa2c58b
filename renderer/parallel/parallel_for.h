// parallel_for(backend, n, f): runs f(i) for i in [0, n) on the backend's device. `f` is a
// CAUSTICA_HD lambda or functor capturing only values and backend pointers, so one body serves
// both backends. Under a host compiler only the CPU path exists; translation units that must also
// launch on CUDA are compiled by nvcc, which adds the kernel path (cuda/launch.cuh).
#pragma once

#include <cstddef>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "renderer/parallel/backend.h"

#if defined(__CUDACC__)
#include "renderer/parallel/cuda/launch.cuh"
#endif

namespace caustica {

template <typename F>
void parallel_for(Backend& backend, size_t n, F f) {
  if (n == 0) return;
  if (backend.kind() == DeviceKind::kCuda) {
#if defined(__CUDACC__)
    launch_on_cuda(backend, n, f);
    return;
#else
    // The loop below would dereference device pointers on the host.
    throw DeviceError("parallel_for on the CUDA backend from code not compiled by nvcc");
#endif
  }
  // Grain 256 keeps scheduling overhead small next to the per-element work (rays, photons).
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 256), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) f(i);
  });
}

}  // namespace caustica
