// The volume photon map and the beam radiance estimate (Jarosz et al. 2008, with Fabianowski's
// corrected units, 2011 sec. 7.1): every collision a photon had in a medium, each given a
// bandwidth h_j, and the radiance a camera ray gathers along a stretch of medium in one query of a
// hierarchy over the collisions' spheres:
//
//   L = sum over collisions j whose sphere the ray passes through, at t_j in the stretch, of
//       K(d_j / h_j) / h_j^2 * Tr(t0, t_j) * p(cos theta_j) * Phi_j
//
// with d_j the ray's distance from the collision, K the 2D Epanechnikov kernel, p the phase
// function and Phi_j the flux scattered there (the extinguished flux times the albedo).
//
// A bandwidth is either the distance to the k-th nearest collision (the knn estimator's) or set by
// the collision's photon differentials (the vkde estimator's, Fabianowski sec. 7.3): the cube root
// of its footprint's volume times a spread, dampened.
//
// The collisions are a photon map (photon_map.h): sorted along the backend's curve, positions
// apart from flux, the k-nearest search its hierarchy answers. The beams' hierarchy is a second
// radix tree over the same leaves and codes, its boxes grown by each collision's bandwidth.
#pragma once

#include <cstdint>

#include "renderer/accel/bvh.h"
#include "renderer/medium/medium.h"
#include "renderer/photon/photon_map.h"
#include "renderer/photon/range_query.h"

namespace caustica {

// The collisions whose distance sets a bandwidth: fewer than a surface estimate's k, since a ray
// gathers from every sphere along its way, about 3 k / (4 h) per unit of length.
constexpr uint32_t kVolumeNearest = 24;

// The largest bandwidth a collision takes, where the gathers' radius is capped by default: 5% of
// the diagonal of the scene's bounds.
CAUSTICA_HDI float volume_bandwidth_cap(const Aabb& scene_bounds) {
  return 0.05f * length(scene_bounds.extent());
}

struct VolumeMapView {
  PhotonMapView points;              // the collisions, their positions and flux in curve order
  const float* bandwidth = nullptr;  // h_j, same order
  const BvhNode* beam_nodes = nullptr;
  uint32_t beam_root = 0;
  Aabb beam_bounds;  // of every sphere

  CAUSTICA_HDI bool empty() const { return points.count == 0; }
};

struct VolumeMap {
  PhotonMap points;
  Buffer<float> bandwidth;
  Bvh beams;

