#include "renderer/estimator/knn_gather.h"

#include <type_traits>

#include "renderer/parallel/parallel_for.h"
#include "renderer/photon/binned_estimate.h"
#include "renderer/photon/knn_estimate.h"

namespace caustica {
namespace {

// Requests per CPU thread, each bounding the next one's search radius (knn_estimate.h),
// which is faster on the CPU. On a GPU the same chains cost more than they save: a warp that
// searches as a group already shares its nodes (docs/performance.md).
constexpr uint32_t kGatherChain = 8;

// From this k on, a GPU's estimates count (binned_estimate.h) instead of keeping heaps: below it
// two walks cost more than small heaps. On the CPU, where a thread searches alone, counting is
// slower at every k (docs/performance.md has the render pass's figures).
constexpr uint32_t kBinnedFromK = 64;
constexpr bool gathers_count(DeviceKind device, uint32_t k) {
  return device == DeviceKind::kCuda && k >= kBinnedFromK;
}
// Registers per thread for the GPU gathers: fewer let more warps share a multiprocessor, which
// hides the latency the searches wait on, until spilling costs more. A scheduler's 16384
// registers hold 4 warps of the counting gather at its own 106 and 5 at 96, which spills little;
// the heap gather gains a warp at 72. Both limits were chosen by measurement (docs/performance.md,
// "Registers").
constexpr unsigned kCountingGatherRegisters = 96;
constexpr unsigned kHeapGatherRegisters = 72;
// Warps per block for the counting gather. Its 20 resident warps take 9 KiB of scratch each, and
// the shared memory not asked for is L1, where the searches' nodes and photons hit (launch.cuh):
// in blocks of 1 warp they needed the largest carveout, in blocks of 2 the next one, with 60 KiB
// more L1. Blocks of 4 and 5 warps, which fit the same carveout, were no faster (a block holds
// its slot until its slowest warp ends), and fewer resident warps with a smaller carveout lost
// (docs/performance.md, "L1 for the gather"). launch.cuh's own choice among shapes that keep 20
// warps, the least shared memory, would take blocks of 5.
constexpr unsigned kCountingGatherBlockWarps = 2;

// The caustic and global estimates of the requests in Hilbert order. A group
// of `lanes` threads (a GPU warp; one thread on the CPU) takes lanes x chain consecutive
// requests, `lanes` at a time, and searches each batch together; each thread carries its
// previous request's two radii as bounds for its next one. kBinned: each estimate by counting
// (binned_estimate.h) in kBinnedWords words of scratch, else with a heap of NeighbourPairs.
template <bool kBinned>
struct GatherEstimates {
  PhotonMapView caustics, global;
  const GatherRequest* requests;
  const uint32_t* by_code;
  const uint32_t* pixel_offsets;  // where each pixel's estimates start in `gathered`
  Vec3f* gathered;                // in pixel order, then path order
  uint32_t request_count;
  uint32_t lanes;  // 32 on a GPU, 1 on the CPU
  uint32_t chain;  // requests per thread
  uint32_t k;
  float max_radius;
  DensityKernel kernel;

  static size_t threads(uint32_t request_count, uint32_t lanes, uint32_t chain) {
    const size_t per_group = size_t(lanes) * chain;
    return (request_count + per_group - 1) / per_group * lanes;
  }

  template <typename Scratch>
  CAUSTICA_HDI RadianceEstimate estimate(const PhotonMapView& map, const GatherRequest& q,
                                         float bound, Scratch scratch, SearchGroup group) const {
    if constexpr (kBinned) {
      return estimate_radiance_binned(map, q.position, q.normal, q.weight, k, max_radius, kernel,
                                      scratch, bound, group);
    } else {
      return estimate_radiance_within(map, q.position, q.normal, q.weight, k, max_radius, kernel,
                                      scratch, bound, group);
    }
  }

