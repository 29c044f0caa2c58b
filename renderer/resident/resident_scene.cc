#include "renderer/resident/resident_scene.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <map>
#include <type_traits>
#include <utility>

#include "renderer/parallel/parallel_for.h"
#include "renderer/resident/derived_maps.h"
#include "renderer/scene/density_grid.h"
#include "renderer/scene/scene_limits.h"

namespace caustica {

// Validated scenes must fit the triangle structure's leaf encoding.
static_assert(kMaxSceneTriangles <= kMaxBvh4Triangles);
static_assert(kNoMedium == kVacuum, "a mesh without a medium holds vacuum");

namespace {

DeviceLight to_device_light(const Light& l) {
  DeviceLight d{};
  d.position = l.position;
  d.color = l.intensity;
  switch (l.type) {
    case LightType::kPoint:
      d.type = DeviceLightType::kPoint;
      break;
    case LightType::kSpot:
      d.type = DeviceLightType::kSpot;
      d.direction = normalize(l.direction);
      d.cos_inner = std::cos(l.inner_angle_deg * kPi / 180.0f);
      d.cos_outer = std::cos(l.outer_angle_deg * kPi / 180.0f);
      break;
    case LightType::kDirectional:
      d.type = DeviceLightType::kDirectional;
      d.direction = normalize(l.direction);
      break;
  }
  return d;
}

static_assert(std::is_nothrow_move_constructible_v<TriangleStructure> &&
                  std::is_nothrow_move_assignable_v<TriangleStructure> &&
                  std::is_nothrow_move_constructible_v<ResidentScene::Lighting> &&
                  std::is_nothrow_move_assignable_v<ResidentScene::Lighting>,
              "a swap that undoes a change cannot fail");

// Turns per-item weights into a normalised CDF of size n + 1 in place; returns the total.
float build_cdf(Backend& backend, Buffer<float>& weights_then_cdf, size_t n) {
  float* cdf = weights_then_cdf.data();
  float total = backend.exclusive_scan(cdf, cdf, n);
  float inv = total > 0 ? 1.0f / total : 0.0f;
  parallel_for(backend, "light_cdf_normalize", n + 1,
               [=] CAUSTICA_HD(size_t i) { cdf[i] = i == n ? 1.0f : cdf[i] * inv; });
  return total;
}

// weight[i] = the power of light i, or of light subset[i] when a subset is given; area_flag[i],
// when asked for, marks area lights. (Not in rebuild_light_tables: nvcc admits no extended lambda
// in a private member function.)
void write_light_weights(Backend& backend, const DeviceLight* lights, const uint32_t* subset,
                         size_t n, float scene_radius, float* weight, uint8_t* area_flag) {
  parallel_for(backend, "light_weights", n, [=] CAUSTICA_HD(size_t i) {
    const DeviceLight& light = lights[subset != nullptr ? subset[i] : i];
    weight[i] = light_power(light, scene_radius);
    if (area_flag != nullptr) area_flag[i] = light.type == DeviceLightType::kArea;
  });
}

std::vector<DeviceMaterial> to_device_materials(std::span<const Material> materials,
                                                std::span<const ResidentScene::MaterialMaps> maps) {
  std::vector<DeviceMaterial> out;
  out.reserve(materials.size());
  for (size_t i = 0; i < materials.size(); ++i) {
    const Material& m = materials[i];
    const ResidentScene::MaterialMaps mine =
        i < maps.size() ? maps[i] : ResidentScene::MaterialMaps{};
    out.push_back({m.type, m.color, m.ior, emitted_radiance(m), mine.color, mine.emission,
                   m.metallic, m.roughness, m.specular, m.exponent, mine.metallic_roughness,
                   mine.normal, m.normal_map.used() ? m.normal_scale : 1.0f, m.alpha_mode,
                   m.opacity, m.alpha_cutoff, mine.opacity, mine.opacity_channel});
  }
  return out;
}

// A map's mean over a triangle with texture coordinates `uv`, for weighing its area light's power:
// lookups at seven points spread over the triangle, at the level of a seventh of its footprint.
// Never quite zero where the factor emits: a point the lookups missed may still glow, and a light
// of zero power would never be drawn (docs/materials.md, "Emission").
Vec3f triangle_map_mean(const TextureView& view, const TextureTransform& transform,
                        const Vec2f* uv) {
  constexpr float kPoints[7][2] = {{1.0f / 3, 1.0f / 3}, {2.0f / 3, 1.0f / 6}, {1.0f / 6, 2.0f / 3},
                                   {1.0f / 6, 1.0f / 6}, {0.5f, 0.4f},         {0.1f, 0.5f},
                                   {0.4f, 0.1f}};
  const float uv_area = std::fabs((uv[1].x - uv[0].x) * (uv[2].y - uv[0].y) -
                                  (uv[2].x - uv[0].x) * (uv[1].y - uv[0].y));
  const float width = std::sqrt(uv_area / 7.0f);
  Vec3f sum(0.0f);
  for (const auto& b : kPoints) {
    const float w = 1.0f - b[0] - b[1];
    const Vec2f at{uv[0].x * w + uv[1].x * b[0] + uv[2].x * b[1],
                   uv[0].y * w + uv[1].y * b[0] + uv[2].y * b[1]};
    const Texel t = view.trilinear(transform.apply(at), width);
    sum += Vec3f(t.r, t.g, t.b);
  }
  constexpr float kFloor = 1.0f / 1024;
  const Vec3f mean = sum / 7.0f;
  return {std::max(mean.x, kFloor), std::max(mean.y, kFloor), std::max(mean.z, kFloor)};
}

// A decoded image as linear texels: 8-bit colour and emission maps are sRGB-encoded (glTF's base
// colour, MTL's map_Kd), other 8-bit maps (`srgb` false: glTF's metallic-roughness) and float
// images already linear.
std::vector<Texel> linear_texels(const DecodedImage& image, bool srgb_encoded) {
  const size_t count = size_t(image.width) * image.height;
  std::vector<Texel> texels(count);
  if (image.is_float()) {
    for (size_t i = 0; i < count; ++i) {
      const float* p = &image.rgba32f[4 * i];
      texels[i] = {p[0], p[1], p[2], p[3]};
    }
    return texels;
  }
  float srgb[256];
  for (int v = 0; v < 256; ++v)
    srgb[v] = srgb_encoded ? srgb_to_linear(float(v) / 255.0f) : float(v) / 255.0f;
  for (size_t i = 0; i < count; ++i) {
    const uint8_t* p = &image.rgba8[4 * i];
    texels[i] = {srgb[p[0]], srgb[p[1]], srgb[p[2]], float(p[3]) / 255.0f};
  }
  return texels;
}

// The emission and power tables of `lighting`, whose lights are uploaded.
void build_light_tables(Backend& backend, float scene_radius, ResidentScene::Lighting& lighting) {
  const size_t n = lighting.lights.size();
  const DeviceLight* lights = lighting.lights.data();
  lighting.light_cdf.resize_discard(n + 1);
  Buffer<uint8_t> is_area(backend, n);
  write_light_weights(backend, lights, nullptr, n, scene_radius, lighting.light_cdf.data(),
                      is_area.data());
  lighting.total_power = build_cdf(backend, lighting.light_cdf, n);

  lighting.area_light_index.resize_discard(n);
  const size_t area_count =
      backend.select_flagged(nullptr, is_area.data(), n, lighting.area_light_index.data());
  lighting.area_light_index.resize_discard(area_count);
  lighting.area_light_cdf.resize_discard(area_count + 1);
  write_light_weights(backend, lights, lighting.area_light_index.data(), area_count, scene_radius,
                      lighting.area_light_cdf.data(), nullptr);
  lighting.area_light_power = build_cdf(backend, lighting.area_light_cdf, area_count);
}

}  // namespace

DeviceMedium to_device_medium(const Medium& m, const uint8_t* grid) {
  DeviceMedium d{};
  d.kind = m.type == MediumType::kGrid ? MediumKind::kGrid : MediumKind::kHomogeneous;
  d.sigma_s = m.scattering;
  d.sigma_t = m.absorption + m.scattering;
  for (int c = 0; c < 3; ++c)
    d.albedo[c] = d.sigma_t[c] > 0.0f ? d.sigma_s[c] / d.sigma_t[c] : 0.0f;
  d.majorant = max_component(d.sigma_t);
  d.g = m.asymmetry;
  if (d.kind == MediumKind::kGrid) {
    const DensityGridFacts facts = density_grid_facts(*m.grid, m.grid_to_scene);
    d.grid.grid = reinterpret_cast<const nanovdb::FloatGrid*>(grid);
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 4; ++col) d.grid.to_index[row][col] = facts.scene_to_index[row][col];
    d.grid.bounds = facts.bounds;
    d.grid.step = facts.step;
    d.majorant *= facts.max_density;
  }
  return d;
}

