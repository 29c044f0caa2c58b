#include "renderer/resident/cutouts.h"

#include <utility>

#include "renderer/parallel/parallel_for.h"

namespace caustica {

CutoutRetrace::CutoutRetrace(Backend& backend, size_t n)
    : backend_(backend),
      rays_(backend, n),
      next_rays_(backend, n),
      hits_(backend, n),
      places_(backend, n),
      next_places_(backend, n),
      kept_(backend, n),
      flags_(backend, n) {}

size_t CutoutRetrace::select(const ResidentSceneView& scene, const Ray* rays, const Hit* hits,
                             size_t n) {
  // Every ray is its own place; the selected ones' rays start where their hits are.
  Ray* to = rays_.data();
  Hit* hit = hits_.data();
  uint32_t* place = places_.data();
  parallel_for(backend_, "cutout_select", n, [=] CAUSTICA_HD(size_t i) {
    to[i] = rays[i];
    hit[i] = hits[i];
    place[i] = uint32_t(i);
  });
  return compact(scene, n);
}

size_t CutoutRetrace::write_back(const ResidentSceneView& scene, Hit* hits, size_t selected) {
  const Hit* hit = hits_.data();
  const uint32_t* place = places_.data();
  parallel_for(backend_, "cutout_write_back", selected,
               [=] CAUSTICA_HD(size_t i) { hits[place[i]] = hit[i]; });
  return compact(scene, selected);
}

size_t CutoutRetrace::compact(const ResidentSceneView& scene, size_t selected) {
  const Ray* ray = rays_.data();
  const Hit* hit = hits_.data();
  uint8_t* flag = flags_.data();
  parallel_for(backend_, "cutout_flag", selected, [=] CAUSTICA_HD(size_t i) {
    flag[i] = hit[i].valid() && passes_through(scene, ray[i], hit[i]) ? 1 : 0;
  });
  uint32_t* index = kept_.data();
  const size_t kept = backend_.select_flagged(nullptr, flags_.data(), selected, index);
  // The kept rays from beyond their hits, with their places in the caller's batch.
  const uint32_t* place = places_.data();
  Ray* to = next_rays_.data();
  uint32_t* to_place = next_places_.data();
  parallel_for(backend_, "cutout_gather", kept, [=] CAUSTICA_HD(size_t i) {
    Ray r = ray[index[i]];
    r.t_min = hit[index[i]].t;
    to[i] = r;
    to_place[i] = place[index[i]];
  });
  std::swap(rays_, next_rays_);
  std::swap(places_, next_places_);
  return kept;
}

void blocked_from_hits(Backend& backend, const Hit* hits, size_t n, uint8_t* blocked) {
  parallel_for(backend, "cutout_blocked", n,
               [=] CAUSTICA_HD(size_t i) { blocked[i] = hits[i].valid() ? 1 : 0; });
}

}  // namespace caustica
