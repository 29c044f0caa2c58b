// The radiance estimate of knn_estimate.h (the same k nearest photons, the same k-th distance) found
// by counting instead of with a heap, for GPU searches in groups at larger k.
//
// A heap search spends most of its instructions keeping its heap: at k = 64 on a GPU, about half
// of the gather's instructions are heap insertions and the climbs that fill the heap, each a
// chain of dependent shared-memory steps that a warp runs for whichever of its lanes has one.
// Here:
// 1. A counting walk files every photon nearer than the limit under a bin of its squared
//    distance (the float's exponent and top three mantissa bits: eight bins per octave). The bin
//    where the count reaches k is the cut; once the bins below it hold k, the cut moves down a bin
//    and the limit with it, so the walk prunes almost as a heap search does. A batch of eight
//    photons is filed without a branch, and the cut lowered once after.
// 2. A collecting walk with the cut's top as a fixed limit sums the flux of the photons below the
//    cut (all among the k nearest) and keeps those in it, about 6 at k = 64, to take the nearest
//    of them that make k. A warp replays the leaves its first counting walk recorded instead of
//    walking the tree again. Should the cut hold more photons than fit, the counting is repeated
//    within it with finer bins first.
// A lane's scratch is 288 bytes at any k (the heap's is 512 at k = 64, 1 KiB at k = 128).
// Counting wins from k = 64 up on a GPU; below, two walks cost more than small heaps
// (kBinnedFromK, whitted.cc), and on the CPU, where a thread searches alone, counting is slower
// at every k (docs/performance.md has the render pass's figures).
#pragma once

#include "renderer/photon/knn_estimate.h"

namespace caustica {

// A lane's words: the counting walk's bins, a word each, which the collecting walk reuses for the
// cut's photons (distance and index, two words each); after them, the leaves of the first
// counting walk (WarpLeafLog).
constexpr uint32_t kDistanceBins = 64;
constexpr uint32_t kBinWords = kDistanceBins;
constexpr uint32_t kCutCapacity = kBinWords / 2;
constexpr uint32_t kLeafLogWords = 8;
constexpr uint32_t kBinnedWords = kBinWords + kLeafLogWords;

CAUSTICA_HDI uint32_t float_bits(float f) { return __builtin_bit_cast(uint32_t, f); }
CAUSTICA_HDI float bits_float(uint32_t u) { return __builtin_bit_cast(float, u); }

// Bins of non-negative squared distances: bin b holds those whose float bits shifted right by
// `shift` equal base + b, and bin 0 every smaller one as well. The order of the float bits is
// that of the values, so bins are intervals in increasing order.
struct DistanceBins {
  uint32_t shift;
  uint32_t base;
  uint32_t last;  // the bin of the largest value below the ceiling the bins were made for

  CAUSTICA_HDI uint32_t key(float d2) const { return float_bits(d2) >> shift; }
  CAUSTICA_HDI uint32_t of(float d2) const {
    const uint32_t k = key(d2);
    return (k > base ? k : base) - base;  // an integer maximum and a subtraction
  }
  // The lower end of bin b >= 1, and the upper end (excluded) of any bin.
  CAUSTICA_HDI float bottom(uint32_t b) const { return bits_float((base + b) << shift); }
  CAUSTICA_HDI float top(uint32_t b) const { return bits_float((base + b + 1) << shift); }
  // The last kDistanceBins keys below `ceiling` at `shift`, none below the key of `floor`.
  CAUSTICA_HDI static DistanceBins below(float ceiling, float floor, uint32_t shift) {
    // The key of the largest value below the ceiling (none below 0: then no bin is used).
    const uint32_t highest = float_bits(ceiling) > 0 ? (float_bits(ceiling) - 1) >> shift : 0u;
    const uint32_t lowest = float_bits(floor) >> shift;
    const uint32_t base =
        highest >= lowest + (kDistanceBins - 1) ? highest - (kDistanceBins - 1) : lowest;
    return {shift, base, highest - base};
  }
};

// Adds to a bin's count. On a GPU, in shared memory, an atomic addition whose result nobody reads:
// the additions of a batch's photons then go out one after the other without a wait, where a
// read, an addition and a write each waited for the previous photon's write. Each lane adds to
// its own words only, so the atomicity itself is not needed.
CAUSTICA_HDI void add_to_bin(uint32_t& count, uint32_t v) {
#if defined(__CUDA_ARCH__)
  // Known at compile time once inlined; words private to a thread are in local memory, which
  // has no atomics.
  if (__isShared(&count)) {
    atomicAdd(&count, v);
    return;
  }
#endif
  count += v;
}

// Eight bins per octave of squared distance to begin with; each refinement splits a bin in 64.
constexpr uint32_t kFirstBinShift = 20;
constexpr uint32_t kRefineBits = 6;

// Sums the flux of the photons taken, as estimate_radiance_within weighs them once the k-th
// distance r is known: w(d / r) is linear in a term per photon (d for the cone, d^2 for the
// Epanechnikov kernel), so the sum is kept in two parts.
struct FluxSum {
  Vec3f flux{0.0f};
  Vec3f by_distance{0.0f};  // flux times d (cone) or d^2 (Epanechnikov)