namespace {

// What a scene's meshes make of its triangles, in the original order: their corners, and what
// changes when meshes move (positions, normals, tangents) apart from what does not (texture
// coordinates, materials).
struct TriangleArrays {
  std::vector<TriangleVertices> triangles;
  std::vector<Vec3f> corner_normals;   // empty when no mesh has normals
  std::vector<Vec4f> corner_tangents;  // empty unless `with_tangents` and a mesh has them
  std::vector<Vec2f> corner_uvs;       // only with `with_uvs`
  std::vector<uint32_t> material_ids;  // only with `with_materials`
  double surface_area = 0;
};

// Whether a mesh of `scene` has texture coordinates.
bool any_uvs(const Scene& scene) {
  return std::any_of(scene.meshes.begin(), scene.meshes.end(),
                     [](const Mesh& m) { return !m.uvs.empty(); });
}

TriangleArrays triangle_arrays(const Scene& scene, bool with_uvs, bool with_materials,
                               bool with_tangents) {
  TriangleArrays out;
  const size_t n = scene.triangle_count();
  bool any_normals = false, any_tangents = false;
  for (const Mesh& m : scene.meshes) {
    any_normals |= !m.normals.empty();
    any_tangents |= with_tangents && !m.tangents.empty();
  }
  out.triangles.reserve(n);
  if (any_normals) out.corner_normals.reserve(3 * n);
  if (with_uvs) out.corner_uvs.reserve(3 * n);
  if (any_tangents) out.corner_tangents.reserve(3 * n);
  if (with_materials) out.material_ids.reserve(n);
  for (const Mesh& m : scene.meshes) {
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      const uint32_t* idx = &m.indices[3 * t];
      const TriangleVertices tri{m.positions[idx[0]], m.positions[idx[1]], m.positions[idx[2]]};
      out.triangles.push_back(tri);
      out.surface_area += 0.5 * double(length(cross(tri.p1 - tri.p0, tri.p2 - tri.p0)));
      if (with_materials) out.material_ids.push_back(m.material_ids[t]);
      for (int c = 0; c < 3; ++c) {
        if (any_normals)
          out.corner_normals.push_back(m.normals.empty() ? Vec3f(0.0f) : m.normals[idx[c]]);
        if (with_uvs) out.corner_uvs.push_back(m.uvs.empty() ? Vec2f{0.0f, 0.0f} : m.uvs[idx[c]]);
        if (any_tangents) {
          out.corner_tangents.push_back(m.tangents.empty() ? Vec4f{0.0f, 0.0f, 0.0f, 0.0f}
                                                           : m.tangents[idx[c]]);
        }
      }
    }
  }
  return out;
}

}  // namespace

