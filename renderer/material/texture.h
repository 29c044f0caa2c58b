// Textures as the materials read them: RGBA texels in linear light, a chain of mip levels each half
// the one before, looked up bilinearly in a level or trilinearly between two, the level chosen
// from the footprint's width in texture coordinates (what ray differentials or ray cones give).
// The texels live in one array, the levels one after the other, so that a device reads them
// through a view of two pointers (docs/materials.md, "Textures").
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "renderer/base/texture_mapping.h"
#include "renderer/base/vec.h"

namespace caustica {

struct Texel {
  float r = 0, g = 0, b = 0, a = 0;
};

CAUSTICA_HDI Texel lerp(const Texel& p, const Texel& q, float t) {
  return {p.r + (q.r - p.r) * t, p.g + (q.g - p.g) * t, p.b + (q.b - p.b) * t,
          p.a + (q.a - p.a) * t};
}

// The sRGB transfer function's exact inverse (IEC 61966-2-1) and the function itself.
CAUSTICA_HDI float srgb_to_linear(float v) {
  return v <= 0.04045f ? v * (1.0f / 12.92f) : powf((v + 0.055f) * (1.0f / 1.055f), 2.4f);
}
CAUSTICA_HDI float linear_to_srgb(float v) {
  return v <= 0.0031308f ? v * 12.92f : 1.055f * powf(v, 1.0f / 2.4f) - 0.055f;
}

// One mip level's place in the texel array.
struct MipLevel {
  uint32_t offset = 0;  // its first texel's index
  uint32_t width = 0, height = 0;
};

struct TextureView {
  const Texel* texels = nullptr;
  const MipLevel* levels = nullptr;
  uint32_t level_count = 0;
  TextureWrap wrap_u = TextureWrap::kRepeat, wrap_v = TextureWrap::kRepeat;

  // Texel (x, y) of `level`, x and y already wrapped.
  CAUSTICA_HDI const Texel& at(const MipLevel& level, uint32_t x, uint32_t y) const {
    return texels[level.offset + size_t(y) * level.width + x];
  }

  CAUSTICA_HDI static int wrap(int i, int n, TextureWrap mode) {
    switch (mode) {
      case TextureWrap::kClampToEdge:
        return i < 0 ? 0 : (i >= n ? n - 1 : i);
      case TextureWrap::kMirroredRepeat: {
        const int period = 2 * n;
        int m = i % period;
        if (m < 0) m += period;
        return m < n ? m : period - 1 - m;
      }
      case TextureWrap::kRepeat:
        break;
    }
    const int m = i % n;
    return m < 0 ? m + n : m;
  }

  // Bilinear in `level`: texel centres at ((x + 0.5) / width, (y + 0.5) / height).
  CAUSTICA_HDI Texel bilinear(uint32_t level_index, Vec2f uv) const {
    const MipLevel& level = levels[level_index];
    const float x = uv.x * float(level.width) - 0.5f, y = uv.y * float(level.height) - 0.5f;
    const float fx = floorf(x), fy = floorf(y);
    const int x0 = int(fx), y0 = int(fy);
    const float tx = x - fx, ty = y - fy;
    const int w = int(level.width), h = int(level.height);
    const uint32_t xa = uint32_t(wrap(x0, w, wrap_u)), xb = uint32_t(wrap(x0 + 1, w, wrap_u));
    const uint32_t ya = uint32_t(wrap(y0, h, wrap_v)), yb = uint32_t(wrap(y0 + 1, h, wrap_v));
    return lerp(lerp(at(level, xa, ya), at(level, xb, ya), tx),
                lerp(at(level, xa, yb), at(level, xb, yb), tx), ty);
  }

  // Trilinear for a footprint `width` wide in texture coordinates: the level whose texels are that
  // wide, interpolated between the two levels around it; level 0 for footprints narrower than its
  // texels, the last level for ones wider than the texture.
  CAUSTICA_HDI Texel trilinear(Vec2f uv, float width) const {
    const MipLevel& base = levels[0];
    const float texels_wide = width * float(base.width > base.height ? base.width : base.height);
    const float level = texels_wide > 1.0f ? log2f(texels_wide) : 0.0f;
    const float last = float(level_count - 1);
    if (level >= last) return bilinear(level_count - 1, uv);
    const uint32_t below = uint32_t(level);
    const float t = level - float(below);
    const Texel a = bilinear(below, uv);
    return t > 0.0f ? lerp(a, bilinear(below + 1, uv), t) : a;
  }
};

// A texture's texels and mip chain in host memory, the form it is uploaded in.
struct MipChain {
  std::vector<Texel> texels;
  std::vector<MipLevel> levels;
};

// The mip chain of a `width` x `height` image (row-major, linear RGBA): each level
// ceil(half) the size of the one before, down to 1 x 1, each of its texels the mean of the 2 x 2
// texels below it (the last row or column of an odd size counted for both of its texels' halves).
inline MipChain build_mip_chain(uint32_t width, uint32_t height, const std::vector<Texel>& image) {
  MipChain chain;
  chain.texels = image;
  chain.levels.push_back({0, width, height});
  while (chain.levels.back().width > 1 || chain.levels.back().height > 1) {
    const MipLevel below = chain.levels.back();
    const MipLevel level{uint32_t(chain.texels.size()), (below.width + 1) / 2,
                         (below.height + 1) / 2};
    for (uint32_t y = 0; y < level.height; ++y) {
      for (uint32_t x = 0; x < level.width; ++x) {
        Texel sum;
        for (uint32_t dy = 0; dy < 2; ++dy) {
          for (uint32_t dx = 0; dx < 2; ++dx) {
            const uint32_t sx = 2 * x + dx < below.width ? 2 * x + dx : below.width - 1;
            const uint32_t sy = 2 * y + dy < below.height ? 2 * y + dy : below.height - 1;
            const Texel t = chain.texels[below.offset + size_t(sy) * below.width + sx];
            sum = {sum.r + t.r, sum.g + t.g, sum.b + t.b, sum.a + t.a};
          }
        }
        chain.texels.push_back({0.25f * sum.r, 0.25f * sum.g, 0.25f * sum.b, 0.25f * sum.a});
      }
    }
    chain.levels.push_back(level);
  }
  return chain;
}

}  // namespace caustica
