#include "renderer/render/film.h"

#include <cmath>

#include "renderer/parallel/parallel_for.h"

namespace caustica {

Film::Film(Backend& backend, int width, int height)
    : sum_(backend, size_t(width) * height),
      resolved_(backend, 0),
      resolved8_(backend, 0),
      resolved_host_(backend),
      resolved8_host_(backend),
      width_(width),
      height_(height) {
  clear();
}

void Film::clear() {
  sum_.fill_zero();
  passes_ = 0;
}

std::span<const float> Film::resolve_linear() {
  const size_t n = sum_.size();
  resolved_.resize_discard(4 * n);
  const Vec3f* sum = sum_.data();
  float* out = resolved_.data();
  const float scale = passes_ > 0 ? 1.0f / float(passes_) : 0.0f;
  parallel_for(*sum_.backend(), "film_resolve_linear", n, [=] CAUSTICA_HD(size_t i) {
    Vec3f c = sum[i] * scale;
    out[4 * i + 0] = c.x;
    out[4 * i + 1] = c.y;
    out[4 * i + 2] = c.z;
    out[4 * i + 3] = 1.0f;
  });
  return resolved_.download(resolved_host_);
}

std::span<const Rgba8> Film::resolve_srgb8(float exposure_stops) {
  const size_t n = sum_.size();
  resolved8_.resize_discard(n);
  const Vec3f* sum = sum_.data();
  Rgba8* out = resolved8_.data();
  const float scale = passes_ > 0 ? std::exp2(exposure_stops) / float(passes_) : 0.0f;
  parallel_for(*sum_.backend(), "film_resolve_srgb8", n, [=] CAUSTICA_HD(size_t i) {
    Vec3f c = sum[i] * scale;
    auto q = [](float v) { return uint8_t(display_srgb(v) * 255.0f + 0.5f); };
    out[i] = Rgba8{q(c.x), q(c.y), q(c.z), 255};
  });
  return resolved8_.download(resolved8_host_);
}

}  // namespace caustica