void ResidentScene::set_area_lights(std::span<const TriangleVertices> triangles,
                                    AreaLights& out) const {
  out.triangle_area_light.assign(triangles.size(), kNoAreaLight);
  out.records.clear();
  out.materials.clear();
  for (const Emitter& e : emitters_) {
    const TriangleVertices& tri = triangles[e.triangle];
    DeviceLight a{};
    a.type = DeviceLightType::kArea;
    a.position = tri.p0;
    a.edge1 = tri.p1 - tri.p0;
    a.edge2 = tri.p2 - tri.p0;
    const Vec3f ng = cross(a.edge1, a.edge2);
    a.area = 0.5f * length(ng);
    a.direction = normalize(ng);
    a.triangle = e.triangle;
    a.emission_map = e.emission_map;
    a.map_mean = e.map_mean;
    // Area lights follow the other lights in `lights` in this order, and so keep it among
    // themselves (rebuild_light_tables); new_lighting gives them their colour.
    if (a.area > 0) {
      out.triangle_area_light[e.triangle] = uint32_t(out.records.size());
      out.records.push_back(a);
      out.materials.push_back(e.material);
    }
  }
}

ResidentScene ResidentScene::upload(Backend& backend, const Scene& scene) {
  ResidentScene r;
  r.backend_ = &backend;
  const size_t n = scene.triangle_count();
  const TextureMaps maps = r.upload_texture_maps(scene);
  // Texture coordinates go to the device only for a scene with a colour map to read, and tangents
  // only for one with a normal map to read and a mesh that brings them; the other meshes'
  // corners are zero, which says to derive the frame from the coordinates.
  const bool with_uvs = !maps.device.empty() && any_uvs(scene);
  TriangleArrays arrays =
      triangle_arrays(scene, with_uvs, /*with_materials=*/true, with_uvs && r.has_normal_maps());
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    const Material& m = scene.materials[i];
    r.has_cutouts_ |= m.alpha_mode != AlphaMode::kOpaque &&
                      (m.opacity < 1.0f || (with_uvs && r.material_maps_[i].opacity != kNoTexture));
  }
  // The emitting triangles, which stay the area lights whatever later changes move them, each
  // with its emission map's mean over its texture coordinates, which stay too.
  size_t first = 0;
  for (const Mesh& m : scene.meshes) {
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      const uint32_t mat = m.material_ids[t];
      if (!is_emitter(scene.materials[mat])) continue;
      Emitter e{uint32_t(first + t), mat, with_uvs ? r.material_maps_[mat].emission : kNoTexture,
                Vec3f(1.0f)};
      if (e.emission_map != kNoTexture) {
        const uint32_t* idx = &m.indices[3 * t];
        Vec2f uv[3];
        for (int c = 0; c < 3; ++c) uv[c] = m.uvs.empty() ? Vec2f{0.0f, 0.0f} : m.uvs[idx[c]];
        e.map_mean =
            triangle_map_mean(maps.host[e.emission_map], maps.device[e.emission_map].transform, uv);
      }
      r.emitters_.push_back(e);
    }
    first += m.triangle_count();
  }
  AreaLights area;
  r.set_area_lights(arrays.triangles, area);
  r.area_lights_host_ = std::move(area.records);
  r.area_light_materials_ = std::move(area.materials);
  r.surface_area_ = arrays.surface_area;
  std::vector<DeviceMedium> media;
  for (const Medium& m : scene.media) {
    const uint8_t* grid = nullptr;
    if (m.type == MediumType::kGrid) {
      Buffer<uint8_t>& bytes = r.grids_.emplace_back(backend, 0);
      bytes.upload(std::span<const uint8_t>(m.grid->data(), m.grid->size()));
      grid = bytes.data();
    }
    media.push_back(to_device_medium(m, grid));
  }
  std::vector<uint32_t> triangle_medium;
  if (!media.empty()) {
    triangle_medium.reserve(n);
    for (const Mesh& m : scene.meshes)
      triangle_medium.insert(triangle_medium.end(), m.triangle_count(), m.interior_medium);
  }
  r.scene_medium_ = media.empty() ? kVacuum : scene.medium;

  r.triangles_.bind(backend);
  r.triangles_.upload(arrays.triangles);
  r.material_ids_.bind(backend);
  r.material_ids_.upload(arrays.material_ids);
  r.triangle_area_light_.bind(backend);
  r.triangle_area_light_.upload(area.triangle_area_light);
  r.corner_normals_.bind(backend);
  r.corner_normals_.upload(arrays.corner_normals);
  r.corner_uvs_.bind(backend);
  r.corner_uvs_.upload(arrays.corner_uvs);
  r.corner_tangents_.bind(backend);
  r.corner_tangents_.upload(arrays.corner_tangents);
  r.texture_maps_.bind(backend);
  r.texture_maps_.upload(maps.device);
  r.media_.bind(backend);
  r.media_.upload(media);
  r.triangle_medium_.bind(backend);
  r.triangle_medium_.upload(triangle_medium);
  r.structure_ = r.new_structure(scene.settings.structure, scene.settings.build);
  r.upload_environment(scene);
  // After the structure, whose bounds weigh the directional lights and the environment.
  r.lighting_ = r.new_lighting(scene.lights, scene.materials, scene.environment);
  return r;
}

