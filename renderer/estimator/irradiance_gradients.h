// A final-gathering seed's irradiance from its gather rays, with what interpolation needs to carry
// it to other points: Ward's validity radius and Ward and Heckbert's (1992) irradiance gradients
// for rays stratified over a grid in (sin^2 theta, phi). docs/convergence.md ("Irradiance
// gradients") derives the terms.
#pragma once

#include <cstdint>
#include <vector>

#include "renderer/base/sampling.h"
#include "renderer/base/vec.h"

namespace caustica {

struct SeedRecord {
  Vec3f irradiance;
  Vec3f rotation[3];     // d irradiance / d (rotation of the normal about each world axis), RGB
  Vec3f translation[3];  // d irradiance / d (position along each world axis), RGB
  float radius;          // how far the irradiance may be carried (Ward's R)
};

// Adds `rgb` times the world vector `v` to a gradient.
CAUSTICA_HDI void add_gradient(Vec3f* gradient, Vec3f v, Vec3f rgb) {
  for (int a = 0; a < 3; ++a) gradient[a] += rgb * v[a];
}

// What one column of a seed's rays (one azimuth cell k, every cell of theta) adds to its record,
// so that a seed's columns can be summed by as many threads.
struct SeedColumn {
  Vec3f radiance;  // the sum over the column's rays
  Vec3f rotation[3];
  Vec3f translation[3];
  float inverse_distances;  // the sum of 1 / distance
  float shortest;           // the nearest first hit
};

// Column k of a seed with `count` cosine-distributed rays around `normal`: radiance(r) is what ray
// r brought back and distance(r) how far its first hit was (infinite where it found none). With
// side != 0, count = side * side and ray r = j + k * side sampled cell j of sin^2(theta) and k of
// phi (phi from the Frame::from_normal tangent towards its bitangent); the column also reads the
// column before it, across its first edge. With side == 0 there is one column, every ray, and no
// gradients.
template <typename Radiance, typename Distance>
CAUSTICA_HDI SeedColumn seed_column(uint32_t k, uint32_t count, uint32_t side, Vec3f normal,
                                    Radiance radiance, Distance distance) {
  SeedColumn out{};
  out.shortest = INFINITY;
  const uint32_t first = side == 0 ? 0u : k * side, rays = side == 0 ? count : side;
  for (uint32_t r = first; r < first + rays; ++r) {
    out.radiance += radiance(r);
    out.inverse_distances += 1.0f / distance(r);
    out.shortest = fminf(out.shortest, distance(r));
  }
  if (side == 0) return out;

  const Frame frame = Frame::from_normal(normal);
  const float cells = float(side);
  const float azimuth_mean = sinf(kPi / cells) / (kPi / cells);
  const float phi = 2.0f * kPi * (float(k) + 0.5f) / cells;
  const float phi_edge = 2.0f * kPi * float(k) / cells;
  const Vec3f along = frame.to_world(Vec3f(cosf(phi), sinf(phi), 0.0f));
  const Vec3f across = frame.to_world(Vec3f(-sinf(phi), cosf(phi), 0.0f));
  const Vec3f across_edge = frame.to_world(Vec3f(-sinf(phi_edge), cosf(phi_edge), 0.0f));
  const uint32_t k_before = (k + side - 1) % side;
  // theta - sin(theta) cos(theta) and sin(theta) at the cell's lower edge, and the radiance and
  // distance of the cell below, carried up the column.
  float tan_integral_edge = 0.0f, sin_edge = 0.0f;
  Vec3f l_below(0.0f);
  float d_below = INFINITY;
  for (uint32_t j = 0; j < side; ++j) {
    const uint32_t r = j + k * side;
    const Vec3f l = radiance(r);
    const float d_here = distance(r);
    const float sin2_edge = float(j) / cells, sin2_next = float(j + 1) / cells;
    const float sin_next = sqrtf(sin2_next), theta_next = asinf(fminf(sin_next, 1.0f));
    const float tan_integral_next = theta_next - sin_next * sqrtf(fmaxf(0.0f, 1.0f - sin2_next));
    // Rotation: n x w over the cosine pdf is tan(theta) across the azimuth, taken as its mean
    // over the cell, theta - sin(theta) cos(theta) between the cell's edges times side, and
    // sinc(pi / side) along the middle azimuth; tan(theta) at the cell's middle would fall 10%
    // short near the horizon, where it grows fastest.
    const float mean_tan = cells * (tan_integral_next - tan_integral_edge);
    add_gradient(out.rotation, across, l * (mean_tan * azimuth_mean * kPi / float(count)));
    // Translation: the light that crosses the cell's edge towards the zenith as the point moves
    // along the azimuth...
    if (j > 0) {
      const float w = (2.0f * kPi / cells) * sin_edge * (1.0f - sin2_edge) / fminf(d_here, d_below);
      add_gradient(out.translation, along, (l - l_below) * w);
    }
    // ...and that which crosses its edge at the smaller azimuth as it moves across.
    const uint32_t o = j + k_before * side;
    const float d = fminf(d_here, distance(o));
    add_gradient(out.translation, across_edge, (l - radiance(o)) * ((sin_next - sin_edge) / d));
    tan_integral_edge = tan_integral_next;
    sin_edge = sin_next;
    l_below = l;
    d_below = d_here;
  }
  return out;
}

// A seed's record from its `columns` columns (seed_column; side of them, or one without a grid).
// R is the rays' harmonic mean distance clamped to [nearest, farthest], and no more than where the
// translation would take any channel to zero (Krivanek et al. 2008), but not below nearest.
CAUSTICA_HDI SeedRecord seed_record_of(const SeedColumn* column, uint32_t columns, uint32_t count,
                                       float nearest, float farthest) {
  SeedRecord out{};
  float inverse_distances = 0.0f, shortest = INFINITY;
  for (uint32_t k = 0; k < columns; ++k) {
    out.irradiance += column[k].radiance;
    for (int a = 0; a < 3; ++a) {
      out.rotation[a] += column[k].rotation[a];
      out.translation[a] += column[k].translation[a];
    }
    inverse_distances += column[k].inverse_distances;
    shortest = fminf(shortest, column[k].shortest);
  }
  out.irradiance = out.irradiance * (kPi / float(count));
  const float harmonic = inverse_distances > 0.0f ? float(count) / inverse_distances : farthest;
  out.radius = fminf(fmaxf(harmonic, nearest), farthest);
  // A ray that hit something nearer than `nearest` would make the gradient as steep as its
  // distance is short; scaled back, it is as steep as at `nearest` (Krivanek et al. 2008).
  if (shortest < nearest)
    for (int a = 0; a < 3; ++a) out.translation[a] = out.translation[a] * (shortest / nearest);
  for (int c = 0; c < 3; ++c) {
    const float g =
        length(Vec3f(out.translation[0][c], out.translation[1][c], out.translation[2][c]));
    if (g > 0.0f && out.irradiance[c] > 0.0f) out.radius = fminf(out.radius, out.irradiance[c] / g);
  }
  out.radius = fmaxf(out.radius, nearest);
  return out;
}

// The whole record in one thread, column by column, on the host (for tests).
template <typename Radiance, typename Distance>
SeedRecord seed_record(uint32_t count, uint32_t side, Vec3f normal, float nearest, float farthest,
                       Radiance radiance, Distance distance) {
  std::vector<SeedColumn> columns(side == 0 ? 1u : side);
  for (uint32_t k = 0; k < columns.size(); ++k)
    columns[k] = seed_column(k, count, side, normal, radiance, distance);
  return seed_record_of(columns.data(), uint32_t(columns.size()), count, nearest, farthest);
}

// The record's irradiance carried from its seed (position, normal) to `position` with `normal`:
// its own plus the gradients' first-order change, never below zero. A point beyond R (which
// interpolation reads only where no seed is valid) takes the change at R's distance: the gradient
// is not to be trusted farther than the irradiance.
CAUSTICA_HDI Vec3f extrapolated(const SeedRecord& r, Vec3f seed_position, Vec3f seed_normal,
                                Vec3f position, Vec3f normal) {
  const Vec3f turn = cross(seed_normal, normal);
  Vec3f move = position - seed_position;
  const float distance = length(move);
  if (distance > r.radius) move = move * (r.radius / distance);
  Vec3f e = r.irradiance;
  for (int a = 0; a < 3; ++a) e += r.rotation[a] * turn[a] + r.translation[a] * move[a];
  return Vec3f(fmaxf(e.x, 0.0f), fmaxf(e.y, 0.0f), fmaxf(e.z, 0.0f));
}

}  // namespace caustica
