#include "renderer/scene/shapes.h"

#include <cmath>
#include <cstdint>

namespace caustica {
namespace {

constexpr double kPiDouble = 3.14159265358979323846;

void add_triangle(Mesh* mesh, uint32_t a, uint32_t b, uint32_t c) {
  mesh->indices.insert(mesh->indices.end(), {a, b, c});
}

// Point at `radius` from the axis through `center` at azimuth `phi`, measured from +x towards +z.
Vec3f on_circle(Vec3f center, double radius, double phi, double y) {
  return {static_cast<float>(center.x + radius * std::cos(phi)), static_cast<float>(y),
          static_cast<float>(center.z + radius * std::sin(phi))};
}

}  // namespace

Mesh make_quad(const std::array<Vec3f, 4>& corners) {
  Mesh mesh;
  mesh.positions.assign(corners.begin(), corners.end());
  mesh.indices = {0, 1, 2, 0, 2, 3};
  return mesh;
}

size_t sphere_triangle_count(int rings, int segments) {
  return 2 * static_cast<size_t>(segments) * static_cast<size_t>(rings - 1);
}

Mesh make_sphere(Vec3f center, float radius, int rings, int segments) {
  Mesh mesh;
  const uint32_t circles = static_cast<uint32_t>(rings - 1);
  const uint32_t n = static_cast<uint32_t>(segments);
  mesh.positions.reserve(2 + size_t{circles} * n);
  mesh.indices.reserve(3 * sphere_triangle_count(rings, segments));

  // Positions in double so that every vertex is at the radius to float precision.
  mesh.positions.push_back({center.x, center.y + radius, center.z});
  for (uint32_t i = 1; i <= circles; ++i) {
    const double theta = kPiDouble * i / rings;
    const double y = center.y + double{radius} * std::cos(theta);
    for (uint32_t j = 0; j < n; ++j) {
      mesh.positions.push_back(
          on_circle(center, double{radius} * std::sin(theta), 2 * kPiDouble * j / n, y));
    }
  }
  mesh.positions.push_back({center.x, center.y - radius, center.z});

  const uint32_t top = 0;
  const uint32_t bottom = 1 + circles * n;
  auto vertex = [n](uint32_t circle, uint32_t j) { return 1 + (circle - 1) * n + j % n; };
  for (uint32_t j = 0; j < n; ++j) add_triangle(&mesh, top, vertex(1, j + 1), vertex(1, j));
  for (uint32_t i = 1; i < circles; ++i) {
    for (uint32_t j = 0; j < n; ++j) {
      const uint32_t a = vertex(i, j), b = vertex(i, j + 1);
      const uint32_t c = vertex(i + 1, j), d = vertex(i + 1, j + 1);
      add_triangle(&mesh, a, b, d);
      add_triangle(&mesh, a, d, c);
    }
  }
  for (uint32_t j = 0; j < n; ++j)
    add_triangle(&mesh, vertex(circles, j), vertex(circles, j + 1), bottom);
  return mesh;
}

size_t ring_triangle_count(int segments) { return 8 * static_cast<size_t>(segments); }

Mesh make_ring(Vec3f base_center, float inner_radius, float thickness, float height, int segments) {
  Mesh mesh;
  const uint32_t n = static_cast<uint32_t>(segments);
  const double r_in = inner_radius;
  const double r_out = double{inner_radius} + thickness;
  const double y0 = base_center.y;
  const double y1 = double{base_center.y} + height;

  // Four parts, each a strip of n vertex pairs: (bottom, top) for walls, (inner, outer) for annuli.
  enum Part : uint32_t { kOuterWall, kInnerWall, kTop, kBottom, kParts };
  mesh.positions.resize(size_t{kParts} * n * 2);
  mesh.normals.resize(mesh.positions.size());
  auto index = [n](Part part, uint32_t j, uint32_t which) {
    return (part * n + j % n) * 2 + which;
  };
  for (uint32_t j = 0; j < n; ++j) {
    const double phi = 2 * kPiDouble * j / n;
    const Vec3f radial{static_cast<float>(std::cos(phi)), 0, static_cast<float>(std::sin(phi))};
    const Vec3f in_bottom = on_circle(base_center, r_in, phi, y0);
    const Vec3f in_top = on_circle(base_center, r_in, phi, y1);
    const Vec3f out_bottom = on_circle(base_center, r_out, phi, y0);
    const Vec3f out_top = on_circle(base_center, r_out, phi, y1);
    const struct {
      Part part;
      Vec3f first, second, normal;
    } strips[] = {{kOuterWall, out_bottom, out_top, radial},
                  {kInnerWall, in_bottom, in_top, -radial},
                  {kTop, in_top, out_top, {0, 1, 0}},
                  {kBottom, in_bottom, out_bottom, {0, -1, 0}}};
    for (const auto& strip : strips) {
      mesh.positions[index(strip.part, j, 0)] = strip.first;
      mesh.positions[index(strip.part, j, 1)] = strip.second;
      mesh.normals[index(strip.part, j, 0)] = strip.normal;
      mesh.normals[index(strip.part, j, 1)] = strip.normal;
    }
  }

  mesh.indices.reserve(3 * ring_triangle_count(segments));
  for (uint32_t j = 0; j < n; ++j) {
    // Strip quad (a0, a1) at j and (b0, b1) at j + 1. With azimuth growing from +x towards +z,
    // (a0, a1, b0) faces away from the axis for walls and down (-y) for annuli.
    for (Part part : {kOuterWall, kInnerWall, kTop, kBottom}) {
      const uint32_t a0 = index(part, j, 0), a1 = index(part, j, 1);
      const uint32_t b0 = index(part, j + 1, 0), b1 = index(part, j + 1, 1);
      const bool already_outward = part == kOuterWall || part == kBottom;
      if (already_outward) {
        add_triangle(&mesh, a0, a1, b0);
        add_triangle(&mesh, b0, a1, b1);
      } else {
        add_triangle(&mesh, a0, b0, a1);
        add_triangle(&mesh, b0, b1, a1);
      }
    }
  }
  return mesh;
}

}  // namespace caustica
