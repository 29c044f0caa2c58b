// parallel_for's kernel path (parallel_for.h includes this when nvcc compiles): one thread per
// element, the functor passed to the kernel by value, launched on the backend's stream.
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>

#include "renderer/parallel/backend.h"
#include "renderer/parallel/cuda/cuda_check.h"
#include "renderer/parallel/scratch.h"

namespace caustica {

// The stream all of a CUDA backend's work is ordered on. Throws DeviceError for other backends.
cudaStream_t cuda_stream(Backend& backend);

namespace detail {

// Threads per block. A block holds its multiprocessor slot until its slowest warp ends, and ray
// kernels' warps end at very different times: 128 beat 256 on incoherent rays and the render
// pass, and 64 lost primary rays (docs/performance.md, "Registers").
constexpr unsigned kParallelForBlock = 128;

// kMinBlocks: the blocks that must fit on a multiprocessor at once, which caps the registers per
// thread when more than 1. Named even when 1: with the block size alone, ptxas held kernels to
// fewer registers than they wanted (the render pass's specular walk to 96, spilling 80 bytes,
// where it takes 118; shadow rays to 53 where they take 64) and rays were 4 to 9% slower.
template <unsigned kMinBlocks, typename F>
__global__ void __launch_bounds__(kParallelForBlock, kMinBlocks)
    parallel_for_kernel(size_t n, F f) {
  const size_t i = size_t(blockIdx.x) * kParallelForBlock + threadIdx.x;
  if (i < n) f(i);
}

// One shared-memory array per block for parallel_for_with_scratch; element j of thread t's
// scratch is at j * blockDim.x + t, so that every thread keeps to its own banks. At most
// kMaxRegisters registers per thread.
template <unsigned kMaxRegisters, typename T, typename F>
__global__ void __maxnreg__(kMaxRegisters) scratch_kernel(size_t n, F f) {
  extern __shared__ __align__(16) unsigned char shared_scratch[];
  const size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) f(i, Scratch<T>{reinterpret_cast<T*>(shared_scratch) + threadIdx.x, blockDim.x});
}

// How a scratch kernel is launched: warps per block, and the share of each multiprocessor's
// unified L1 and shared memory (percent of the most it may give to shared memory) that its
// resident blocks need.
struct ScratchShape {
  unsigned warps = 0;
  int shared_percent = 100;
};

// The shape for `per_thread` bytes of scratch, with `block_warps` warps per block where it is not
// 0, else the warps per block that let the most warps share a multiprocessor, by the driver's
// occupancy for the kernel (its registers, the scratch and each block's reserved shared memory)
// under the largest shared-memory carveout; among those that tie, the one whose blocks need the
// least shared memory, then the fewest warps per block (a block holds its slot until its slowest
// warp ends). The carveout then asked for is just what those blocks need, and the rest of the
// memory stays L1, which caches the searches' nodes and photons. warps is 0 when the block's
// scratch is more than a block may have without opting in (48 KiB). Counting shared memory alone
// chose blocks of 8 warps for 128 bytes per thread, of which 86 registers per thread let 2 blocks,
// 16 warps, share a multiprocessor; blocks of 1 warp let 20.
template <typename Kernel>
ScratchShape scratch_shape(Kernel kernel, size_t per_thread, unsigned block_warps) {
  constexpr size_t kBlockBytes = 48 * 1024, kMaxWarps = 8;
  int device = 0, sm_shared = 0, reserved = 0;
  CAUSTICA_CUDA_CHECK(cudaGetDevice(&device));
  CAUSTICA_CUDA_CHECK(
      cudaDeviceGetAttribute(&sm_shared, cudaDevAttrMaxSharedMemoryPerMultiprocessor, device));
  CAUSTICA_CUDA_CHECK(
      cudaDeviceGetAttribute(&reserved, cudaDevAttrReservedSharedMemoryPerBlock, device));
  CAUSTICA_CUDA_CHECK(cudaFuncSetAttribute(kernel, cudaFuncAttributePreferredSharedMemoryCarveout,
                                           int(cudaSharedmemCarveoutMaxShared)));
  ScratchShape best;
  int best_resident = 0;
  size_t best_shared = 0;
  for (unsigned warps = 1; warps <= kMaxWarps && warps * 32 * per_thread <= kBlockBytes; ++warps) {
    if (block_warps != 0 && warps != block_warps) continue;
    int blocks = 0;
    CAUSTICA_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(
        &blocks, kernel, int(32 * warps), 32 * warps * per_thread));
    const int resident = blocks * int(warps);
    const size_t shared = size_t(blocks) * (32 * warps * per_thread + size_t(reserved));
    if (resident > best_resident || (resident == best_resident && shared < best_shared)) {
      best_resident = resident;
      best_shared = shared;
      best.warps = warps;
    }
  }
  if (best.warps != 0 && sm_shared > 0) {
    const size_t percent = (best_shared * 100 + size_t(sm_shared) - 1) / size_t(sm_shared);
    best.shared_percent = int(percent < 100 ? percent : 100);
  }
  return best;
}

}  // namespace detail

// Returns false, launching nothing, when a block's scratch does not fit in its shared memory.
template <typename T, unsigned kMaxRegisters, unsigned kBlockWarps, typename F>
bool launch_with_scratch_on_cuda(Backend& backend, size_t n, uint32_t scratch_count, const F& f) {
  const size_t per_thread = size_t(scratch_count) * sizeof(T);
  // The shape is asked of the driver once per kernel and scratch size, not at every launch (the
  // gather launches once a pass with the same k). The carveout is the kernel's, shared by every
  // thread of the process, so it is set again at each launch: another thread may have launched the
  // same kernel with scratch of another size since.
  auto* kernel = detail::scratch_kernel<kMaxRegisters, T, F>;
  static thread_local size_t cached_per_thread = ~size_t(0);
  static thread_local detail::ScratchShape shape;
  if (per_thread != cached_per_thread) {
    shape = detail::scratch_shape(kernel, per_thread, kBlockWarps);
    cached_per_thread = per_thread;
  }
  const unsigned warps = shape.warps;
  if (warps == 0) return false;
  CAUSTICA_CUDA_CHECK(cudaFuncSetAttribute(kernel, cudaFuncAttributePreferredSharedMemoryCarveout,
                                           shape.shared_percent));
  const unsigned block = 32 * warps;
  const size_t blocks = (n + block - 1) / block;
  if (blocks > 0x7fffffffu) throw DeviceError("parallel_for: too many elements for one launch");
  detail::scratch_kernel<kMaxRegisters, T>
      <<<unsigned(blocks), block, block * per_thread, cuda_stream(backend)>>>(n, f);
  CAUSTICA_CUDA_CHECK(cudaGetLastError());
  return true;
}

template <unsigned kResidentThreads, typename F>
void launch_on_cuda(Backend& backend, size_t n, const F& f) {
  constexpr unsigned kMinBlocks = kResidentThreads > detail::kParallelForBlock
                                      ? kResidentThreads / detail::kParallelForBlock
                                      : 1;
  const size_t blocks = (n + detail::kParallelForBlock - 1) / detail::kParallelForBlock;
  if (blocks > 0x7fffffffu) throw DeviceError("parallel_for: too many elements for one launch");
  detail::parallel_for_kernel<kMinBlocks>
      <<<unsigned(blocks), detail::kParallelForBlock, 0, cuda_stream(backend)>>>(n, f);
  CAUSTICA_CUDA_CHECK(cudaGetLastError());
}

}  // namespace caustica
