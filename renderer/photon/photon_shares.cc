#include "renderer/photon/photon_shares.h"

#include <algorithm>
#include <cstddef>

namespace caustica {
namespace {

// One kind's photons (or footprints) of every share, concatenated into `out` on `target` in the
// whole trace's order.
template <typename T>
Buffer<T> merge_kind(Backend& target, std::span<const TracedPhotons> shares,
                     const Buffer<T> TracedPhotons::*part, size_t TracedPhotons::*from_slots) {
  size_t total = 0;
  for (const TracedPhotons& share : shares) total += (share.*part).size();
  Buffer<T> out(target, total);
  size_t at = 0;
  auto append = [&](const TracedPhotons& share, size_t begin, size_t end) {
    const Buffer<T>& from = share.*part;
    if (end == begin) return;
    target.copy_from(*from.backend(), out.data() + at, from.data() + begin,
                     (end - begin) * sizeof(T));
    at += end - begin;
  };
  for (const TracedPhotons& share : shares) {
    // Footprints come only with differentials; a kind without them stays empty.
    append(share, 0, std::min((share.*part).size(), share.*from_slots));
  }
  for (const TracedPhotons& share : shares) {
    const size_t size = (share.*part).size();
    append(share, std::min(size, share.*from_slots), size);
  }
  return out;
}

}  // namespace

TracedPhotons merge_traced_photons(Backend& target, std::span<const TracedPhotons> shares) {
  TracedPhotons merged;
  merged.caustic =
      merge_kind(target, shares, &TracedPhotons::caustic, &TracedPhotons::caustic_from_slots);
  merged.global =
      merge_kind(target, shares, &TracedPhotons::global, &TracedPhotons::global_from_slots);
  merged.volume =
      merge_kind(target, shares, &TracedPhotons::volume, &TracedPhotons::volume_from_slots);
  merged.caustic_footprints = merge_kind(target, shares, &TracedPhotons::caustic_footprints,
                                         &TracedPhotons::caustic_from_slots);
  merged.global_footprints = merge_kind(target, shares, &TracedPhotons::global_footprints,
                                        &TracedPhotons::global_from_slots);
  merged.volume_footprints = merge_kind(target, shares, &TracedPhotons::volume_footprints,
                                        &TracedPhotons::volume_from_slots);
  for (const TracedPhotons& share : shares) {
    merged.emitted += share.emitted;
    merged.capped_paths += share.capped_paths;
    merged.specular_capped_paths += share.specular_capped_paths;
    merged.caustic_from_slots += share.caustic_from_slots;
    merged.global_from_slots += share.global_from_slots;
    merged.volume_from_slots += share.volume_from_slots;
  }
  return merged;
}

}  // namespace caustica
