#include "renderer/scene/transform.h"

#include <cmath>
#include <utility>

namespace caustica {
namespace {

constexpr double kDegreesToRadians = 3.14159265358979323846 / 180.0;

Vec3f to_vec3f(double x, double y, double z) {
  return {static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)};
}

Vec3f normalized_or_zero(Vec3f v) {
  const float len = length(v);
  return len > 0 ? v / len : v;
}

// Cofactor matrix of the linear part: det * inverse-transpose, defined even when det == 0.
std::array<std::array<double, 3>, 3> cofactors(const Affine& a) {
  const auto& m = a.m;
  std::array<std::array<double, 3>, 3> c{};
  for (int r = 0; r < 3; ++r) {
    for (int col = 0; col < 3; ++col) {
      const int r1 = (r + 1) % 3, r2 = (r + 2) % 3;
      const int c1 = (col + 1) % 3, c2 = (col + 2) % 3;
      c[r][col] = m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1];
    }
  }
  return c;
}

Affine rotation_about_axis(int axis, double degrees) {
  const double s = std::sin(degrees * kDegreesToRadians);
  const double c = std::cos(degrees * kDegreesToRadians);
  const int i = (axis + 1) % 3, j = (axis + 2) % 3;  // the plane that turns, right-handed
  Affine r;
  r.m[i][i] = c;
  r.m[i][j] = -s;
  r.m[j][i] = s;
  r.m[j][j] = c;
  return r;
}

}  // namespace

Vec3f Affine::apply_to_point(Vec3f p) const {
  return to_vec3f(m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
                  m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
                  m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3]);
}

Vec3f Affine::apply_to_vector(Vec3f v) const {
  return to_vec3f(m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
                  m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
                  m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z);
}

Affine Affine::normal_transform() const {
  const auto c = cofactors(*this);
  // Cofactors are det * inverse-transpose; the sign of det keeps normals on the same side.
  const double sign = determinant() < 0 ? -1.0 : 1.0;
  Affine r;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r.m[i][j] = sign * c[i][j];
  }
  return r;
}

double Affine::determinant() const {
  const auto c = cofactors(*this);
  return m[0][0] * c[0][0] + m[0][1] * c[0][1] + m[0][2] * c[0][2];
}

Affine Affine::inverse() const {
  const auto c = cofactors(*this);
  const double inv_det = 1.0 / determinant();
  Affine r;
  // The linear part's inverse is the transposed cofactors over det; the translation follows.
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r.m[i][j] = c[j][i] * inv_det;
  }
  for (int i = 0; i < 3; ++i) {
    r.m[i][3] = -(r.m[i][0] * m[0][3] + r.m[i][1] * m[1][3] + r.m[i][2] * m[2][3]);
  }
  return r;
}

Affine operator*(const Affine& a, const Affine& b) {
  Affine r;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) {
      double sum = j == 3 ? a.m[i][3] : 0.0;
      for (int k = 0; k < 3; ++k) sum += a.m[i][k] * b.m[k][j];
      r.m[i][j] = sum;
    }
  }
  return r;
}

Affine translation(Vec3f t) {
  Affine r;
  r.m[0][3] = t.x;
  r.m[1][3] = t.y;
  r.m[2][3] = t.z;
  return r;
}

Affine scaling(Vec3f s) {
  Affine r;
  r.m[0][0] = s.x;
  r.m[1][1] = s.y;
  r.m[2][2] = s.z;
  return r;
}

Affine rotation_x_deg(double degrees) { return rotation_about_axis(0, degrees); }
Affine rotation_y_deg(double degrees) { return rotation_about_axis(1, degrees); }
Affine rotation_z_deg(double degrees) { return rotation_about_axis(2, degrees); }

Affine rotation_quaternion(double x, double y, double z, double w) {
  // Normalise first: exporters write quaternions that are unit only to a few digits.
  const double norm = std::sqrt(x * x + y * y + z * z + w * w);
  if (norm > 0) {
    x /= norm;
    y /= norm;
    z /= norm;
    w /= norm;
  }
  Affine r;
  r.m[0] = {1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w), 0};
  r.m[1] = {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w), 0};
  r.m[2] = {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y), 0};
  return r;
}

Affine from_column_major(const std::array<double, 16>& columns) {
  Affine r;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 4; ++col) r.m[row][col] = columns[col * 4 + row];
  }
  return r;
}

void transform_mesh(const Affine& transform, Mesh* mesh) {
  for (Vec3f& p : mesh->positions) p = transform.apply_to_point(p);
  const Affine normal_transform = transform.normal_transform();
  for (Vec3f& n : mesh->normals) n = normalized_or_zero(normal_transform.apply_to_vector(n));
  // A tangent lies in the surface, so it moves as a direction; a mirroring transform turns the
  // frame's handedness, and with it the bitangent's sign.
  const bool mirrors = transform.determinant() < 0;
  for (Vec4f& t : mesh->tangents) {
    const Vec3f d = normalized_or_zero(transform.apply_to_vector({t.x, t.y, t.z}));
    t = {d.x, d.y, d.z, mirrors ? -t.w : t.w};
  }
  if (mirrors) {
    for (size_t t = 0; t + 2 < mesh->indices.size(); t += 3) {
      std::swap(mesh->indices[t + 1], mesh->indices[t + 2]);
    }
  }
}

void transform_light(const Affine& transform, Light* light) {
  light->position = transform.apply_to_point(light->position);
  light->direction = normalized_or_zero(transform.apply_to_vector(light->direction));
}

Affine placement(Vec3f translate, Vec3f rotate_deg, Vec3f scale) {
  return translation(translate) * rotation_z_deg(rotate_deg.z) * rotation_y_deg(rotate_deg.y) *
         rotation_x_deg(rotate_deg.x) * scaling(scale);
}

}  // namespace caustica
