// parallel_for's kernel path (parallel_for.h includes this when nvcc compiles): one thread per
// element, the functor passed to the kernel by value, launched on the backend's stream.
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>

#include "renderer/parallel/backend.h"
#include "renderer/parallel/cuda/cuda_check.h"

namespace caustica {

// The stream all of a CUDA backend's work is ordered on. Throws DeviceError for other backends.
cudaStream_t cuda_stream(Backend& backend);

namespace detail {

constexpr unsigned kParallelForBlock = 256;

template <typename F>
__global__ void __launch_bounds__(kParallelForBlock) parallel_for_kernel(size_t n, F f) {
  const size_t i = size_t(blockIdx.x) * kParallelForBlock + threadIdx.x;
  if (i < n) f(i);
}

}  // namespace detail

template <typename F>
void launch_on_cuda(Backend& backend, size_t n, const F& f) {
  const size_t blocks = (n + detail::kParallelForBlock - 1) / detail::kParallelForBlock;
  if (blocks > 0x7fffffffu) throw DeviceError("parallel_for: too many elements for one launch");
  detail::
      parallel_for_kernel<<<unsigned(blocks), detail::kParallelForBlock, 0, cuda_stream(backend)>>>(
          n, f);
  CAUSTICA_CUDA_CHECK(cudaGetLastError());
}

}  // namespace caustica
