// A scene resident in backend memory: triangles and their ray-tracing structure, materials and
// lights in the flat form kernels read. Built once per geometry change; lights are re-uploaded
// alone when only they change (the engine's epochs decide which).
#pragma once

#include <algorithm>
#include <deque>
#include <span>

#include "absl/status/statusor.h"
#include "renderer/accel/structure.h"
#include "renderer/base/sampling.h"
#include "renderer/material/environment_map.h"
#include "renderer/material/texture.h"
#include "renderer/medium/medium.h"
#include "renderer/scene/scene.h"

namespace caustica {

struct DeviceMaterial {
  MaterialType type;
  Vec3f color;
  float ior;
  Vec3f radiance;         // what the front face emits now (any type may emit)
  uint32_t color_map;     // index into ResidentSceneView::texture_maps, or kNoTexture
  uint32_t emission_map;  // likewise
  float metallic, roughness;  // Material's
  Vec3f specular;
  float exponent;
  // A metallic-roughness material's map (linear): green multiplies roughness, blue metallic.
  uint32_t metallic_roughness_map;
  uint32_t normal_map;  // a tangent-space normal map (linear), or kNoTexture
  float normal_scale;
  // Material's; opacity_channel is the map texel's channel that multiplies opacity: 3 (alpha)
  // where the map's image has an alpha channel, else 0.
  AlphaMode alpha_mode;
  float opacity, alpha_cutoff;
  uint32_t opacity_map;
  uint32_t opacity_channel;
};

// A material's colour or emission map as kernels read it: the image's mip chain with the map's
// wrap modes, and its KHR_texture_transform.
struct DeviceTextureMap {
  TextureView view;
  TextureTransform transform;
};

enum class DeviceLightType : uint32_t {
  kPoint = 0,
  kSpot = 1,
  kDirectional = 2,
  kArea = 3,
  kEnvironment = 4,
};

// Flat light record. Area lights are one record per emissive triangle (`triangle`, `area`). The
// environment's record stands for it in the choice of lights by power; its light comes from
// ResidentSceneView::environment.
struct DeviceLight {
  DeviceLightType type;
  Vec3f position;      // point/spot; area: first vertex
  Vec3f direction;     // spot axis / directional travel direction; area: unit geometric normal
  // Intensity (point/spot), irradiance (directional), radiance (area) or the environment's mean
  // radiance over the sphere.
  Vec3f color;
  float cos_inner;     // spot
  float cos_outer;     // spot
  Vec3f edge1, edge2;  // area: triangle edges from `position`
  float area;
  // Area: the triangle (original order) and its material's emission map (an index into
  // ResidentSceneView::texture_maps, or kNoTexture), which multiplies `color` where the triangle's
  // texture coordinates say; and the map's mean over the triangle, which weighs the light's power.
  uint32_t triangle = 0;
  uint32_t emission_map = kNoTexture;
  Vec3f map_mean{1.0f};
};

// A sampled light position seen from nowhere in particular: what emission and shadow rays need.
struct LightSample {
  Vec3f position;
  Vec3f normal;    // area lights: the emitting side
  float pdf_area;  // area lights: 1 / area
};

// A triangle that is no area light (ResidentSceneView::triangle_area_light).
constexpr uint32_t kNoAreaLight = 0xffffffffu;

// Medium `m` as kernels read it; a grid medium's `grid` is its NanoVDB buffer in the backend's
// memory.
DeviceMedium to_device_medium(const Medium& m, const uint8_t* grid);

// Plain pointers for kernels: everything of the scene but its structure, whose view kernels take
// beside this one (structure.h).
struct ResidentSceneView {
  const TriangleVertices* triangles;  // original order
  const Vec3f* corner_normals;        // 3 per triangle, or nullptr when no mesh has normals
  // 3 per triangle (v down the image), or nullptr when no material has a map to read with them.
  const Vec2f* corner_uvs;
  // 3 per triangle, xyz and the bitangent's sign w as Mesh::tangents (zero where a mesh has none),
  // or nullptr unless a mesh with tangents may be normal-mapped.
  const Vec4f* corner_tangents;
  const DeviceTextureMap* texture_maps;  // what materials' and area lights' map indices name
  const uint32_t* material_ids;       // per triangle
  const DeviceMaterial* materials;
  const DeviceLight* lights;    // every light, area triangles included
  const float* light_cdf;       // emission choice by power, size light_count + 1
  const uint32_t* area_lights;  // indices into `lights` of the area lights
  const float* area_light_cdf;  // shadow-ray choice among area lights by power
  // Per triangle (original order): its area light's index into area_lights and area_light_cdf,
  // or kNoAreaLight; how a path that meets a light weighs it against the shadow rays' choice.
  const uint32_t* triangle_area_light;
  uint32_t light_count;
  uint32_t area_light_count;
  // The environment, when has_environment: its record is the last light before the area lights.
  EnvironmentMap environment;
  bool has_environment;
  // Whether a material has a normal map that a triangle's texture coordinates can read: only then
  // does surface_at look for one.
  bool has_normal_maps;
  // Whether a material lets rays through some of its surface (Material::has_cutouts): only then
  // do the traces of cutouts.h look at what they hit.
  bool has_cutouts;
  float total_power;  // sum over lights of average-channel power (W)
  float area_light_power;
  MediaView media;  // none when the scene has no participating media