  CAUSTICA_HDI void add(const PhotonMapView& map, uint32_t index, float d2, Vec3f normal,
                        DensityKernel kernel) {
    const PhotonFlux ph = map.flux_of(index);
    if (!octahedral_along(ph.incoming, normal)) return;
    flux += ph.power;
    if (kernel == DensityKernel::kCone) by_distance += ph.power * sqrtf(d2);
    if (kernel == DensityKernel::kEpanechnikov) by_distance += ph.power * d2;
  }
  // sum w(d / r) dPhi for the squared radius r2, each kernel normalised as kernel_weight is.
  CAUSTICA_HDI Vec3f weighted(DensityKernel kernel, float r2) const {
    switch (kernel) {
      case DensityKernel::kUniform:
        return flux;
      case DensityKernel::kCone:
        return 3.0f * (flux - by_distance * (1.0f / sqrtf(r2)));
      case DensityKernel::kEpanechnikov:
        return 2.0f * (flux - by_distance * (1.0f / r2));
    }
    return flux;
  }
};

// The leaves of a group's first counting walk, for its collecting walk: every leaf within a
// member's final limit was visited then, since its limits only shrank towards it. Entry j is kept
// by the group's lane j mod n (of n) in its word j / n, and read by the whole group through a
// shuffle: kLeafLogWords words per lane hold 8 n leaves (a search of the global map visits about
// 50). A lone search (lanes 0) keeps none, and walks the tree again. The group must be the warp's
// lowest lanes. Past the words' room it stops recording and is incomplete.
template <typename Words>
struct WarpLeafLog {
  Words words;
  uint32_t first_word;
  uint32_t lanes;
  // Where the next leaf goes (lane, word) and where the next is read: counted up rather than
  // divided, since the group's size is not a constant.
  uint32_t size = 0, lane = 0, word = 0, read_lane = 0, read_word = 0;
  bool recording = false, replaying = false;

