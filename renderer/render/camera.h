// Pinhole camera rays. Pixel (0, 0) is the top-left corner of the image.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "renderer/base/ray.h"
#include "renderer/scene/scene.h"

namespace caustica {

// An image's rows dealt to `devices` devices in bands of `band_rows` rows, round-robin, so that
// every device gets rows from the whole image and a bright region costs them all alike
// (docs/multi-device.md). Device `device` holds film_rows() of them, its row y being the image's
// image_row(y). One device holds every row as one band.
struct RowBands {
  int band_rows = 1 << 30;
  int devices = 1;
  int device = 0;

  CAUSTICA_HDI int image_row(int film_row) const {
    return (film_row / band_rows) * band_rows * devices + device * band_rows + film_row % band_rows;
  }
  int film_rows(int image_height) const {
    const int stride = band_rows * devices;
    const int whole = image_height / stride, rest = image_height % stride - device * band_rows;
    return whole * band_rows + (rest <= 0 ? 0 : rest < band_rows ? rest : band_rows);
  }
};

struct PinholeCamera {
  Vec3f origin, forward, right, up;  // right and up scaled to the image plane at distance 1
  // The film's size in pixels: the whole image, or on one of several devices its rows' share.
  int width, height;
  int image_height;  // the whole image's rows
  RowBands bands;

  static PinholeCamera from(const Camera& c) {
    PinholeCamera p;
    p.origin = c.position;
    p.forward = normalize(c.look_at - c.position);
    Vec3f r = normalize(cross(p.forward, c.up));
    Vec3f u = cross(r, p.forward);
    float tan_half = std::tan(0.5f * c.vertical_fov_deg * kPi / 180.0f);
    float aspect = float(c.width) / float(c.height);
    p.right = r * (tan_half * aspect);
    p.up = u * tan_half;
    p.width = c.width;
    p.height = c.height;
    p.image_height = c.height;
    return p;
  }

  // This camera narrowed to the rows `bands` deals one device.
  PinholeCamera with_bands(const RowBands& b) const {
    PinholeCamera p = *this;
    p.bands = b;
    p.height = b.film_rows(image_height);
    return p;
  }

  // Ray through film position (x, y) in pixels, continuous.
  CAUSTICA_HDI Ray ray_through(float x, float y) const {
    const float row = floorf(y);
    return ray_through_image(x, float(bands.image_row(int(row))) + (y - row));
  }

  // Film pixel `pixel`'s ray through the point (jx, jy) inside it, in [0, 1)^2. The offset is
  // added to the pixel's place in the whole image, so that every device rounds it alike.
  // The angle one pixel spans at the image's centre: a camera ray cone's width per unit of
  // distance (surface_color).
  CAUSTICA_HDI float pixel_spread() const { return 2.0f * length(up) / float(image_height); }

  CAUSTICA_HDI Ray pixel_ray(size_t pixel, float jx, float jy) const {
    return ray_through_image(float(pixel % size_t(width)) + jx,
                             float(bands.image_row(int(pixel / size_t(width)))) + jy);
  }

  // Ray through position (x, y) of the whole image.
  CAUSTICA_HDI Ray ray_through_image(float x, float y) const {
    float sx = 2.0f * x / float(width) - 1.0f;
    float sy = 1.0f - 2.0f * y / float(image_height);
    Ray r;
    r.origin = origin;
    r.direction = normalize(forward + right * sx + up * sy);
    return r;
  }

  // The sample stream of film pixel `pixel`: its index in the whole image, so that a pixel draws
  // the same samples whichever device renders it.
  CAUSTICA_HDI uint32_t stream(size_t pixel) const {
    return uint32_t(size_t(bands.image_row(int(pixel / size_t(width)))) * size_t(width) +
                    pixel % size_t(width));
  }
};

}  // namespace caustica