  // Index of the first CDF bucket whose upper edge exceeds u; cdf[0] = 0, cdf[count] = 1.
  CAUSTICA_HD static uint32_t sample_cdf(const float* cdf, uint32_t count, float u) {
    uint32_t lo = 0, hi = count;
    while (lo + 1 < hi) {
      uint32_t mid = (lo + hi) / 2;
      if (cdf[mid] <= u)
        lo = mid;
      else
        hi = mid;
    }
    return lo;
  }
};

// Surface data at a ray hit.
struct SurfaceHit {
  Vec3f position;
  Vec3f geometric_normal;  // unit
  Vec3f shading_normal;    // unit, same side as geometric_normal
  uint32_t material;
};

// Texture coordinates at barycentrics (u, v) of `triangle`; the scene must have them.
CAUSTICA_HDI Vec2f uv_at(const ResidentSceneView& scene, uint32_t triangle, float u, float v) {
  const Vec2f* uv = scene.corner_uvs + 3 * size_t(triangle);
  const float w = 1.0f - u - v;
  return {uv[0].x * w + uv[1].x * u + uv[2].x * v, uv[0].y * w + uv[1].y * u + uv[2].y * v};
}

// Map `map` at `hit`, its level chosen by a ray cone `cone_width` wide (in scene units) at the
// hit, arriving along `direction` (Akenine-Moller et al. 2019: the footprint grows by 1 / |cos| on
// the surface and maps to texture coordinates by the triangle's ratio of texture to scene area).
// A width of 0 reads the finest level, as photons do.
CAUSTICA_HDI Vec3f map_at_hit(const ResidentSceneView& scene, uint32_t map_index, const Hit& hit,
                              Vec3f direction, float cone_width) {
  const DeviceTextureMap& map = scene.texture_maps[map_index];
  float width = 0.0f;
  if (cone_width > 0.0f) {
    const Vec2f* uv = scene.corner_uvs + 3 * size_t(hit.triangle);
    const TriangleVertices& t = scene.triangles[hit.triangle];
    const Vec3f n = cross(t.p1 - t.p0, t.p2 - t.p0);
    const float scene_area = length(n);
    const float uv_area = fabsf((uv[1].x - uv[0].x) * (uv[2].y - uv[0].y) -
                                (uv[2].x - uv[0].x) * (uv[1].y - uv[0].y));
    const float cos_theta = scene_area > 0.0f ? fabsf(dot(direction, n)) / scene_area : 0.0f;
    if (scene_area > 0.0f && cos_theta > 1e-3f) {
      width = cone_width / cos_theta * sqrtf(uv_area / scene_area);
    }
  }
  const Texel c =
      map.view.trilinear(map.transform.apply(uv_at(scene, hit.triangle, hit.u, hit.v)), width);
  return Vec3f(c.r, c.g, c.b);
}

// Shading normal `n` (unit, on the side of the unit geometric normal `ng`) at `hit` bent by
// material `m`'s normal map, read at its finest level: the texel c gives (2 c - 1) with x and y
// times the map's scale, in the frame of the tangent, the bitangent and n. The tangent is the
// mesh's (glTF's TANGENT, the bitangent w cross(n, tangent)) where it has one, else the
// triangle's direction of growing u after the map's transform, the bitangent then up the image
// (against v, which runs down it; mirrored coordinates flip it), as MikkTSpace's would be for the
// triangle alone. Unbent where the coordinates are degenerate or the bent normal would face away
// from ng (docs/materials.md, "Normal maps").
CAUSTICA_HDI Vec3f normal_mapped(const ResidentSceneView& scene, const DeviceMaterial& m,
                                 const Hit& hit, Vec3f n, Vec3f ng) {
  const DeviceTextureMap& map = scene.texture_maps[m.normal_map];
  Vec3f along_u(0.0f), bitangent_side(0.0f);
  float handedness = 1.0f;
  if (scene.corner_tangents != nullptr) {
    const Vec4f* tangent = scene.corner_tangents + 3 * size_t(hit.triangle);
    const float w = 1.0f - hit.u - hit.v;
    const Vec4f t = {tangent[0].x * w + tangent[1].x * hit.u + tangent[2].x * hit.v,
                     tangent[0].y * w + tangent[1].y * hit.u + tangent[2].y * hit.v,
                     tangent[0].z * w + tangent[1].z * hit.u + tangent[2].z * hit.v, tangent[0].w};
    along_u = Vec3f(t.x, t.y, t.z);
    handedness = t.w < 0.0f ? -1.0f : 1.0f;
  }
  if (!(length_squared(along_u) > 0.0f)) {
    // No tangents: the triangle's own, dp/du, and the bitangent's side from dp/dv.
    const TriangleVertices& t = scene.triangles[hit.triangle];
    const Vec2f* corner = scene.corner_uvs + 3 * size_t(hit.triangle);
    const Vec2f uv0 = map.transform.apply(corner[0]), uv1 = map.transform.apply(corner[1]),
                uv2 = map.transform.apply(corner[2]);
    const float du1 = uv1.x - uv0.x, dv1 = uv1.y - uv0.y;
    const float du2 = uv2.x - uv0.x, dv2 = uv2.y - uv0.y;
    const float det = du1 * dv2 - du2 * dv1;
    if (!(fabsf(det) > 0.0f)) return n;
    const Vec3f dp1 = t.p1 - t.p0, dp2 = t.p2 - t.p0;
    along_u = (dp1 * dv2 - dp2 * dv1) / det;
    bitangent_side = (dp2 * du1 - dp1 * du2) / det;  // dp/dv: down the image
  }
  const Vec3f in_plane = along_u - n * dot(n, along_u);
  if (!(length_squared(in_plane) > 0.0f)) return n;
  const Vec3f tangent = normalize(in_plane);
  Vec3f bitangent = cross(n, tangent) * handedness;
  if (dot(bitangent, bitangent_side) > 0.0f) bitangent = -bitangent;
  const Texel c =
      map.view.trilinear(map.transform.apply(uv_at(scene, hit.triangle, hit.u, hit.v)), 0.0f);
  const Vec3f bent = tangent * ((2.0f * c.r - 1.0f) * m.normal_scale) +
                     bitangent * ((2.0f * c.g - 1.0f) * m.normal_scale) + n * (2.0f * c.b - 1.0f);
  if (!(length_squared(bent) > 0.0f)) return n;
  const Vec3f bent_unit = normalize(bent);
  return dot(bent_unit, ng) > 0.0f ? bent_unit : n;
}

// kNormalMaps false compiles the normal maps out, for launches whose registers are held to a
// bound that scenes without them should not pay for (docs/performance.md, "Launches by what the
// scene has"); it must then be chosen only for scenes without normal maps.
template <bool kNormalMaps = true>
CAUSTICA_HDI SurfaceHit surface_at(const ResidentSceneView& scene, const Hit& hit) {
  const TriangleVertices& t = scene.triangles[hit.triangle];
  float w = 1.0f - hit.u - hit.v;
  SurfaceHit s;
  s.position = t.p0 * w + t.p1 * hit.u + t.p2 * hit.v;
  s.geometric_normal = normalize(geometric_normal(t));
  s.shading_normal = s.geometric_normal;
  if (scene.corner_normals != nullptr) {
    const Vec3f* n = scene.corner_normals + 3 * size_t(hit.triangle);
    Vec3f ns = n[0] * w + n[1] * hit.u + n[2] * hit.v;
    if (length_squared(ns) > 0.0f) {
      ns = normalize(ns);
      s.shading_normal = dot(ns, s.geometric_normal) < 0.0f ? -ns : ns;
    }
  }
  s.material = scene.material_ids[hit.triangle];
  if (kNormalMaps && scene.has_normal_maps) {
    const DeviceMaterial& m = scene.materials[s.material];
    if (m.normal_map != kNoTexture)
      s.shading_normal = normal_mapped(scene, m, hit, s.shading_normal, s.geometric_normal);
  }
  return s;
}

// The colour a material shows at `hit`: its colour times its colour map there (map_at_hit).
// Without a map, or on a triangle without texture coordinates, the colour.
CAUSTICA_HDI Vec3f surface_color(const ResidentSceneView& scene, const DeviceMaterial& m,
                                 const Hit& hit, Vec3f direction, float cone_width) {
  if (m.color_map == kNoTexture || scene.corner_uvs == nullptr) return m.color;
  return m.color * map_at_hit(scene, m.color_map, hit, direction, cone_width);
}

// The radiance a material's front face emits at `hit`, seen along `direction`: its emission
// times its emission map there, read as surface_color reads colour maps.
CAUSTICA_HDI Vec3f surface_emission(const ResidentSceneView& scene, const DeviceMaterial& m,
                                    const Hit& hit, Vec3f direction, float cone_width) {
  if (m.emission_map == kNoTexture || scene.corner_uvs == nullptr) return m.radiance;
  return m.radiance * map_at_hit(scene, m.emission_map, hit, direction, cone_width);
}

// The radiance area light `l` emits at barycentrics b of its triangle (the finest level of its
// emission map).
CAUSTICA_HDI Vec3f area_light_radiance(const ResidentSceneView& scene, const DeviceLight& l,
                                       Vec2f b) {
  if (l.emission_map == kNoTexture || scene.corner_uvs == nullptr) return l.color;
  const DeviceTextureMap& map = scene.texture_maps[l.emission_map];
  const Texel c = map.view.trilinear(map.transform.apply(uv_at(scene, l.triangle, b.x, b.y)), 0.0f);
  return l.color * Vec3f(c.r, c.g, c.b);
}

// Power of a light averaged over channels, in the units photon flux is expressed in.
CAUSTICA_HDI float light_power(const DeviceLight& l, float scene_radius) {
  float c = l.emission_map == kNoTexture ? average(l.color) : average(l.color * l.map_mean);
  switch (l.type) {
    case DeviceLightType::kPoint:
      return 4.0f * kPi * c;
    case DeviceLightType::kSpot:  // smoothstep falloff: half the transition band (pbrt-v4)
      return 2.0f * kPi * c * ((1.0f - l.cos_inner) + (l.cos_inner - l.cos_outer) * 0.5f);
    case DeviceLightType::kDirectional:
      return c * kPi * scene_radius * scene_radius;
    case DeviceLightType::kArea:
      return c * kPi * l.area;
    case DeviceLightType::kEnvironment:  // through a disc of the scene's radius, from all around
      return c * 4.0f * kPi * kPi * scene_radius * scene_radius;
  }
  return 0.0f;
}

// Smoothstep falloff between the outer and inner cone (pbrt-v4 SpotLight::I).
CAUSTICA_HDI float spot_falloff(const DeviceLight& l, Vec3f direction_from_light) {
  float cos_theta = dot(direction_from_light, l.direction);
  if (cos_theta >= l.cos_inner) return 1.0f;
  if (cos_theta <= l.cos_outer) return 0.0f;
  float x = (cos_theta - l.cos_outer) / (l.cos_inner - l.cos_outer);
  return x * x * (3.0f - 2.0f * x);
}

class ResidentScene {
 public:
  // A material's maps: indices into texture_maps_, or kNoTexture.
  struct MaterialMaps {
    uint32_t color = kNoTexture, emission = kNoTexture, metallic_roughness = kNoTexture,
             normal = kNoTexture, opacity = kNoTexture;
    uint32_t opacity_channel = 0;  // DeviceMaterial's
  };

