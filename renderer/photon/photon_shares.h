// A pass's photons traced in shares, one per device (PhotonTraceSettings::first_path), put back
// together on one device in the order a single trace of the whole pass keeps them, so that every
// device builds the same photon maps as one device would.
#pragma once

#include <span>

#include "renderer/photon/photon_tracer.h"

namespace caustica {

// `shares` in path order, each in its own backend's memory, merged into `target`'s: per kind
// every share's first run (TracedPhotons::*_from_slots), then every share's later stores, with
// the footprints in the same order. Copies go device to device where they can
// (Backend::copy_from): the shares' backends must be synchronised, and the shares kept until
// `target` synchronises.
TracedPhotons merge_traced_photons(Backend& target, std::span<const TracedPhotons> shares);

}  // namespace caustica
