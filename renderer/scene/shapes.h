// Procedural meshes for the JSON shapes that are not files. Each returns geometry only
// (positions, indices, normals where stated); the caller assigns materials. Triangles wind
// counter-clockwise seen from outside, so (v1 - v0) x (v2 - v0) points out of the solid.
#pragma once

#include <array>
#include <cstddef>

#include "renderer/base/vec.h"
#include "renderer/scene/scene.h"

namespace caustica {

// Triangles (0, 1, 2) and (0, 2, 3) of the corners in the given order.
Mesh make_quad(const std::array<Vec3f, 4>& corners);

// UV sphere with poles on the y axis: the two poles plus rings - 1 circles of `segments`
// vertices at polar angles pi * i / rings; fans at the poles, split quads between circles.
// No normals: it is shaded flat. Needs rings >= 2, segments >= 3.
Mesh make_sphere(Vec3f center, float radius, int rings, int segments);
size_t sphere_triangle_count(int rings, int segments);

// Closed thick band around the vertical axis through `base_center`, standing on its y:
// inner wall at `inner_radius`, outer wall `thickness` further out, top and bottom annuli.
// Each part has its own vertices so that the walls can carry smooth radial normals (a faceted
// mirror would break its caustic into streaks) while the annuli stay flat. Needs segments >= 3.
Mesh make_ring(Vec3f base_center, float inner_radius, float thickness, float height, int segments);
size_t ring_triangle_count(int segments);

}  // namespace caustica
