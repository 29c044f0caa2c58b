// Affine placement of meshes and lights: JSON "transform" objects and glTF node hierarchies.
// Kept in double precision because glTF hierarchies multiply several matrices before use.
#pragma once

#include <array>

#include "renderer/base/vec.h"
#include "renderer/scene/scene.h"

namespace caustica {

// p -> linear * p + translation, stored as the top three rows of a 4x4 matrix.
struct Affine {
  std::array<std::array<double, 4>, 3> m{{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}}};

  Vec3f apply_to_point(Vec3f p) const;
  Vec3f apply_to_vector(Vec3f v) const;
  // The map for normals: the inverse transpose of the linear part, up to a positive factor
  // (normals are renormalised after it anyway). Defined even for singular maps.
  Affine normal_transform() const;
  double determinant() const;  // of the linear part; negative means the map mirrors
};

Affine operator*(const Affine& a, const Affine& b);  // apply b first, then a

Affine translation(Vec3f t);
Affine scaling(Vec3f s);
Affine rotation_x_deg(double degrees);
Affine rotation_y_deg(double degrees);
Affine rotation_z_deg(double degrees);
// Unit quaternion (x, y, z, w), as glTF stores rotations.
Affine rotation_quaternion(double x, double y, double z, double w);
// glTF's 4x4 column-major matrix; the bottom row is assumed to be (0, 0, 0, 1).
Affine from_column_major(const std::array<double, 16>& columns);

// Moves positions and normals; a mirroring map also flips the winding, so that geometric normals
// keep pointing out of the surface.
void transform_mesh(const Affine& transform, Mesh* mesh);
// Moves a light's position and turns its direction (renormalised).
void transform_light(const Affine& transform, Light* light);

}  // namespace caustica