void ResidentScene::upload_environment(const Scene& scene) {
  const Environment& e = scene.environment;
  if (!e.present) return;
  // A constant sky is a white image that the scale colours, of enough rows that its distribution
  // follows the sphere's solid angle (environment_distribution).
  uint32_t width = 32, height = 16;
  std::vector<Texel> texels(size_t(width) * height, Texel{1.0f, 1.0f, 1.0f, 1.0f});
  if (e.texture < scene.textures.size()) {
    const TextureImage& image = scene.textures[e.texture];
    if (image.decoded != nullptr && image.decoded->width > 0) {
      width = image.decoded->width;
      height = image.decoded->height;
      texels = linear_texels(*image.decoded, /*srgb_encoded=*/true);
    }
  }
  const PiecewiseConstant2DData d = environment_distribution(width, height, texels);
  EnvironmentImage& out = environment_;
  out.present = true;
  for (Buffer<float>* b : {&out.func, &out.row_cdfs, &out.row_integrals, &out.marginal_cdf})
    b->bind(*backend_);
  out.texels.bind(*backend_);
  out.level.bind(*backend_);
  out.texels.upload(texels);
  out.level.upload(std::vector<MipLevel>{{0, width, height}});
  out.func.upload(d.func);
  out.row_cdfs.upload(d.row_cdfs);
  out.row_integrals.upload(d.row_integrals);
  out.marginal_cdf.upload(d.marginal_cdf);
  out.nu = d.nu;
  out.nv = d.nv;
  out.integral = d.integral;
  out.mean = environment_mean(width, height, texels);
}