  // The materials and every light as kernels read them: what a light change replaces as a whole.
  struct Lighting {
    Buffer<DeviceMaterial> materials;
    Buffer<DeviceLight> lights;  // the non-geometric lights, then the area lights
    Buffer<float> light_cdf;
    Buffer<uint32_t> area_light_index;
    Buffer<float> area_light_cdf;
    float total_power = 0;
    float area_light_power = 0;
    // The environment's scale (colour times intensity) and rotation about +y in radians.
    bool environment = false;
    Vec3f environment_scale{1.0f};
    float environment_rotation = 0;

    size_t bytes() const;
  };

  // Uploads geometry, materials and their colour maps and builds the triangle structure the
  // scene's settings name. The scene's textures must be decoded (decode_textures).
  static ResidentScene upload(Backend& backend, const Scene& scene);

  // A change is built beside what is in use and then swapped in, so that one that runs out of
  // memory leaves the scene as it was, and a swap back undoes one without allocating.
  // A structure of `kind`, its builder told `options`, over the same triangles.
  TriangleStructure new_structure(StructureKind kind, const BuildOptions& options) const;
  void swap_structure(TriangleStructure& structure) noexcept;
  // The triangles where a geometry change that keeps every triangle, its material and its
  // texture coordinates puts them (Engine::apply's meshes): their corners, area lights and
  // structure, built beside what is in use; the structure refitted instead where the settings'
  // refit policy allows (RefitPolicy, build_options.h). The lighting must be made again after the
  // swap, for the area lights and the bounds it weighs lights by.
  struct Geometry {
    Buffer<TriangleVertices> triangles;
    Buffer<Vec3f> corner_normals;
    Buffer<Vec4f> corner_tangents;
    Buffer<uint32_t> triangle_area_light;
    std::vector<DeviceLight> area_lights_host;
    std::vector<uint32_t> area_light_materials;
    double surface_area = 0;
    TriangleStructure structure;
  };
  Geometry new_geometry(const Scene& next) const;
  void swap_geometry(Geometry& geometry) noexcept;
  // `lights` (area lights follow the geometry and stay) with the emission of `materials`, the
  // materials given at upload with their emission changed or not, and `environment`, the one
  // given at upload with its intensity and rotation changed or not.
  Lighting new_lighting(std::span<const Light> lights, std::span<const Material> materials,
                        const Environment& environment) const;
  void swap_lighting(Lighting& lighting) noexcept;

