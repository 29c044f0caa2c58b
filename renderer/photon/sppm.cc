#include "renderer/photon/sppm.h"

#include "renderer/base/octahedral.h"
#include "renderer/parallel/parallel_for.h"
#include "renderer/photon/knn_estimate.h"

namespace caustica {

double sppm_global_shrink(uint32_t pass_number, float alpha) {
  double shrink = 1.0;
  for (uint32_t j = 1; j < pass_number; ++j) shrink *= (j + double(alpha)) / (j + 1.0);
  return shrink;
}

void sppm_gather(Backend& backend, const PhotonMapView& map, const VisiblePoint* points,
                 const Vec3f* light, SppmPixel* pixels, Vec3f* film_sum, const PixelBlocks& blocks,
                 const SppmGather& cfg) {
  const size_t threads = blocks.thread_count();
  // The threads of a GPU warp take 8 x 4 neighbouring pixels, whose visible points mostly lie
  // close together: they walk the map as a search group, sharing its nodes and photons.
  parallel_for(backend, "sppm_gather", threads, [=] CAUSTICA_HD(size_t thread) {
    size_t pixel = 0;
    const bool has_pixel = blocks.pixel_of(thread, pixel);
    const VisiblePoint vp = has_pixel ? points[pixel] : VisiblePoint{};
    SppmPixel st = has_pixel ? pixels[pixel] : SppmPixel{};
    const bool visible = has_pixel && max_component(vp.weight) > 0.0f;
    const float max_d2 = cfg.max_radius * cfg.max_radius;
    const SearchGroup seeing = launch_warp(thread, threads).among(visible);
    if (visible) {
      const bool fresh = st.radius_squared == 0.0f;
      const SearchGroup starting = seeing.among(fresh);
      if (fresh) {
        NeighbourPair storage[NeighbourHeap<NeighbourPair*>::pairs_for(kSppmInitialSearch)];
        NeighbourHeap<NeighbourPair*> heap{storage};
        const uint32_t k =
            cfg.initial_nearest < kSppmInitialSearch ? cfg.initial_nearest : kSppmInitialSearch;
        const uint32_t found = find_nearest(map, vp.position, k, max_d2, heap, starting);
        const float scaled = heap.top.distance_squared * (float(cfg.initial_nearest) / float(k));
        st.radius_squared = found == k && scaled < max_d2 ? scaled : max_d2;
        if (!(st.radius_squared > 0.0f)) st.radius_squared = max_d2;
      }
      const float r2 = cfg.rule == SppmRadius::kGlobal ? st.radius_squared * cfg.global_shrink
                                                       : st.radius_squared;
      // The photons within the radius on the visible point's side, and their flux.
      float limit = r2;
      uint32_t m = 0;
      Vec3f phi(0.0f);
      for_each_photon_within(map, vp.position, limit, seeing, [&](float, uint32_t i) {
        const PhotonFlux ph = map.flux_of(i);
        if (!octahedral_along(ph.incoming, vp.normal)) return;
        phi += ph.power;
        ++m;
      });
      phi = vp.weight * phi * kInvPi;  // f_r = albedo / pi
      if (cfg.rule == SppmRadius::kGlobal) {
        st.flux += phi / r2;
      } else if (m > 0) {
        const float n = st.photons + cfg.alpha * float(m);
        const float shrink = n / (st.photons + float(m));
        st.photons = n;
        st.radius_squared = r2 * shrink;
        st.flux = (st.flux + phi) * shrink;
      }
      pixels[pixel] = st;
    }
    if (!has_pixel) return;
    Vec3f estimate(0.0f);
    if (st.radius_squared > 0.0f) {
      estimate = cfg.rule == SppmRadius::kGlobal ? st.flux * kInvPi
                                                 : st.flux * (kInvPi / st.radius_squared);
    }
    film_sum[pixel] = light[pixel] + estimate;
  });
}

}  // namespace caustica
