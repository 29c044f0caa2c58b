// The scene model on the host: what loaders produce, validation checks and the engine uploads.
// Units are the scene's own (the bundled Cornell boxes use millimetres); colours are linear RGB.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "renderer/accel/build_options.h"
#include "renderer/accel/structure_kind.h"
#include "renderer/base/texture_mapping.h"
#include "renderer/base/vec.h"
#include "renderer/scene/affine.h"
#include "renderer/scene/setting_kinds.h"

namespace caustica {

// How a surface scatters (docs/materials.md): the first four kinds, glTF's metallic-roughness
// model and the modified Phong model (a Lambertian and a glossy lobe, as the seed's).
enum class MaterialType : uint32_t {
  kDiffuse = 0,
  kMirror = 1,
  kDielectric = 2,  // smooth glass when `roughness` is 0, rough (GGX) glass otherwise
  kEmissive = 3,
  kMetallicRoughness = 4,
  kPhong = 5,
};
inline constexpr MaterialType kLastMaterialType = MaterialType::kPhong;

// How a surface's opacity applies (glTF's alphaMode): not at all, as a cut-out where it falls
// below the material's cutoff, or as the chance that a ray stops there (stochastic
// transparency, docs/materials.md, "Cut-outs and transparency").
enum class AlphaMode : uint32_t {
  kOpaque = 0,
  kMask = 1,
  kBlend = 2,
};
inline constexpr AlphaMode kLastAlphaMode = AlphaMode::kBlend;

// No texture: a TextureRef's `texture` when the material's factor stands alone.
inline constexpr uint32_t kNoTexture = 0xffffffffu;

// An image decoded: 8-bit RGBA as the file stored it (colour maps are sRGB-encoded, the rest
// linear), or 32-bit float RGBA in linear light for Radiance HDR and OpenEXR. Rows top to bottom.
struct DecodedImage {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgba8;
  std::vector<float> rgba32f;
  bool has_alpha = false;  // whether the file stored an alpha channel (else alpha is 1)
  bool is_float() const { return !rgba32f.empty(); }
  size_t bytes() const { return rgba8.size() + rgba32f.size() * sizeof(float); }
};

// A texture image as a model file referenced it: its file's bytes (PNG, JPEG, TGA, Radiance HDR or
// OpenEXR), which travel to the server as they are and are decoded there (texture_decode.h).
// Shared, as grids are, because scenes are copied and images are large.
struct TextureImage {
  std::string name;  // file name or the model's image name, for messages
  std::shared_ptr<const std::string> encoded;
  std::shared_ptr<const DecodedImage> decoded;  // set by decode_textures
};

// One texture a material reads: an index into Scene::textures (kNoTexture for none), how
// coordinates outside [0, 1) wrap, and KHR_texture_transform.
struct TextureRef {
  uint32_t texture = kNoTexture;
  TextureWrap wrap_u = TextureWrap::kRepeat, wrap_v = TextureWrap::kRepeat;
  TextureTransform transform;
  bool used() const { return texture != kNoTexture; }
  // Whether `other` reads its image at the same coordinates: same wrap modes and transform.
  bool samples_like(const TextureRef& other) const {
    const TextureTransform &s = transform, &t = other.transform;
    return wrap_u == other.wrap_u && wrap_v == other.wrap_v && s.offset.x == t.offset.x &&
           s.offset.y == t.offset.y && s.scale.x == t.scale.x && s.scale.y == t.scale.y &&
           s.rotation == t.rotation;
  }
};

struct Material {
  std::string name;
  MaterialType type = MaterialType::kDiffuse;
  // Diffuse albedo, mirror reflectance, metallic-roughness base colour or Phong's diffuse colour
  // (each channel in [0, 1]).
  Vec3f color{0.8f, 0.8f, 0.8f};
  float ior = 1.5f;  // dielectric index of refraction (outside medium is vacuum)
  // Metallic-roughness: glTF's metalness and perceptual roughness (GGX alpha = roughness^2), each
  // in [0, 1]. A dielectric's roughness likewise, 0 for smooth glass.
  float metallic = 0.0f;
  float roughness = 0.0f;
  // Phong: the glossy lobe's colour (color + specular <= 1 in every channel conserves energy) and
  // its exponent (> 0).
  Vec3f specular{0.0f, 0.0f, 0.0f};
  float exponent = 20.0f;
  // Outgoing radiance of the front face. An emissive material's surface is black; another kind
  // given an emission (glTF's emissive factor, MTL's Ke) emits and reflects.
  Vec3f radiance{0, 0, 0};
  bool off = false;  // emits nothing for now, `radiance` kept for later
  // Maps of the model file, multiplying `color` (sRGB-encoded) and `radiance` (sRGB-encoded, as
  // glTF's emissive texture) where the mesh has texture coordinates.
  TextureRef color_map;
  TextureRef emission_map;
  // glTF's metallicRoughnessTexture, linear: its green channel multiplies `roughness`, its blue
  // `metallic` (metallic-roughness materials only).
  TextureRef metallic_roughness_map;
  // The same two as separate linear maps, their first channels multiplying `roughness` and
  // `metallic` (MTL's map_Pr and map_Pm, an FBX file's roughness and metalness maps); packed into
  // one at upload (docs/materials.md, "Derived maps"). Either excludes metallic_roughness_map.
  TextureRef roughness_map;
  TextureRef metallic_map;
  // A tangent-space normal map (glTF's normalTexture, MTL's norm), linear, any type: its texel c
  // bends the shading normal to (2 c - 1) with x and y times `normal_scale`, x along the texture's
  // u and y up its image (docs/materials.md, "Normal maps").
  TextureRef normal_map;
  float normal_scale = 1.0f;
  // A height map (MTL's bump, a 3DS or Assimp height map), linear, any type: its first channel is
  // a height, `bump_scale` times its value in units of a texel's width, from which a normal map is
  // derived at upload (docs/materials.md, "Derived maps"). A normal map, where both are given,
  // takes precedence.
  TextureRef bump_map;
  float bump_scale = 1.0f;
  // Opacity in [0, 1] (glTF's base colour alpha, MTL's map_d), times its map's alpha channel
  // where the map's image has one, else its first (a grey dissolve map), applied as
  // `alpha_mode` says; a mask cuts out where it is below `alpha_cutoff`. Any type may have it.
  AlphaMode alpha_mode = AlphaMode::kOpaque;
  float opacity = 1.0f;
  float alpha_cutoff = 0.5f;
  TextureRef opacity_map;

