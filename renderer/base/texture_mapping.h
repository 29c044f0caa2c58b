// How a surface point's texture coordinates become a place in an image: glTF's sampler wrap
// modes and KHR_texture_transform. A leaf, so that the scene model and the device lookups
// (material/texture.h) share them.
#pragma once

#include <cmath>
#include <cstdint>

#include "renderer/base/vec.h"

namespace caustica {

// What a coordinate outside [0, 1) reads (glTF's sampler wrap modes).
enum class TextureWrap : uint32_t { kRepeat, kClampToEdge, kMirroredRepeat };

// KHR_texture_transform: uv' = T(offset) R(rotation) S(scale) uv, with the extension's rotation
// matrix (columns (cos, sin) and (-sin, cos)).
struct TextureTransform {
  Vec2f offset{0.0f, 0.0f};
  float rotation = 0.0f;
  Vec2f scale{1.0f, 1.0f};

  CAUSTICA_HDI Vec2f apply(Vec2f uv) const {
    const float c = cosf(rotation), s = sinf(rotation);
    const float x = uv.x * scale.x, y = uv.y * scale.y;
    return {c * x - s * y + offset.x, s * x + c * y + offset.y};
  }
};

}  // namespace caustica
