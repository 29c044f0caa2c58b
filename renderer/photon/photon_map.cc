#include "renderer/photon/photon_map.h"

#include "renderer/base/morton.h"
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

  Buffer<uint32_t> codes(backend, n);
  Buffer<uint32_t> order(backend, n);
  uint32_t* code = codes.data();
  uint32_t* id = order.data();
  parallel_for(backend, n, [=] CAUSTICA_HD(size_t i) {
    code[i] = morton_code(in[i].position, bounds);
    id[i] = uint32_t(i);
  });
  backend.sort_pairs(code, id, n, 30);

  map.photons.resize_discard(n);
  Photon* sorted = map.photons.data();
  parallel_for(backend, n, [=] CAUSTICA_HD(size_t i) {
    sorted[i] = in[id[i]];
    point[i] = Aabb{sorted[i].position, sorted[i].position};
  });
  map.bvh = build_bvh_from_sorted_codes(backend, code, point, n, bounds);
  return map;
}

}  // namespace caustica