ResidentScene::TextureMaps ResidentScene::upload_texture_maps(const Scene& scene) {
  TextureMaps maps;
  std::vector<uint32_t> chain_of_map;
  // Each chain once, however many maps read it: an image per encoding (sRGB or linear), and each
  // map derived from images per the images and wrap modes it is derived from.
  std::map<std::array<uint32_t, 5>, uint32_t> chain_of_source;
  enum Source : uint32_t { kLinear, kSrgb, kNormalsFromHeights, kPackedMetallicRoughness };
  auto decoded = [&](const TextureRef& ref) -> const DecodedImage* {
    if (!ref.used() || ref.texture >= scene.textures.size()) return nullptr;
    const TextureImage& image = scene.textures[ref.texture];
    return image.decoded != nullptr && image.decoded->width > 0 ? image.decoded.get() : nullptr;
  };
  auto chain_for = [&](std::array<uint32_t, 5> source, auto&& texels) -> uint32_t {
    auto [it, added] = chain_of_source.try_emplace(source, uint32_t(maps.chains.size()));
    if (added) {
      uint32_t width = 0, height = 0;
      std::vector<Texel> image = texels(&width, &height);
      const MipChain& mips = maps.chains.emplace_back(build_mip_chain(width, height, image));
      texels_.emplace_back(*backend_, 0).upload(mips.texels);
      mip_levels_.emplace_back(*backend_, 0).upload(mips.levels);
    }
    return it->second;
  };
  auto map_of = [&](uint32_t chain, const TextureRef& ref) -> uint32_t {
    DeviceTextureMap map;
    map.view.texels = texels_[chain].data();
    map.view.levels = mip_levels_[chain].data();
    map.view.level_count = uint32_t(mip_levels_[chain].size());
    map.view.wrap_u = ref.wrap_u;
    map.view.wrap_v = ref.wrap_v;
    map.transform = ref.transform;
    chain_of_map.push_back(chain);
    maps.device.push_back(map);
    return uint32_t(maps.device.size() - 1);
  };
  auto add_map = [&](const TextureRef& ref, bool srgb) -> uint32_t {
    const DecodedImage* image = decoded(ref);
    if (image == nullptr) return kNoTexture;
    const uint32_t chain =
        chain_for({srgb ? kSrgb : kLinear, ref.texture, 0, 0, 0}, [&](uint32_t* w, uint32_t* h) {
          *w = image->width, *h = image->height;
          return linear_texels(*image, srgb);
        });
    return map_of(chain, ref);
  };
  auto add_bump_map = [&](const TextureRef& ref, float scale) -> uint32_t {
    const DecodedImage* image = decoded(ref);
    if (image == nullptr) return kNoTexture;
    const uint32_t chain =
        chain_for({kNormalsFromHeights, ref.texture, uint32_t(ref.wrap_u), uint32_t(ref.wrap_v),
                   std::bit_cast<uint32_t>(scale)},
                  [&](uint32_t* w, uint32_t* h) {
                    *w = image->width, *h = image->height;
                    return normals_from_heights(*image, scale, ref.wrap_u, ref.wrap_v);
                  });
    return map_of(chain, ref);
  };
  auto add_packed_map = [&](const TextureRef& roughness, const TextureRef& metallic) -> uint32_t {
    const DecodedImage *r = decoded(roughness), *m = decoded(metallic);
    if (r == nullptr && m == nullptr) return kNoTexture;
    const uint32_t chain = chain_for({kPackedMetallicRoughness, r ? roughness.texture : kNoTexture,
                                      m ? metallic.texture : kNoTexture, 0, 0},
                                     [&](uint32_t* w, uint32_t* h) {
                                       PackedImage packed = packed_metallic_roughness(r, m);
                                       *w = packed.width, *h = packed.height;
                                       return std::move(packed.texels);
                                     });
    // Validation has both sample alike.
    return map_of(chain, r != nullptr ? roughness : metallic);
  };
  material_maps_.assign(scene.materials.size(), MaterialMaps{});
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    const Material& m = scene.materials[i];
    MaterialMaps& mine = material_maps_[i];
    mine.color = add_map(m.color_map, true);
    mine.emission = add_map(m.emission_map, true);
    if (m.type == MaterialType::kMetallicRoughness) {
      mine.metallic_roughness = m.metallic_roughness_map.used()
                                    ? add_map(m.metallic_roughness_map, false)
                                    : add_packed_map(m.roughness_map, m.metallic_map);
    }
    mine.normal = add_map(m.normal_map, false);
    // A derived normal map carries its bump scale; to_device_materials gives it scale 1.
    if (!m.normal_map.used()) mine.normal = add_bump_map(m.bump_map, m.bump_scale);
    if (m.alpha_mode != AlphaMode::kOpaque && m.opacity_map.used() &&
        m.opacity_map.texture < scene.textures.size()) {
      // Alpha is linear in every chain, so an alpha map shares its image's colour chain (glTF's
      // opacity is the base colour texture's alpha); a grey map is read linear.
      const TextureImage& image = scene.textures[m.opacity_map.texture];
      const bool alpha = image.decoded != nullptr && image.decoded->has_alpha;
      mine.opacity = add_map(m.opacity_map, alpha);
      mine.opacity_channel = alpha ? 3 : 0;
    }
  }
  // The same maps over the host's copies, now that the chains no longer move.
  for (size_t i = 0; i < maps.device.size(); ++i) {
    const MipChain& mips = maps.chains[chain_of_map[i]];
    TextureView view = maps.device[i].view;
    view.texels = mips.texels.data();
    view.levels = mips.levels.data();
    maps.host.push_back(view);
  }
  return maps;
}

