// The film: per-pixel sums of radiance over progressive passes, and its resolution into linear
// RGBA float or tone-mapped sRGB 8-bit pixels (exposure, then the sRGB transfer curve).
#pragma once

#include <cstdint>
#include <span>

#include "renderer/base/vec.h"
#include "renderer/material/texture.h"
#include "renderer/parallel/buffer.h"

namespace caustica {

struct Rgba8 {
  uint8_t r, g, b, a;
};

class Film {
 public:
  Film() = default;
  Film(Backend& backend, int width, int height);

  void clear();
  Vec3f* accumulator() { return sum_.data(); }
  void add_pass() { ++passes_; }
  uint32_t passes() const { return passes_; }
  int width() const { return width_; }
  int height() const { return height_; }
  size_t bytes() const { return sum_.bytes() + resolved_.bytes(); }

  // The resolved image in host memory the film keeps (page-locked on a GPU) and overwrites at its
  // next resolve. Mean radiance per pixel as linear RGBA float (alpha 1), row-major from the
  // top-left.
  std::span<const float> resolve_linear();
  // Exposure in stops, then sRGB encoding to 8 bits.
  std::span<const Rgba8> resolve_srgb8(float exposure_stops = 0.0f);

 private:
  Buffer<Vec3f> sum_;
  Buffer<float> resolved_;
  Buffer<Rgba8> resolved8_;
  HostBuffer<float> resolved_host_;
  HostBuffer<Rgba8> resolved8_host_;
  int width_ = 0, height_ = 0;
  uint32_t passes_ = 0;
};

// A displayed value: `v` clamped to [0, 1] and sRGB-encoded (material/texture.h's transfer).
CAUSTICA_HDI float display_srgb(float v) { return linear_to_srgb(min_f(max_f(v, 0.0f), 1.0f)); }

}  // namespace caustica
