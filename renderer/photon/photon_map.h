// The photon map: photons sorted in Morton order under the same Karras LBVH as the triangles
// (Fabianowski 2011 ch. 6 builds his photon map with this machinery), queried by exact k-nearest
// neighbours (density.h).
#pragma once

#include "renderer/accel/bvh.h"
#include "renderer/photon/photon.h"

namespace caustica {

struct PhotonMapView {
  const BvhNode* nodes = nullptr;
  const Photon* photons = nullptr;  // leaf order
  uint32_t count = 0;
  uint32_t root = 0;
  Aabb bounds;
};

struct PhotonMap {
  Bvh bvh;
  Buffer<Photon> photons;

  PhotonMapView view() const {
    return {bvh.nodes.data(), photons.data(), bvh.leaf_count, bvh.root, bvh.bounds};
  }
  size_t size() const { return photons.size(); }
  size_t bytes() const { return bvh.nodes.bytes() + photons.bytes(); }
};

// Sorts `photons` into Morton order and builds the hierarchy over them; takes ownership.
PhotonMap build_photon_map(Backend& backend, Buffer<Photon> photons);

}  // namespace caustica