TriangleStructure ResidentScene::new_structure(StructureKind kind,
                                               const BuildOptions& options) const {
  return build_structure(*backend_, kind, triangles_.data(), uint32_t(triangles_.size()), options);
}

void ResidentScene::swap_structure(TriangleStructure& structure) noexcept {
  std::swap(structure_, structure);
}

ResidentScene::Geometry ResidentScene::new_geometry(const Scene& next) const {
  Geometry g;
  const bool tangents = !corner_uvs_.empty() && has_normal_maps();
  TriangleArrays arrays = triangle_arrays(next, false, false, tangents);
  AreaLights area;
  set_area_lights(arrays.triangles, area);
  g.triangles.bind(*backend_);
  g.triangles.upload(arrays.triangles);
  g.corner_normals.bind(*backend_);
  g.corner_normals.upload(arrays.corner_normals);
  g.corner_tangents.bind(*backend_);
  g.corner_tangents.upload(arrays.corner_tangents);
  g.triangle_area_light.bind(*backend_);
  g.triangle_area_light.upload(area.triangle_area_light);
  g.area_lights_host = std::move(area.records);
  g.area_light_materials = std::move(area.materials);
  g.surface_area = arrays.surface_area;
  const uint32_t count = uint32_t(g.triangles.size());
  const BuildOptions& build = next.settings.build;
  if (build.refit != RefitPolicy::kNever && next.settings.structure == structure_.kind()) {
    std::optional<TriangleStructure> refitted =
        refit_structure(*backend_, structure_, g.triangles.data(), count);
    if (refitted &&
        (build.refit == RefitPolicy::kAlways ||
         refitted->stats().sah_cost <= build.refit_sah_bound * refitted->stats().built_sah_cost)) {
      g.structure = *std::move(refitted);
      return g;
    }
  }
  g.structure = build_structure(*backend_, next.settings.structure, g.triangles.data(), count,
                                next.settings.build);
  return g;
}

