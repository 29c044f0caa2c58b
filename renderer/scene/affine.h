// Affine maps in double precision: where JSON "transform" objects and glTF node hierarchies
// place meshes, lights and density grids (transform.h applies them to meshes and lights).
#pragma once

#include <array>

#include "renderer/base/vec.h"

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
  // The map back; only for maps whose determinant is not 0.
  Affine inverse() const;
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

}  // namespace caustica