  ResidentSceneView view() const;
  const TriangleStructure& structure() const { return structure_; }
  size_t triangle_count() const { return triangles_.size(); }
  size_t bytes() const;
  // What a geometry change builds beside what is in use (new_geometry and new_lighting): the
  // triangles' corners, area lights, structure and lighting.
  size_t geometry_change_bytes() const;
  Aabb bounds() const { return structure_.bounds(); }
  float radius() const { return 0.5f * length(bounds().extent()); }
  double surface_area() const { return surface_area_; }  // of every triangle
  bool has_media() const { return !media_.empty(); }
  bool has_grid_media() const { return !grids_.empty(); }

 private:
  // The maps materials read: as kernels read them, and the same over host copies of their
  // chains, which upload keeps while it weighs area lights by their emission maps.
  struct TextureMaps {
    std::vector<DeviceTextureMap> device;
    std::vector<TextureView> host;
    std::deque<MipChain> chains;
  };
  // Uploads the mip chain of every image a map reads and sets material_maps_, indices into the
  // maps it returns.
  TextureMaps upload_texture_maps(const Scene& scene);
  // Uploads the environment's image and the distribution its directions are drawn from.
  void upload_environment(const Scene& scene);
  // Whether a material reads a normal map (after upload_texture_maps).
  bool has_normal_maps() const {
    return std::any_of(material_maps_.begin(), material_maps_.end(),
                       [](const MaterialMaps& m) { return m.normal != kNoTexture; });
  }
  // Whether a material lets rays through (set by upload).
  bool has_cutouts_ = false;
  // An emitting triangle of the scene as uploaded (original order), its material and emission
  // map and the map's mean over its texture coordinates: what stays when the triangle moves.
  struct Emitter {
    uint32_t triangle, material, emission_map;
    Vec3f map_mean;
  };
  std::vector<Emitter> emitters_;
  // The area lights of the emitters at `triangles`: those of some area, in emitter order, and
  // each triangle's index among them (or kNoAreaLight).
  struct AreaLights {
    std::vector<DeviceLight> records;
    std::vector<uint32_t> materials;
    std::vector<uint32_t> triangle_area_light;
  };
  void set_area_lights(std::span<const TriangleVertices> triangles, AreaLights& out) const;

