#include "renderer/photon/photon_map.h"

#include "renderer/accel/bvh_build.h"
#include "renderer/accel/morton_order.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {

PhotonMap build_photon_map(Backend& backend, Buffer<Photon> photons) {
  PhotonMap map;
  const uint32_t n = uint32_t(photons.size());
  map.photons.bind(backend);
  if (n == 0) {
    map.bvh.nodes.bind(backend);
    return map;
  }
  Buffer<Aabb> points(backend, n);
  Aabb* point = points.data();
  const Photon* in = photons.data();
  parallel_for(backend, n, [=] CAUSTICA_HD(size_t i) { point[i] = Aabb{in[i].position, in[i].position}; });
  const Aabb bounds = backend.reduce_bounds(point, n);

  MortonOrder sorted_order = sort_by_morton(backend, point, n, bounds);
  const uint32_t* id = sorted_order.order.data();

  map.photons.resize_discard(n);
  Photon* sorted = map.photons.data();
  parallel_for(backend, n, [=] CAUSTICA_HD(size_t i) { sorted[i] = in[id[i]]; });
  map.bvh = build_bvh_from_sorted_codes(backend, sorted_order.codes.data(), n, bounds,
                                        [=] CAUSTICA_HD(uint32_t leaf) {
                                          return Aabb{sorted[leaf].position, sorted[leaf].position};
                                        });
  return map;
}

}  // namespace caustica
