// Warp-level helpers for device code that shares work between the lanes of a warp (the shadow
// rays' shared walks, H-PLOC's cluster merges).
#pragma once

#include <cstdint>
#include <cstring>

namespace caustica {

#if defined(__CUDA_ARCH__)
namespace detail {

// `value` as lane `source` holds it, word by word.
template <typename T>
__device__ __forceinline__ T shuffle_words(unsigned mask, const T& value, int source) {
  static_assert(sizeof(T) % 4 == 0, "whole words");
  uint32_t words[sizeof(T) / 4];
  memcpy(words, &value, sizeof(T));
  for (uint32_t& w : words) w = __shfl_sync(mask, w, source);
  T out = value;  // WatertightRay has no default constructor
  memcpy(&out, words, sizeof(T));
  return out;
}

// The lane of the `rank`-th set bit of `mask` (rank from 0), by halving: the rank's bit lies in
// the low half when that half holds more than `rank` bits.
__device__ __forceinline__ int nth_set_lane(uint32_t mask, int rank) {
  int lane = 0;
  for (int width = 16; width >= 1; width /= 2) {
    const uint32_t low = mask & ((1u << width) - 1u);
    const int count = __popc(low);
    const bool high = rank >= count;
    rank -= high ? count : 0;
    lane += high ? width : 0;
    mask = high ? mask >> width : low;
  }
  return lane;
}

}  // namespace detail
#endif

}  // namespace caustica