  // Every map with its field's name, for what treats them alike.
  std::array<std::pair<TextureRef*, const char*>, 8> maps() {
    return {{{&color_map, "color_map"},
             {&emission_map, "emission_map"},
             {&metallic_roughness_map, "metallic_roughness_map"},
             {&roughness_map, "roughness_map"},
             {&metallic_map, "metallic_map"},
             {&normal_map, "normal_map"},
             {&bump_map, "bump_map"},
             {&opacity_map, "opacity_map"}}};
  }
  std::array<std::pair<const TextureRef*, const char*>, 8> maps() const {
    auto all = const_cast<Material*>(this)->maps();
    std::array<std::pair<const TextureRef*, const char*>, 8> out;
    for (size_t i = 0; i < all.size(); ++i) out[i] = {all[i].first, all[i].second};
    return out;
  }
  // Whether a ray may pass through some of the surface.
  bool has_cutouts() const {
    return alpha_mode != AlphaMode::kOpaque && (opacity < 1.0f || opacity_map.used());
  }
};

// Whether a material's triangles are area lights: an emissive material's always, so that one off
// or dark now can be turned on; another kind's when it was given an emission.
inline bool is_emitter(const Material& m) {
  return m.type == MaterialType::kEmissive || !is_black(m.radiance);
}

// What a material emits now.
inline Vec3f emitted_radiance(const Material& m) {
  return is_emitter(m) && !m.off ? m.radiance : Vec3f{0, 0, 0};
}

// A change to an emitting material's emission (UpdateLights' emitters); unset fields keep theirs.
struct EmitterChange {
  std::string material;  // the material's name
  std::optional<Vec3f> radiance;
  std::optional<bool> off;
};

// A change to one mesh (UpdateGeometry, Engine::set_geometry): where it stands and what its
// vertices are. Unset fields keep theirs.
struct MeshChange {
  std::string mesh;  // the mesh's name (Mesh::name), as SceneInfo lists it
  // Where the mesh stands now: the map from its vertices as uploaded (or as last replaced) to the
  // scene, replacing the one before (identity at upload). Normals turn with it.
  std::optional<Affine> transform;
  // New vertices, as many as the mesh has, in the same order (the triangles stay). They drop the
  // mesh's tangents, and its shading normals unless `normals` come with them: neither fits any
  // more.
  std::optional<std::vector<Vec3f>> positions;
  std::optional<std::vector<Vec3f>> normals;
};

enum class MediumType : uint32_t { kHomogeneous = 0, kGrid = 1 };

// Bytes kept 32-byte aligned, as NanoVDB wants the buffer of a grid.
class AlignedBytes {
 public:
  explicit AlignedBytes(size_t size) : blocks_((size + 31) / 32), size_(size) {}
  uint8_t* data() { return blocks_.empty() ? nullptr : blocks_.front().bytes; }
  const uint8_t* data() const { return blocks_.empty() ? nullptr : blocks_.front().bytes; }
  size_t size() const { return size_; }

