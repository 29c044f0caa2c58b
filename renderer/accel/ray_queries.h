// The batch entry points of the structure seam: trace_closest(rays) -> hits and
// trace_any(rays) -> blocked, over a whole queue of rays in the backend's memory. Structures whose
// views answer one ray at a time (StructureView) get them from a named parallel_for over their
// per-ray functions; a structure that can only answer batches (DACRT, dacrt.h) defines its own
// overloads. Every view meets BatchStructureView, so code written against the queues (the render
// pass's and the photon tracer's waves) runs on every structure.
#pragma once

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "renderer/accel/triangle.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {

// What a per-ray device view answers: the box of everything it holds, the nearest hit along a
// ray in (t_min, t_max), and whether anything blocks that open segment. `triangle` in a Hit is
// the index in the order the builder was given the triangles.
template <typename View>
concept StructureView = std::is_trivially_copyable_v<View> && requires(const View& v, Ray r) {
  { v.bounds } -> std::convertible_to<Aabb>;
  { closest_hit(v, r) } -> std::same_as<Hit>;
  { any_hit(v, r) } -> std::same_as<bool>;
};

// hits[i] = the closest hit of rays[i], for `count` rays; both arrays in the backend's memory.
template <StructureView View>
void trace_closest(Backend& backend, const View& view, const Ray* rays, size_t count, Hit* hits) {
  parallel_for(backend, "trace_closest", count,
               [=] CAUSTICA_HD(size_t i) { hits[i] = closest_hit(view, rays[i]); });
}

// blocked[i] = 1 when anything blocks the open segment of rays[i], else 0.
template <StructureView View>
void trace_any(Backend& backend, const View& view, const Ray* rays, size_t count,
               uint8_t* blocked) {
  parallel_for(backend, "trace_any", count,
               [=] CAUSTICA_HD(size_t i) { blocked[i] = any_hit(view, rays[i]) ? 1 : 0; });
}

// What every structure's view answers: its bounds, and the two batch queries.
template <typename View>
concept BatchStructureView =
    std::is_trivially_copyable_v<View> &&
    requires(const View& v, Backend& backend, const Ray* rays, size_t n, Hit* hits,
             uint8_t* blocked) {
      { v.bounds } -> std::convertible_to<Aabb>;
      trace_closest(backend, v, rays, n, hits);
      trace_any(backend, v, rays, n, blocked);
    };

}  // namespace caustica