  CAUSTICA_HDI WarpLeafLog(Words w, uint32_t first, uint32_t group_lanes)
      : words(w), first_word(first), lanes(group_lanes) {
#if defined(__CUDA_ARCH__)
    size = uint32_t(__popc(lanes));
#endif
  }
  CAUSTICA_HDI void record(uint32_t leaf) {
#if defined(__CUDA_ARCH__)
    if (!recording || word > kLeafLogWords) return;
    if (word < kLeafLogWords && (threadIdx.x & 31u) == lane) words[first_word + word] = leaf;
    if (++lane == size) {
      lane = 0;
      ++word;
    }
#else
    (void)leaf;
#endif
  }
  CAUSTICA_HDI bool replays() const { return replaying; }
  CAUSTICA_HDI uint32_t next() {
#if defined(__CUDA_ARCH__)
    if (read_word == word && read_lane == lane) return ~0u;
    const uint32_t leaf = __shfl_sync(lanes, words[first_word + read_word], read_lane);
    if (++read_lane == size) {
      read_lane = 0;
      ++read_word;
    }
    return leaf;
#else
    return ~0u;
#endif
  }
  // Whether every leaf recorded fit (a group's only: a lone search records none).
  CAUSTICA_HDI bool complete() const {
    return lanes != 0 && (word < kLeafLogWords || (word == kLeafLogWords && lane == 0));
  }
};

// estimate_radiance_within's estimate, by counting: the same photons (where several lie exactly
// at the k-th distance, as many of them as make k, perhaps others), the same squared radius, the
// flux summed in another order. `words` holds kBinnedWords 32-bit words. Every member of `group`
// must make this call with the same map and k.
template <typename Words>
CAUSTICA_HDI RadianceEstimate estimate_radiance_binned(const PhotonMapView& map, Vec3f p,
                                                       Vec3f normal, Vec3f albedo, uint32_t k,
                                                       float max_radius, DensityKernel kernel,
                                                       Words words, float bound_squared,
                                                       SearchGroup group) {
  const float max_d2 = max_radius * max_radius;
  if (k == 0) return {Vec3f(0.0f), max_d2};
  // Counting: the cut is searched for among the photons in [floor, ceiling); `known` photons lie
  // below the floor, all among the k nearest.
  float ceiling = bound_squared < max_d2 ? bound_squared : max_d2;
  float floor = 0.0f;
  uint32_t known = 0;
  DistanceBins bins = DistanceBins::below(ceiling, floor, kFirstBinShift);
  uint32_t cut = 0, in_cut = 0, counted = 0;
  // Collecting: photons below `lo` are summed; those in [lo, hi), the cut's, kept in `words` (or,
  // when they all lie at one distance and are too many to keep, the first `needed` summed).
  float lo = 0.0f, hi = 0.0f;
  uint32_t needed = 0, kept = 0, taken = 0;
  bool all = false, keeps = true;
  FluxSum sum;

  // Files a photon nearer than the limit under its bin when `in` (it is at or above the floor),
  // without branching, so that a batch's photons are filed in step (no lane waits for another's
  // insertions). A photon left out adds 0 to the cut's word.
  auto count = [&](float d2, bool in) {
    add_to_bin(words[in ? bins.of(d2) : cut], uint32_t(in));
    counted += uint32_t(in);
  };
  // While the bins below the cut hold k, the cut moves down. Returns the limit: the cut's top. The
  // cut's count is read from its word here, once a batch, where keeping it in a register apart
  // took every photon a comparison and a select more to leave the cut's word out.
  auto lower_cut = [&]() {
    const uint32_t wanted = k - known;
    in_cut = words[cut];
    while (counted - in_cut >= wanted) {
      counted -= in_cut;
      --cut;
      in_cut = words[cut];
    }
    return min_f(ceiling, bins.top(cut));
  };
  auto collect = [&](float d2, uint32_t index) {
    if (d2 < lo) {
      sum.add(map, index, d2, normal, kernel);
    } else if (keeps) {
      if (kept < kCutCapacity) {
        words[2 * kept] = float_bits(d2);
        words[2 * kept + 1] = index;
        ++kept;
      }
    } else if (taken < needed) {
      sum.add(map, index, d2, normal, kernel);
      ++taken;
    }
  };

  // Counting walks until every member has its cut: all members first (their leaves recorded),
  // then those whose bound held fewer than k, from the maximum radius, and those whose cut holds
  // more photons than fit, within it with finer bins. Then one collecting walk for all, through
  // the recorded leaves where they cover every member. One call site for every walk, since each
  // inlines the whole leaf loop.
  WarpLeafLog<Words> log{words, kBinWords, group.lanes};
  log.recording = true;
  bool counting = true, walks = true, widened = false;
  SearchGroup walking = group;
  while (true) {
    if (walks) {
      float limit;
      if (counting) {
        // Unrolled in full, the 64 stores took the kernel from 106 to 196 registers.
        CAUSTICA_UNROLL_BY(8)
        for (uint32_t w = 0; w < kBinWords; ++w) words[w] = 0u;
        cut = bins.last;
        in_cut = 0;
        counted = 0;
        limit = ceiling;
      } else {
        limit = hi;
      }
      visit_photon_batches(
          map, p, limit, walking,
          [&](uint32_t first, const float d2[kPhotonBatch]) {
            if (counting) {  // the cut lowered once after the batch
              for (uint32_t j = 0; j < kPhotonBatch; ++j) {
                count(d2[j], d2[j] < limit && d2[j] >= floor);
              }
              limit = lower_cut();
            } else {
              offer_nearer(d2, first, limit, collect);
            }
          },
          [&](float d2, uint32_t index) {
            if (!counting) {
              collect(d2, index);
            } else if (d2 >= floor) {
              count(d2, true);
              limit = lower_cut();
            }
          },
          log);
      log.recording = false;
    }
    if (!counting) break;  // that was the collecting walk
    bool again = false;
    if (walks) {
      const bool few = known + counted < k;
      // A cut of one key at the finest bins holds photons all at one distance: no refining.
      const bool one_key = cut > 0 || bins.base <= bins.key(floor);
      if (few && ceiling < max_d2) {  // the bound held fewer than k: from the maximum
        ceiling = max_d2;
        bins = DistanceBins::below(ceiling, 0.0f, kFirstBinShift);
        again = widened = true;
      } else if (!few && in_cut > kCutCapacity && (bins.shift > 0 || !one_key)) {
        known += counted - in_cut;
        const float top = min_f(ceiling, bins.top(cut));
        if (cut > 0) floor = bins.bottom(cut);
        ceiling = top;
        const uint32_t shift = !one_key                   ? bins.shift
                               : bins.shift > kRefineBits ? bins.shift - kRefineBits
                                                          : 0u;
        bins = DistanceBins::below(ceiling, floor, shift);
        again = true;
      }
    }
    if (group.any(again)) {
      walking = group.among(again);
      walks = again;
      continue;
    }
    // Every member has its cut.
    counting = false;
    walks = true;
    walking = group;
    log.replaying = log.complete() && !group.any(widened);
    all = known + counted < k;  // fewer than k within the maximum radius: all of them
    lo = all ? max_d2 : cut > 0 ? bins.bottom(cut) : floor;
    hi = all ? max_d2 : min_f(ceiling, bins.top(cut));
    needed = all ? 0u : k - (known + counted - in_cut);
    keeps = in_cut <= kCutCapacity;
  }
  float r2 = all ? max_d2 : lo;
  if (keeps) {
    // The `needed` nearest of the cut's photons, ties in the order they were kept.
    for (uint32_t a = 0; a < kept; ++a) {
      const float d = bits_float(words[2 * a]);
      // Those kept before it count when no farther, those after when nearer: two loops of one
      // comparison each, where one loop over all weighed the tie by index. Not unrolled: they run
      // a few times each, and nvcc's unrolling by four with its remainder loops took 4.8% of the
      // gather's instructions.
      uint32_t rank = 0;
      CAUSTICA_NO_UNROLL
      for (uint32_t b = 0; b < a; ++b) rank += bits_float(words[2 * b]) <= d;
      CAUSTICA_NO_UNROLL
      for (uint32_t b = a + 1; b < kept; ++b) rank += bits_float(words[2 * b]) < d;
      if (rank >= needed) continue;
      sum.add(map, words[2 * a + 1], d, normal, kernel);
      if (rank == needed - 1) r2 = d;
    }
  }
  const uint32_t found = all ? counted : k;
  if (found == 0) return {Vec3f(0.0f), max_d2};
  if (r2 <= 0.0f) return {Vec3f(0.0f), r2};
  return {albedo * sum.weighted(kernel, r2) * (kInvPi * kInvPi / r2), r2};
}

}  // namespace caustica
