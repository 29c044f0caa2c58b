// The costs the kd-tree build (kd_tree_build.cc) minimises over split candidates: its constants
// per cost function, and the visit probabilities of a cell's two children for a plane, by the
// surface area heuristic or by Fabianowski's scene-interior ray origin heuristic (SIROH).
#pragma once

#include "renderer/accel/kd_tree.h"

namespace caustica {

// The cost constants (docs/structures.md): traversal step C_T and triangle test C_I, the largest
// leaf that is never split, and the empty-space bias: a candidate whose empty child holds more
// than kEmptyVolumeShare of the cell's volume costs kEmptyBonus less.
struct KdCostParameters {
  float traversal, intersection;
  uint32_t leaf_size;  // split only nodes of more references than this
  float empty_volume_share, empty_bonus;
};

CAUSTICA_HDI KdCostParameters parameters_of(KdCost cost) {
  if (cost == KdCost::kSiroh) return {1.0f, 3.0f, 4u, 0.3f, 0.2f};
  return {1.0f, 1.0f, 0u, 0.3f, 0.2f};
}

// The visit probabilities of a cell's children, relative to the cell's own, for splits along one
// axis. For the SAH, surface areas. For SIROH (Fabianowski's thesis, eq. 4.6), a node's
// probability is V(N) / V(S) plus, for each of its six faces, the share of the scene box beyond
// that face's plane which faces it: depth d of that region, V(S) normalising, A_S and C_S the
// area and circumference of the scene box's face on that axis, A_N the node's face:
//   d A_S A_N / (V(S) (2 A_S + d C_S)).
// A child L below the plane at distance l from the cell's lower side keeps the cell's lower face
// term, its volume and its four side faces scale by l / p, and only its face on the plane is new,
// with region depth r (the plane to the scene's upper side): p_L = c1 + c2 l + r / (c3 + c4 r),
// three additions, two multiplications and one division per candidate; p_R likewise.
struct ChildProbabilities {
  bool siroh;
  // SAH: the cell's half area and its cross-section and perimeter across the axis.
  float inv_half_area, cross_section, cross_perimeter;
  float lower, upper, extent;  // the cell along the axis
  // SIROH: the constants for each side, and the scene's bounds along the axis.
  float c1_left, c1_right, c2, c3, c4, inv_parent;
  float scene_lower, scene_upper;

  CAUSTICA_HDI void at(float split, float& left, float& right) const {
    const float l = split - lower, r = upper - split;
    if (!siroh) {
      left = (cross_section + l * cross_perimeter) * inv_half_area;
      right = (cross_section + r * cross_perimeter) * inv_half_area;
      return;
    }
    const float beyond_left = scene_upper - split, beyond_right = split - scene_lower;
    left = (c1_left + c2 * l + beyond_left / (c3 + c4 * beyond_left)) * inv_parent;
    right = (c1_right + c2 * r + beyond_right / (c3 + c4 * beyond_right)) * inv_parent;
  }
};

// SIROH's term for the face of `node` on `axis` whose region beyond it is `depth` deep.
CAUSTICA_HDI float siroh_face(const Aabb& scene, const Aabb& node, int axis, float depth,
                              float scene_volume) {
  const int b = (axis + 1) % 3, c = (axis + 2) % 3;
  const Vec3f se = scene.extent(), ne = node.extent();
  const float scene_face = se[b] * se[c], scene_rim = 2.0f * (se[b] + se[c]);
  const float node_face = ne[b] * ne[c];
  return depth * scene_face * node_face / (scene_volume * (2.0f * scene_face + depth * scene_rim));
}

CAUSTICA_HDI float siroh_probability(const Aabb& scene, const Aabb& node, float scene_volume) {
  const Vec3f ne = node.extent();
  float p = ne.x * ne.y * ne.z / scene_volume;
  for (int a = 0; a < 3; ++a) {
    p += siroh_face(scene, node, a, node.lower[a] - scene.lower[a], scene_volume);
    p += siroh_face(scene, node, a, scene.upper[a] - node.upper[a], scene_volume);
  }
  return p;
}

CAUSTICA_HDI ChildProbabilities child_probabilities(bool siroh, const Aabb& cell, int axis,
                                                    const Aabb& scene, float scene_volume) {
  ChildProbabilities p{};
  const int b = (axis + 1) % 3, c = (axis + 2) % 3;
  const Vec3f e = cell.extent();
  p.lower = cell.lower[axis];
  p.upper = cell.upper[axis];
  p.extent = e[axis];
  p.siroh = siroh;
  if (!siroh) {
    p.inv_half_area = 1.0f / cell.half_area();
    p.cross_section = e[b] * e[c];
    p.cross_perimeter = e[b] + e[c];
    return p;
  }
  const float parent = siroh_probability(scene, cell, scene_volume);
  p.inv_parent = 1.0f / parent;
  p.c1_left = siroh_face(scene, cell, axis, cell.lower[axis] - scene.lower[axis], scene_volume);
  p.c1_right = siroh_face(scene, cell, axis, scene.upper[axis] - cell.upper[axis], scene_volume);
  // Volume and the four faces across the other axes, per unit of extent along this one.
  float scaled = e.x * e.y * e.z / scene_volume;
  for (int i = 0; i < 2; ++i) {
    const int other = i == 0 ? b : c;
    scaled += siroh_face(scene, cell, other, cell.lower[other] - scene.lower[other], scene_volume);
    scaled += siroh_face(scene, cell, other, scene.upper[other] - cell.upper[other], scene_volume);
  }
  p.c2 = scaled / e[axis];
  const Vec3f se = scene.extent();
  const float scene_face = se[b] * se[c], scene_rim = 2.0f * (se[b] + se[c]);
  const float plane_face = e[b] * e[c];
  p.c3 = 2.0f * scene_volume / plane_face;
  p.c4 = scene_volume * scene_rim / (scene_face * plane_face);
  p.scene_lower = scene.lower[axis];
  p.scene_upper = scene.upper[axis];
  return p;
}

}  // namespace caustica