  Backend* backend_ = nullptr;
  // From emitting triangles, fixed with the geometry but for their colour, the emission of their
  // material (area_light_materials_), which new_lighting sets.
  std::vector<DeviceLight> area_lights_host_;
  std::vector<uint32_t> area_light_materials_;
  // Each material's index into texture_maps_, or kNoTexture.
  std::vector<MaterialMaps> material_maps_;
  Buffer<TriangleVertices> triangles_;
  Buffer<Vec3f> corner_normals_;
  Buffer<Vec2f> corner_uvs_;
  Buffer<Vec4f> corner_tangents_;
  // One mip chain per image a map reads, and the maps, which point into them.
  std::vector<Buffer<Texel>> texels_;
  std::vector<Buffer<MipLevel>> mip_levels_;
  Buffer<DeviceTextureMap> texture_maps_;
  // The environment's image (one level: it is looked up, never filtered over a footprint), the
  // arrays of its distribution (PiecewiseConstant2D) and its mean radiance over the sphere.
  struct EnvironmentImage {
    bool present = false;
    Buffer<Texel> texels;
    Buffer<MipLevel> level;
    Buffer<float> func, row_cdfs, row_integrals, marginal_cdf;
    uint32_t nu = 0, nv = 0;
    float integral = 0;
    Vec3f mean{0.0f};
  } environment_;
  Buffer<uint32_t> material_ids_;
  Buffer<uint32_t> triangle_area_light_;
  Lighting lighting_;
  Buffer<DeviceMedium> media_;
  std::vector<Buffer<uint8_t>> grids_;  // the grid media's NanoVDB buffers, which media_ points at
  Buffer<uint32_t> triangle_medium_;    // only when there are media
  uint32_t scene_medium_ = kVacuum;
  double surface_area_ = 0;
  TriangleStructure structure_;
};

}  // namespace caustica