 private:
  struct alignas(32) Block {
    uint8_t bytes[32];
  };
  std::vector<Block> blocks_;
  size_t size_;
};

// No medium: vacuum, where light travels unchanged.
inline constexpr uint32_t kNoMedium = 0xffffffffu;

// A participating medium (docs/scene-format.md, "Media"): per channel, the absorption and the
// scattering coefficients (per unit of the scene's length), scattered by the Henyey-Greenstein
// phase function of asymmetry g. A grid medium scales both by the density its grid holds at each
// point, and is empty outside the grid.
struct Medium {
  std::string name;
  MediumType type = MediumType::kHomogeneous;
  Vec3f absorption{0, 0, 0};  // a grid medium's: per unit of density
  Vec3f scattering{0, 0, 0};
  float asymmetry = 0;  // g in (-1, 1): mean cosine of the scattering angle
  // kGrid: one NanoVDB float grid as its buffer (density_grid.h reads and checks it), shared
  // because scenes are copied and grids are large; where it came from, for messages; and where
  // it stands: a point p of the grid's own space is at grid_to_scene(p) in the scene.
  std::shared_ptr<const AlignedBytes> grid;
  std::string grid_source;
  Affine grid_to_scene;
};

// One triangle mesh; every triangle refers to a material by index into Scene::materials.
struct Mesh {
  std::string name;  // file name or shape name, for error messages
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;          // optional: per-vertex shading normals
  std::vector<Vec2f> uvs;              // optional: per-vertex texture coordinates
  // Optional, with normals only: per-vertex tangents, xyz a unit vector and w the bitangent's
  // sign (bitangent = w * cross(normal, tangent)), as glTF's TANGENT.
  std::vector<Vec4f> tangents;
  std::vector<uint32_t> indices;       // 3 per triangle
  std::vector<uint32_t> material_ids;  // 1 per triangle
  // The medium this mesh encloses (an index into Scene::media), or kNoMedium. A mesh that
  // encloses one must be closed.
  uint32_t interior_medium = kNoMedium;
  size_t triangle_count() const { return indices.size() / 3; }
};

enum class LightType : uint32_t { kPoint = 0, kSpot = 1, kDirectional = 2 };

// A light that is not geometry. Area lights are the triangles of emissive materials.
struct Light {
  std::string name;
  LightType type = LightType::kPoint;
  Vec3f position{0, 0, 0};     // point, spot
  Vec3f direction{0, -1, 0};   // spot axis, or the direction a directional light travels
  Vec3f intensity{1, 1, 1};    // point/spot: W/sr per channel; directional: irradiance W/m^2
  float inner_angle_deg = 30;  // spot: full intensity inside this half-angle
  float outer_angle_deg = 45;  // spot: zero outside this half-angle (smoothstep between)
};

// Light from all around the scene (docs/scene-format.md, "Environment"): radiance `color` times
// `intensity` from every direction, each multiplied by an equirectangular image of radiance when
// `texture` names one (an index into Scene::textures, linear for Radiance HDR and OpenEXR, sRGB for
// 8-bit images), row 0 the zenith (+y), turned by `rotation_deg` about +y. Camera rays that miss
// see it, shadow rays sample it and photons come from it. Intensity and rotation change with the
// lights.
struct Environment {
  bool present = false;
  uint32_t texture = kNoTexture;
  Vec3f color{1, 1, 1};
  float intensity = 1;
  float rotation_deg = 0;
};

// A change to the environment's intensity or rotation (UpdateLights); unset fields keep theirs.
struct EnvironmentChange {
  std::optional<float> intensity;
  std::optional<float> rotation_deg;
};

struct Camera {
  Vec3f position{0, 0, 1};
  Vec3f look_at{0, 0, 0};
  Vec3f up{0, 1, 0};
  float vertical_fov_deg = 45;
  int width = 512;
  int height = 512;
};

struct RenderSettings {
  uint32_t photons_per_pass = 200000;  // photons emitted per pass (global and caustic together)
  uint32_t k_nearest = 64;             // photons per radiance estimate
  float max_radius = 0;                // gather radius cap; 0 = 5% of the scene's diagonal
  DensityKernel kernel = DensityKernel::kEpanechnikov;
  Integrator integrator = Integrator::kPhoton;
  // How the photon integrator turns photons into radiance (estimator/estimator.h).
  EstimatorKind estimator = EstimatorKind::kKnn;
  float sppm_alpha = 0.7f;  // the fraction of new photons SPPM keeps as its radii shrink
  SppmRadius sppm_radius = SppmRadius::kPixel;
  float vkde_spread = 0;  // VKDE's spread factor s; 0 = sqrt(k_nearest / (2 pi))
  // Final gathering for knn's indirect light (estimator/final_gather.h), its rays per seed.
  bool final_gather = false;
  uint32_t final_gather_rays = 256;
  uint32_t final_gather_seeds = 0;  // per pass; 0 = 4096, at most one a pixel
  // Caps on path length, safety nets only: Russian roulette ends camera branches by their
  // throughput and photon paths by their surfaces' albedo long before (docs/convergence.md).
  uint32_t max_depth = 64;           // specular bounces of camera rays
  uint32_t max_photon_bounces = 64;  // surface interactions of a photon path
  // Mirror and glass bounces in a row of a photon path: the one cap that is no safety net, for
  // light trapped by total internal reflection (docs/convergence.md, "Path length").
  uint32_t max_photon_specular_bounces = 12;
  uint32_t area_light_samples = 4;   // shadow rays per diffuse hit for area lights
  uint32_t passes = 1;               // progressive passes, fresh photons each
  uint32_t seed = 1;
  // The triangle structure rays are traced through, and what its builder is told; changing
  // either rebuilds the geometry's structure.
  StructureKind structure = kDefaultStructure;
  BuildOptions build;
};

struct Scene {
  std::vector<Material> materials;
  std::vector<TextureImage> textures;  // what the materials' maps index
  std::vector<Medium> media;
  // The medium everywhere outside the meshes that enclose one (an index into media), or
  // kNoMedium.
  uint32_t medium = kNoMedium;
  std::vector<Mesh> meshes;
  std::vector<Light> lights;
  Environment environment;
  Camera camera;
  RenderSettings settings;

  size_t triangle_count() const {
    size_t n = 0;
    for (const Mesh& m : meshes) n += m.triangle_count();
    return n;
  }
};

}  // namespace caustica
