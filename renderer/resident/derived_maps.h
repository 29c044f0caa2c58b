// Maps derived at upload from what a model file gives, so that kernels read one kind of map for
// each job: a tangent-space normal map from a height (bump) map, and one packed
// metallic-roughness map from separate roughness and metalness maps (docs/materials.md, "Derived
// maps").
#pragma once

#include <cstdint>
#include <vector>

#include "renderer/base/texture_mapping.h"
#include "renderer/material/texture.h"
#include "renderer/scene/scene.h"

namespace caustica {

// The normals of the surface whose height at each texel is `scale` times the first channel of
// `heights` (linear), in units of a texel's width, from central differences that wrap as the map
// does: (-dh/dx, -dh/dy, 1) normalized, x along the texture's u and y up its image, encoded as
// (n + 1) / 2 for a normal map of scale 1.
std::vector<Texel> normals_from_heights(const DecodedImage& heights, float scale,
                                        TextureWrap wrap_u, TextureWrap wrap_v);

// glTF's packed layout of separate maps, green the roughness map's first channel and blue the
// metalness map's (1 where a map is missing), at the size of the larger image, the smaller
// sampled bilinearly at the same place. At least one of the two must be given.
struct PackedImage {
  uint32_t width = 0, height = 0;
  std::vector<Texel> texels;
};
PackedImage packed_metallic_roughness(const DecodedImage* roughness, const DecodedImage* metallic);

}  // namespace caustica
