#include "renderer/resident/derived_maps.h"

#include <algorithm>
#include <cmath>

namespace caustica {
namespace {

// The first channel of texel (x, y), linear: 8-bit values over 255, float images as they are.
float first_channel(const DecodedImage& image, uint32_t x, uint32_t y) {
  const size_t i = 4 * (size_t(y) * image.width + x);
  return image.is_float() ? image.rgba32f[i] : float(image.rgba8[i]) / 255.0f;
}

// Index `i` of a row or column of `n` texels, as `wrap` continues it past either end.
uint32_t wrapped(int64_t i, uint32_t n, TextureWrap wrap) {
  const int64_t size = n;
  switch (wrap) {
    case TextureWrap::kRepeat:
      return uint32_t(((i % size) + size) % size);
    case TextureWrap::kMirroredRepeat: {
      const int64_t period = 2 * size;
      const int64_t m = ((i % period) + period) % period;
      return uint32_t(m < size ? m : period - 1 - m);
    }
    case TextureWrap::kClampToEdge:
    default:
      return uint32_t(std::clamp<int64_t>(i, 0, size - 1));
  }
}

// The first channel at (u, v) in [0, 1]^2 (v down the image), bilinear between texel centres,
// clamped at the edges.
float bilinear_first_channel(const DecodedImage& image, float u, float v) {
  const float x = u * float(image.width) - 0.5f, y = v * float(image.height) - 0.5f;
  const float fx = std::floor(x), fy = std::floor(y);
  const float tx = x - fx, ty = y - fy;
  const auto at = [&](float px, float py) {
    return first_channel(image, uint32_t(std::clamp(px, 0.0f, float(image.width - 1))),
                         uint32_t(std::clamp(py, 0.0f, float(image.height - 1))));
  };
  const float top = at(fx, fy) * (1 - tx) + at(fx + 1, fy) * tx;
  const float bottom = at(fx, fy + 1) * (1 - tx) + at(fx + 1, fy + 1) * tx;
  return top * (1 - ty) + bottom * ty;
}

}  // namespace

std::vector<Texel> normals_from_heights(const DecodedImage& heights, float scale,
                                        TextureWrap wrap_u, TextureWrap wrap_v) {
  const uint32_t w = heights.width, h = heights.height;
  std::vector<Texel> texels(size_t(w) * h);
  for (uint32_t y = 0; y < h; ++y) {
    const uint32_t up = wrapped(int64_t(y) - 1, h, wrap_v),
                   down = wrapped(int64_t(y) + 1, h, wrap_v);
    for (uint32_t x = 0; x < w; ++x) {
      const uint32_t left = wrapped(int64_t(x) - 1, w, wrap_u);
      const uint32_t right = wrapped(int64_t(x) + 1, w, wrap_u);
      const float dx =
          0.5f * scale * (first_channel(heights, right, y) - first_channel(heights, left, y));
      // Up the image is against the row index.
      const float dy =
          0.5f * scale * (first_channel(heights, x, up) - first_channel(heights, x, down));
      const float inv = 1.0f / std::sqrt(dx * dx + dy * dy + 1.0f);
      texels[size_t(y) * w + x] = {0.5f * (1.0f - dx * inv), 0.5f * (1.0f - dy * inv),
                                   0.5f * (1.0f + inv), 1.0f};
    }
  }
  return texels;
}

PackedImage packed_metallic_roughness(const DecodedImage* roughness, const DecodedImage* metallic) {
  const auto pixels = [](const DecodedImage* image) {
    return image == nullptr ? uint64_t{0} : uint64_t(image->width) * image->height;
  };
  const DecodedImage& larger = pixels(roughness) >= pixels(metallic) ? *roughness : *metallic;
  PackedImage out;
  out.width = larger.width;
  out.height = larger.height;
  out.texels.resize(size_t(out.width) * out.height);
  const auto channel = [&](const DecodedImage* image, uint32_t x, uint32_t y) {
    if (image == nullptr) return 1.0f;
    if (image == &larger) return first_channel(*image, x, y);
    return bilinear_first_channel(*image, (float(x) + 0.5f) / float(out.width),
                                  (float(y) + 0.5f) / float(out.height));
  };
  for (uint32_t y = 0; y < out.height; ++y)
    for (uint32_t x = 0; x < out.width; ++x)
      out.texels[size_t(y) * out.width + x] = {1.0f, channel(roughness, x, y),
                                               channel(metallic, x, y), 1.0f};
  return out;
}

}  // namespace caustica
