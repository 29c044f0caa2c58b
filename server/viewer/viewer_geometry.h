// The viewer's image-plane geometry: where a light appears in the picture, where a drag moves it,
// and the camera's orbit and zoom. Image coordinates (u, v) run from (0, 0) at the picture's
// top-left corner to (1, 1) at its bottom-right, as the renderer's pinhole camera lays pixels out
// (renderer/render/camera.h).
#pragma once

#include <optional>

#include "caustica/v1/scene.pb.h"

namespace caustica::server::viewer {

struct Vec3d {
  double x = 0, y = 0, z = 0;
};

// A world point seen by the camera: its image position and its depth along the view axis.
struct ImagePoint {
  double u = 0, v = 0;
  double depth = 0;
};

Vec3d to_vec3d(const v1::Vec3& v);
v1::Vec3 to_proto(const Vec3d& v);

// The image position of `point`, or nullopt when it lies on or behind the camera's plane.
std::optional<ImagePoint> project(const v1::Camera& camera, const Vec3d& point);

// The world point at image position (u, v) and depth `depth` along the view axis.
Vec3d point_at(const v1::Camera& camera, double u, double v, double depth);

// Moves `position` within the camera's image plane at its own depth so that it appears at
// (u, v). A point on or behind the camera's plane is first brought to `fallback_depth`.
Vec3d move_in_image_plane(const v1::Camera& camera, const Vec3d& position, double u, double v,
                          double fallback_depth);

// A length on the scale of the scene, for placing things the API cannot tell us about: the
// larger of the camera's distances to its look-at point and to the world origin. The API has no
// scene bounds, and bundled scenes either look at their middle or are modelled around the origin.
double scene_scale_hint(const v1::Camera& camera);

// Turns the camera around the point `pivot_distance` ahead of it: `dx` of the image width turns
// it half a circle about the up axis, `dy` of the image height half a circle upwards (stopping
// short of the poles, where the up vector would be lost).
v1::Camera orbit(const v1::Camera& camera, double dx, double dy, double pivot_distance);

// Moves the camera towards (steps > 0) or away from the point `pivot_distance` ahead of it, by a
// tenth of the distance per step, never closer than a hundredth of it.
v1::Camera zoom(const v1::Camera& camera, double steps, double pivot_distance);

}  // namespace caustica::server::viewer