  VolumeMapView view() const {
    return {points.view(), bandwidth.data(), beams.nodes.data(), beams.root, beams.bounds};
  }
  size_t size() const { return points.size(); }
  size_t bytes() const { return points.bytes() + bandwidth.bytes() + beams.nodes.bytes(); }
};

// Builds the map over `collisions` with `photons_per_leaf` per leaf, each bandwidth the distance
// to the k-th nearest other collision (itself counted), at most `max_bandwidth`.
VolumeMap build_volume_map(Backend& backend, const Buffer<Photon>& collisions,
                           uint32_t photons_per_leaf, uint32_t k, float max_bandwidth);

// Bandwidths from footprints: with V a collision's footprint volume among n photons emitted,
// x = cbrt(V n / (4 pi)) the cube root of its differentials' own volume, and P the pivot,
//   h = spread cbrt(4 pi / n) P log(1 + x / P),
// which is spread cbrt(V) where x is well below P and grows only logarithmically beyond it, as
// Fabianowski dampens with log1p (his sec. 7.3.2): a path's differentials see only its own
// spreading, while the collisions of many paths overlap. At most max_bandwidth.
struct VolumeKernelSettings {
  float spread;
  float pivot;
  float max_bandwidth;
  uint32_t photons;  // n, emitted
};

// The bandwidth of a collision of footprint volume `volume` (volume_bandwidths' formula).
CAUSTICA_HDI float differential_bandwidth(float volume, const VolumeKernelSettings& s) {
  const float per_photon = cbrtf(4.0f * kPi / float(s.photons));
  const float x = cbrtf(volume) / per_photon;
  const float h = s.spread * per_photon * s.pivot * log1pf(x / s.pivot);
  return h < s.max_bandwidth ? h : s.max_bandwidth;
}

// Builds the map over `collisions` with `photons_per_leaf` per leaf, each bandwidth set by its
// footprint volume in `footprint_volumes` (the same order).
VolumeMap build_volume_map(Backend& backend, const Buffer<Photon>& collisions,
                           const Buffer<float>& footprint_volumes, uint32_t photons_per_leaf,
                           const VolumeKernelSettings& settings);

// Whether the segment [t0, t1] of the ray (origin, inverse direction) meets `box`.
CAUSTICA_HDI bool segment_meets(const BvhChild& box, Vec3f origin, Vec3f inv_direction, float t0,
                                float t1) {
  for (int a = 0; a < 3; ++a) {
    float near = (box.lower[a] - origin[a]) * inv_direction[a];
    float far = (box.upper[a] - origin[a]) * inv_direction[a];
    if (near > far) {
      const float swap = near;
      near = far;
      far = swap;
    }
    // A NaN from 0 * inf (the origin on a slab's plane, parallel to it) leaves the bounds as
    // they were.
    t0 = near > t0 ? near : t0;
    t1 = far < t1 ? far : t1;
  }
  return t0 <= t1;
}

// Calls visit(i) for every collision of a leaf whose box the segment [t0, t1] of the ray meets;
// the caller tests the collision's own sphere. The members of `group` (range_query.h) walk the
// tree as one, each node visited when any of them needs it, so that a warp of neighbouring rays
// reads each node and collision once for all its lanes; every member must make this call.
template <typename Visit>
CAUSTICA_HDI void visit_beam_leaves(const VolumeMapView& map, Vec3f origin, Vec3f direction,
                                    float t0, float t1, SearchGroup group, Visit visit) {
  const PhotonMapView& points = map.points;
  if (points.count == 0) return;
  const Vec3f inv(1.0f / direction.x, 1.0f / direction.y, 1.0f / direction.z);
  auto visit_leaf = [&](uint32_t leaf) {
    const uint32_t end = points.leaf_end(leaf);
    for (uint32_t i = points.leaf_begin(leaf); i < end; ++i) visit(i);
  };
  const BvhChild root{map.beam_bounds.lower, 0, map.beam_bounds.upper};
  if (!group.any(segment_meets(root, origin, inv, t0, t1))) return;
  if (points.leaf_count == 1) {
    visit_leaf(0);
    return;
  }
  // The tree over at most 2^32 leaves of a 1024^3 grid's codes and their indices is at most 62
  // deep; one pending child per level.
  uint32_t stack[64];
  uint32_t top = 0;
  uint32_t node = map.beam_root;
  for (;;) {
    const BvhNode& n = map.beam_nodes[node];
    bool go[2];
    for (int c = 0; c < 2; ++c) go[c] = group.any(segment_meets(n.child[c], origin, inv, t0, t1));
    uint32_t next = 0;
    bool have_next = false;
    for (int c = 0; c < 2; ++c) {
      if (!go[c]) continue;
      const uint32_t child = n.child[c].index;
      if (is_leaf(child)) {
        visit_leaf(leaf_index(child));
      } else if (!have_next) {
        next = child;
        have_next = true;
      } else {
        stack[top++] = child;
      }
    }
    if (have_next) {
      node = next;
      continue;
    }
    if (top == 0) return;
    node = stack[--top];
  }
}

// The in-scattered radiance the stretch `span` of the ray (origin, unit direction) in medium `m`
// gathers from the map, as seen from the stretch's start. With a `group`, every member calls it
// (an empty span takes part in the votes and gathers nothing). kGrids: some medium of the scene
// is a grid, whose transmittance to each collision comes from the stretch's optical depths
// (chosen per launch, so that scenes without grids keep their registers).
template <bool kGrids = false>
CAUSTICA_HDI Vec3f beam_radiance(const VolumeMapView& map, const DeviceMedium& m, Vec3f origin,
                                 Vec3f direction, const MediumSpan& span, SearchGroup group = {}) {
  Vec3f sum(0.0f);
  if (map.empty()) return sum;
  // A lone thread with nothing to gather stops here; a group's member keeps voting.
  const bool gathers = span.length() > 0.0f;
  if (!group.any(gathers)) return sum;
  const float t0 = gathers ? span.t0 : 1.0f, t1 = gathers ? span.t1 : 0.0f;
  auto gather = [&](auto transmittance_to) {
    visit_beam_leaves(map, origin, direction, t0, t1, group, [&](uint32_t i) {
      const Vec3f v = map.points.positions[i] - origin;
      const float t = dot(v, direction);
      if (t < t0 || t > t1) return;
      const float h = map.bandwidth[i];
      const float h2 = h * h;
      const float d2 = length_squared(v) - t * t;
      if (!(d2 < h2)) return;
      const PhotonFlux flux = map.points.flux_of(i);
      // Light travelled along -incoming and leaves towards the ray's origin, along -direction.
      const float cos_theta = dot(decode_octahedral(flux.incoming), direction);
      const float kernel = 2.0f * kInvPi * (1.0f - d2 / h2) / h2;
      sum += flux.power * transmittance_to(t) * (kernel * henyey_greenstein(cos_theta, m.g));
    });
  };
  if constexpr (kGrids) {
    const bool grid = m.kind == MediumKind::kGrid;
    const OpticalDepth depth(grid ? m.grid : DeviceGrid{}, origin, direction,
                             grid && gathers ? span : MediumSpan{});
    gather([&](float t) {
      return grid ? exp_negative(m.sigma_t * depth.at(t)) : transmittance(m, t - t0);
    });
  } else {
    gather([&](float t) { return transmittance(m, t - t0); });
  }
  return sum;
}

}  // namespace caustica