  template <typename Scratch>
  CAUSTICA_HDI void operator()(size_t thread, Scratch scratch) const {
    const uint32_t lane = uint32_t(thread % lanes);
    const size_t group_first = (thread - lane) * chain;
    // An infinite radius carries no bound to the first request.
    RadianceEstimate caustic{Vec3f(0.0f), INFINITY}, indirect{Vec3f(0.0f), INFINITY};
    Vec3f previous(0.0f);
    for (uint32_t step = 0; step < chain; ++step) {
      const size_t batch = group_first + size_t(step) * lanes;
      if (batch + lane >= request_count) return;
      const GatherRequest q = requests[by_code[batch + lane]];
      const size_t in_batch = request_count - batch < lanes ? request_count - batch : lanes;
      const SearchGroup group{lanes == 1 ? 0u : uint32_t((uint64_t(1) << in_batch) - 1)};
      const float caustic_bound =
          carried_radius_squared(caustic.radius_squared, previous, q.position);
      const float indirect_bound =
          carried_radius_squared(indirect.radius_squared, previous, q.position);
      caustic = estimate(caustics, q, caustic_bound, scratch, group);
      indirect = estimate(global, q, indirect_bound, scratch, group);
      gathered[pixel_offsets[q.pixel] + q.order] = caustic.radiance + indirect.radiance;
      previous = q.position;
    }
  }
};

// Both photon-map estimates per request, stored in pixel and path order. A GPU warp's
// requests are Hilbert neighbours, so its lanes search together. On a GPU from k = 64 on, each
// estimate counts in 288 bytes of per-thread scratch at any k; otherwise a neighbour heap lives
// in fast per-thread scratch where it fits (k up to 192 on a GPU), else in a private array.
}  // namespace

// Leaves of 16 photons for counting, whose walks file a leaf's photons in batches of 8; heaps keep
// smaller leaves, which measured faster for them (docs/performance.md).
uint32_t photons_per_leaf_for(DeviceKind device, uint32_t k, uint32_t requested) {
  if (requested != 0) return requested;
  return gathers_count(device, k) ? 16u : 8u;
}

void KnnGather::gather(Backend& backend, const GatherRequests& requests, const ShadingSettings& cfg,
                       Vec3f* gathered) const {
  const uint32_t k = cfg.k_nearest < kMaxNearest ? cfg.k_nearest : kMaxNearest;
  const bool gpu = backend.kind() == DeviceKind::kCuda;
  const uint32_t lanes = gpu ? 32 : 1;
  const uint32_t chain = gpu ? 1 : kGatherChain;
  const size_t threads = GatherEstimates<false>::threads(requests.count, lanes, chain);
  auto gather_with = [&](auto binned) {
    return GatherEstimates<decltype(binned)::value>{caustic_.view(),
                                                    global_.view(),
                                                    requests.requests,
                                                    requests.by_code,
                                                    requests.pixel_offsets,
                                                    gathered,
                                                    requests.count,
                                                    lanes,
                                                    chain,
                                                    k,
                                                    cfg.max_radius,
                                                    cfg.kernel};
  };
  if (gathers_count(backend.kind(), k)) {
    if (!parallel_for_with_scratch<uint32_t, kCountingGatherRegisters, kCountingGatherBlockWarps>(
            backend, "gather_counting", threads, kBinnedWords, gather_with(std::true_type{}))) {
      throw DeviceError("knn gather: no room for the gather's scratch");
    }
  } else {
    const auto gather = gather_with(std::false_type{});
    const uint32_t heap_pairs = NeighbourHeap<NeighbourPair*>::pairs_for(k);
    if (!parallel_for_with_scratch<NeighbourPair, kHeapGatherRegisters>(
            backend, "gather_heaps", threads, heap_pairs, gather)) {
      parallel_for(backend, "gather_heaps_private", threads, [=] CAUSTICA_HD(size_t thread) {
        NeighbourPair heap[NeighbourHeap<NeighbourPair*>::pairs_for(kMaxNearest)];
        gather(thread, heap);
      });
    }
  }
}

}  // namespace caustica
