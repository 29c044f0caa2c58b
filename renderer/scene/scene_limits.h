// Upper bounds on what a scene may ask for. They keep a typo or a hostile file from requesting
// absurd memory or time; loaders check them before allocating, validation checks them again.
#pragma once

#include <cstddef>
#include <cstdint>

namespace caustica {

inline constexpr int kMaxImageSide = 16384;
inline constexpr uint32_t kMaxPhotonsPerPass = 100'000'000;
inline constexpr uint32_t kMaxNearestPhotons = 1024;
inline constexpr uint32_t kMaxDepth = 64;
inline constexpr uint32_t kMaxPhotonBounces = 64;
inline constexpr uint32_t kMaxAreaLightSamples = 1024;
inline constexpr uint32_t kMaxPasses = 100'000;
// A kernel s times a footprint wide covers s^2 of them; beyond 100 every kernel is the scene.
inline constexpr float kMaxVkdeSpread = 100.0f;
inline constexpr uint32_t kMaxFinalGatherRays = 4096;
inline constexpr uint32_t kMaxFinalGatherSeeds = 1 << 20;
// A Phong lobe this narrow is a mirror to within float precision; larger exponents are typos.
inline constexpr float kMaxPhongExponent = 1e6f;
// A normal map's x and y scaled beyond this bend every normal to the tangent plane; larger scales
// are typos.
inline constexpr float kMaxNormalScale = 100.0f;
// A height map's steps are a few hundredths of its range per texel; a scale beyond this bends
// every derived normal to the tangent plane.
inline constexpr float kMaxBumpScale = 1000.0f;
#ifdef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
// The fuzz preset (fuzz/): a few bytes of scene may legally ask for a 100M-triangle sphere, which
// would exceed a fuzzer's memory and time per input and be reported as a finding. Meshes a fuzzer
// can afford keep the same checks meaningful.
inline constexpr size_t kMaxTrianglesPerMesh = size_t{1} << 20;
inline constexpr size_t kMaxVerticesPerMesh = size_t{1} << 20;
#else
inline constexpr size_t kMaxTrianglesPerMesh = 100'000'000;
inline constexpr size_t kMaxVerticesPerMesh = 100'000'000;
#endif
// All meshes together: the triangle structure's leaves address the sorted triangles with 28 bits
// (kMaxBvh4Triangles in accel/bvh4.h; resident_scene.cc checks that the two agree).
inline constexpr size_t kMaxSceneTriangles = size_t{1} << 28;
// What a (possibly compressed) file may expand to in memory; stops gzip bombs.
inline constexpr size_t kMaxFileBytes = size_t{8} << 30;
// The largest density grid one medium may hold, as its NanoVDB buffer.
inline constexpr size_t kMaxGridBytes = size_t{4} << 30;
// Texture images: how many one scene may reference, the largest file, the widest side and what one
// may decode to (an image is refused before its pixels are allocated).
inline constexpr size_t kMaxTextures = 4096;
inline constexpr size_t kMaxTextureFileBytes = size_t{256} << 20;
#ifdef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
inline constexpr uint32_t kMaxTextureSide = 2048;
#else
inline constexpr uint32_t kMaxTextureSide = 16384;
#endif
inline constexpr size_t kMaxTextureDecodedBytes = size_t{1} << 30;

}  // namespace caustica