void ResidentScene::swap_geometry(Geometry& g) noexcept {
  std::swap(triangles_, g.triangles);
  std::swap(corner_normals_, g.corner_normals);
  std::swap(corner_tangents_, g.corner_tangents);
  std::swap(triangle_area_light_, g.triangle_area_light);
  std::swap(area_lights_host_, g.area_lights_host);
  std::swap(area_light_materials_, g.area_light_materials);
  std::swap(surface_area_, g.surface_area);
  std::swap(structure_, g.structure);
}

ResidentScene::Lighting ResidentScene::new_lighting(std::span<const Light> lights,
                                                    std::span<const Material> materials,
                                                    const Environment& environment) const {
  std::vector<DeviceLight> all;
  all.reserve(lights.size() + 1 + area_lights_host_.size());
  for (const Light& l : lights) all.push_back(to_device_light(l));
  Lighting lighting;
  if (environment_.present) {
    lighting.environment = true;
    lighting.environment_scale = environment.color * environment.intensity;
    lighting.environment_rotation = environment.rotation_deg * (kPi / 180.0f);
    DeviceLight& e = all.emplace_back();
    e.type = DeviceLightType::kEnvironment;
    e.color = lighting.environment_scale * environment_.mean;
  }
  for (size_t i = 0; i < area_lights_host_.size(); ++i) {
    DeviceLight& area = all.emplace_back(area_lights_host_[i]);
    area.color = emitted_radiance(materials[area_light_materials_[i]]);
  }
  lighting.materials.bind(*backend_);
  lighting.lights.bind(*backend_);
  lighting.light_cdf.bind(*backend_);
  lighting.area_light_index.bind(*backend_);
  lighting.area_light_cdf.bind(*backend_);
  lighting.materials.upload(to_device_materials(materials, material_maps_));
  lighting.lights.upload(all);
  build_light_tables(*backend_, radius(), lighting);
  return lighting;
}

