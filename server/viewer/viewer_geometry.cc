#include "server/viewer/viewer_geometry.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace caustica::server::viewer {
namespace {

Vec3d operator+(const Vec3d& a, const Vec3d& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec3d operator-(const Vec3d& a, const Vec3d& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3d operator*(const Vec3d& a, double s) { return {a.x * s, a.y * s, a.z * s}; }
double dot(const Vec3d& a, const Vec3d& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double length(const Vec3d& a) { return std::sqrt(dot(a, a)); }
Vec3d normalize(const Vec3d& a) {
  const double l = length(a);
  return l > 0 ? a * (1 / l) : a;
}

// The camera's orthonormal frame and the image plane's half extents at depth 1, as
// PinholeCamera::from builds them.
struct CameraFrame {
  Vec3d origin, forward, right, up;
  double half_width = 1, half_height = 1;
};

CameraFrame frame_of(const v1::Camera& camera) {
  CameraFrame f;
  f.origin = to_vec3d(camera.position());
  f.forward = normalize(to_vec3d(camera.look_at()) - f.origin);
  f.right = normalize(cross(f.forward, to_vec3d(camera.up())));
  f.up = cross(f.right, f.forward);
  f.half_height = std::tan(0.5 * camera.vertical_fov_deg() * std::numbers::pi / 180.0);
  const double aspect = camera.height() > 0 ? double(camera.width()) / camera.height() : 1.0;
  f.half_width = f.half_height * aspect;
  return f;
}

// Rotates `v` about the unit axis `axis` by `angle` radians (Rodrigues).
Vec3d rotate(const Vec3d& v, const Vec3d& axis, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return v * c + cross(axis, v) * s + axis * (dot(axis, v) * (1 - c));
}

}  // namespace

Vec3d to_vec3d(const v1::Vec3& v) { return {v.x(), v.y(), v.z()}; }

v1::Vec3 to_proto(const Vec3d& v) {
  v1::Vec3 out;
  out.set_x(static_cast<float>(v.x));
  out.set_y(static_cast<float>(v.y));
  out.set_z(static_cast<float>(v.z));
  return out;
}

std::optional<ImagePoint> project(const v1::Camera& camera, const Vec3d& point) {
  const CameraFrame f = frame_of(camera);
  const Vec3d offset = point - f.origin;
  const double depth = dot(offset, f.forward);
  if (!(depth > 0)) return std::nullopt;
  const double sx = dot(offset, f.right) / (depth * f.half_width);
  const double sy = dot(offset, f.up) / (depth * f.half_height);
  return ImagePoint{0.5 * (sx + 1), 0.5 * (1 - sy), depth};
}

Vec3d point_at(const v1::Camera& camera, double u, double v, double depth) {
  const CameraFrame f = frame_of(camera);
  const double sx = 2 * u - 1, sy = 1 - 2 * v;
  return f.origin +
         (f.forward + f.right * (sx * f.half_width) + f.up * (sy * f.half_height)) * depth;
}

Vec3d move_in_image_plane(const v1::Camera& camera, const Vec3d& position, double u, double v,
                          double fallback_depth) {
  const std::optional<ImagePoint> seen = project(camera, position);
  return point_at(camera, u, v, seen ? seen->depth : fallback_depth);
}

double scene_scale_hint(const v1::Camera& camera) {
  const Vec3d position = to_vec3d(camera.position());
  const double scale = std::max(length(to_vec3d(camera.look_at()) - position), length(position));
  return scale > 0 ? scale : 1.0;
}

v1::Camera orbit(const v1::Camera& camera, double dx, double dy, double pivot_distance) {
  const CameraFrame f = frame_of(camera);
  const Vec3d world_up = normalize(to_vec3d(camera.up()));
  const Vec3d pivot = f.origin + f.forward * pivot_distance;
  Vec3d arm = f.origin - pivot;
  arm = rotate(arm, world_up, -dx * std::numbers::pi);
  // Keeps the view direction at least a few degrees away from the up axis.
  const double limit = std::numbers::pi / 2 - 0.05;
  const double elevation = std::asin(std::clamp(dot(normalize(arm), world_up), -1.0, 1.0));
  const double target = std::clamp(elevation + dy * std::numbers::pi, -limit, limit);
  const Vec3d side = normalize(cross(world_up, arm));
  if (length(side) > 0) arm = rotate(arm, side, -(target - elevation));
  v1::Camera out = camera;
  *out.mutable_position() = to_proto(pivot + arm);
  *out.mutable_look_at() = to_proto(pivot);
  return out;
}

v1::Camera zoom(const v1::Camera& camera, double steps, double pivot_distance) {
  const CameraFrame f = frame_of(camera);
  const Vec3d pivot = f.origin + f.forward * pivot_distance;
  const double distance = std::max(pivot_distance * std::pow(0.9, steps), pivot_distance * 0.01);
  v1::Camera out = camera;
  *out.mutable_position() = to_proto(pivot - f.forward * distance);
  *out.mutable_look_at() = to_proto(pivot);
  return out;
}

}  // namespace caustica::server::viewer