void ResidentScene::swap_lighting(Lighting& lighting) noexcept { std::swap(lighting_, lighting); }

size_t ResidentScene::Lighting::bytes() const {
  return materials.bytes() + lights.bytes() + light_cdf.bytes() + area_light_index.bytes() +
         area_light_cdf.bytes();
}

ResidentSceneView ResidentScene::view() const {
  ResidentSceneView v;
  v.triangles = triangles_.data();
  v.corner_normals = corner_normals_.empty() ? nullptr : corner_normals_.data();
  v.corner_uvs = corner_uvs_.empty() ? nullptr : corner_uvs_.data();
  v.texture_maps = texture_maps_.empty() ? nullptr : texture_maps_.data();
  v.material_ids = material_ids_.data();
  v.triangle_area_light = triangle_area_light_.data();
  v.materials = lighting_.materials.data();
  v.lights = lighting_.lights.data();
  v.light_cdf = lighting_.light_cdf.data();
  v.area_lights = lighting_.area_light_index.data();
  v.area_light_cdf = lighting_.area_light_cdf.data();
  v.light_count = uint32_t(lighting_.lights.size());
  v.area_light_count = uint32_t(lighting_.area_light_index.size());
  v.total_power = lighting_.total_power;
  v.area_light_power = lighting_.area_light_power;
  v.has_environment = lighting_.environment && environment_.present;
  v.corner_tangents = corner_tangents_.empty() ? nullptr : corner_tangents_.data();
  v.has_normal_maps = !corner_uvs_.empty() && has_normal_maps();
  v.has_cutouts = has_cutouts_;
  if (v.has_environment) {
    const EnvironmentImage& e = environment_;
    v.environment.image = {e.texels.data(), e.level.data(), 1, TextureWrap::kRepeat,
                           TextureWrap::kClampToEdge};
    v.environment.distribution = {
        e.func.data(), e.row_cdfs.data(), e.row_integrals.data(), e.marginal_cdf.data(), e.nu,
        e.nv,          e.integral};
    v.environment.scale = lighting_.environment_scale;
    v.environment.rotation = lighting_.environment_rotation;
  }
  if (!media_.empty()) {
    v.media.media = media_.data();
    v.media.triangle_medium = triangle_medium_.data();
    v.media.count = uint32_t(media_.size());
    v.media.scene_medium = scene_medium_;
    v.media.bounds = bounds();
    v.media.grids = !grids_.empty();
  }
  return v;
}

size_t ResidentScene::geometry_change_bytes() const {
  return triangles_.bytes() + corner_normals_.bytes() + corner_tangents_.bytes() +
         triangle_area_light_.bytes() + structure_.stats().bytes + lighting_.bytes();
}

size_t ResidentScene::bytes() const {
  size_t grid_bytes = 0;
  for (const Buffer<uint8_t>& g : grids_) grid_bytes += g.bytes();
  for (const Buffer<Texel>& t : texels_) grid_bytes += t.bytes();
  for (const Buffer<MipLevel>& l : mip_levels_) grid_bytes += l.bytes();
  const EnvironmentImage& e = environment_;
  grid_bytes += e.texels.bytes() + e.level.bytes() + e.func.bytes() + e.row_cdfs.bytes() +
                e.row_integrals.bytes() + e.marginal_cdf.bytes();
  return triangles_.bytes() + corner_normals_.bytes() + corner_uvs_.bytes() +
         corner_tangents_.bytes() + texture_maps_.bytes() + material_ids_.bytes() +
         triangle_area_light_.bytes() + lighting_.bytes() + media_.bytes() +
         triangle_medium_.bytes() + structure_.stats().bytes + grid_bytes;
}

}  // namespace caustica
