#include "proto/wire/scene_wire.h"

#include <zlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <iterator>
#include <optional>
#include <tuple>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "renderer/scene/scene_limits.h"
#include "renderer/scene/validate.h"

namespace caustica::wire {
namespace {

// The MeshChunk arrays, indexed by MeshChunk::Array: element sizes and names.
constexpr int kMeshArrays = v1::MeshChunk::Array_ARRAYSIZE;
constexpr size_t kElementBytes[] = {0,
                                    3 * sizeof(float),
                                    3 * sizeof(float),
                                    3 * sizeof(uint32_t),
                                    sizeof(uint32_t),
                                    2 * sizeof(float),
                                    4 * sizeof(float)};
constexpr const char* kArrayNames[] = {"unspecified",  "positions", "normals", "indices",
                                       "material_ids", "texcoords", "tangents"};
static_assert(std::size(kElementBytes) == kMeshArrays && std::size(kArrayNames) == kMeshArrays);

// Debian's Abseil has its own string_view, which StrCat takes; std's converts through this.
absl::string_view as_absl(std::string_view s) { return {s.data(), s.size()}; }

absl::Status invalid(std::string_view field, std::string_view problem) {
  return absl::InvalidArgumentError(absl::StrCat(as_absl(field), ": ", as_absl(problem)));
}

std::string join_field(std::string_view field, std::string_view member) {
  return absl::StrCat(as_absl(field), ".", as_absl(member));
}

// An affine map as 12 numbers, the top three rows of its 4x4 matrix row by row (a grid medium's
// placement, a mesh's transform).
void encode_affine(const Affine& a, google::protobuf::RepeatedField<double>* out) {
  for (const auto& row : a.m)
    for (const double x : row) out->Add(x);
}
absl::StatusOr<Affine> decode_affine(const google::protobuf::RepeatedField<double>& numbers,
                                     std::string_view field) {
  if (numbers.size() != 12) {
    return invalid(field, absl::StrCat("has ", numbers.size(), " numbers; it takes 12"));
  }
  Affine a;
  for (int i = 0; i < 12; ++i) {
    if (!std::isfinite(numbers[i])) {
      return invalid(field, absl::StrCat("number ", i, " is ", numbers[i], ", not finite"));
    }
    a.m[i / 4][i % 4] = numbers[i];
  }
  return a;
}

// Appends a chunk's elements to `out` (room for the whole array's `total` reserved with the first
// chunk) and checks each with `check(element, its index in the whole array)`; after a failure
// nothing of the chunk stays. `received_bytes`: the array's bytes before this chunk.
template <typename T, typename Check>
absl::Status append_elements(std::vector<T>& out, size_t total, const std::string& data,
                             size_t received_bytes, Check check) {
  if (out.empty()) out.reserve(total);
  const size_t base = out.size();
  const size_t count = data.size() / sizeof(T);
  out.resize(base + count);
  std::memcpy(out.data() + base, data.data(), data.size());
  const size_t first = received_bytes / sizeof(T);
  for (size_t i = 0; i < count; ++i) {
    if (absl::Status s = check(out[base + i], first + i); !s.ok()) {
      out.resize(base);
      return s;
    }
  }
  return absl::OkStatus();
}

// One chunk of a byte blob (a grid's buffer, a texture's file; GridChunk and TextureChunk alike):
// checked for its size, its checksum, its place after the `received` bytes so far and within the
// `declared` total, then handed to `store(data, received)` and counted in `received` and
// `bytes_received`. `field` names the chunk kind ("grid", "texture") and `where` the blob.
template <typename Chunk, typename Store>
absl::Status receive_blob_chunk(std::string_view field, const std::string& where,
                                const Chunk& chunk, uint64_t& received, uint64_t declared,
                                size_t& bytes_received, Store store) {
  const std::string& data = chunk.data();
  if (data.size() > kMaxChunkBytes) {
    return invalid(join_field(field, "data"), absl::StrCat(where, ": ", data.size(),
                                                           " bytes exceed the ", kMaxChunkBytes,
                                                           "-byte chunk limit"));
  }
  if (data.empty()) return invalid(join_field(field, "data"), absl::StrCat(where, ": is empty"));
  if (chunk_crc32(data) != chunk.crc32()) {
    return invalid(join_field(field, "crc32"),
                   absl::StrFormat("%s: checksum %08x does not match the data (%08x)", where,
                                   chunk.crc32(), chunk_crc32(data)));
  }
  if (chunk.offset() != received) {
    return invalid(join_field(field, "offset"), absl::StrCat(where, ": offset ", chunk.offset(),
                                                             " but ", received,
                                                             " bytes arrived so far"));
  }
  if (received + data.size() > declared) {
    return invalid(join_field(field, "data"),
                   absl::StrCat(where, ": ", received + data.size(), " bytes exceed the ",
                                declared, " the header declares"));
  }
  store(data, received);
  received += data.size();
  bytes_received += data.size();
  return absl::OkStatus();
}

constexpr v1::TextureRef::Wrap kWireWraps[] = {
    v1::TextureRef::REPEAT, v1::TextureRef::CLAMP_TO_EDGE, v1::TextureRef::MIRRORED_REPEAT};
static_assert(std::size(kWireWraps) == v1::TextureRef::Wrap_ARRAYSIZE);

v1::TextureRef encode_texture_ref(const TextureRef& ref) {
  v1::TextureRef out;
  out.set_texture(ref.texture + 1);
  out.set_wrap_u(kWireWraps[static_cast<int>(ref.wrap_u)]);
  out.set_wrap_v(kWireWraps[static_cast<int>(ref.wrap_v)]);
  out.set_offset_u(ref.transform.offset.x);
  out.set_offset_v(ref.transform.offset.y);
  out.set_rotation(ref.transform.rotation);
  out.set_scale_u(ref.transform.scale.x);
  out.set_scale_v(ref.transform.scale.y);
  return out;
}

absl::StatusOr<TextureRef> decode_texture_ref(const v1::TextureRef& in, const std::string& field,
                                              size_t textures) {
  TextureRef ref;
  if (in.texture() == 0) return ref;
  if (in.texture() > textures) {
    return invalid(join_field(field, "texture"),
                   absl::StrCat(in.texture(), " names no texture (the scene has ", textures,
                                " textures; 1 is the first, 0 none)"));
  }
  ref.texture = in.texture() - 1;
  const std::tuple<int, const char*, TextureWrap*> wraps[] = {{in.wrap_u(), "wrap_u", &ref.wrap_u},
                                                              {in.wrap_v(), "wrap_v", &ref.wrap_v}};
  for (const auto& [wire, member, out] : wraps) {
    if (wire < 0 || wire >= v1::TextureRef::Wrap_ARRAYSIZE) {
      return invalid(join_field(field, member), absl::StrCat(wire, " is not a wrap mode"));
    }
    *out = static_cast<TextureWrap>(wire);
  }
  ref.transform.offset = {in.offset_u(), in.offset_v()};
  ref.transform.rotation = in.rotation();
  ref.transform.scale = {in.has_scale_u() ? in.scale_u() : 1.0f,
                         in.has_scale_v() ? in.scale_v() : 1.0f};
  const float numbers[] = {ref.transform.offset.x, ref.transform.offset.y, ref.transform.rotation,
                           ref.transform.scale.x, ref.transform.scale.y};
  for (float x : numbers) {
    if (!std::isfinite(x)) return invalid(field, "has a transform number that is not finite");
  }
  return ref;
}

// Bytes one (mesh, array) must deliver according to the header.
size_t expected_bytes(const MeshHeaderCounts& counts, int array) {
  switch (array) {
    case v1::MeshChunk::POSITIONS:
      return counts.vertices * kElementBytes[array];
    case v1::MeshChunk::NORMALS:
      return counts.has_normals ? counts.vertices * kElementBytes[array] : 0;
    case v1::MeshChunk::INDICES:
      return counts.triangles * kElementBytes[array];
    case v1::MeshChunk::MATERIAL_IDS:
      return counts.per_triangle_materials ? counts.triangles * kElementBytes[array] : 0;
    case v1::MeshChunk::TEXCOORDS:
      return counts.has_texcoords ? counts.vertices * kElementBytes[array] : 0;
    case v1::MeshChunk::TANGENTS:
      return counts.has_tangents ? counts.vertices * kElementBytes[array] : 0;
  }
  return 0;
}

// The wire's value of every structure: the one place where the two enums are matched, so that a
// new StructureKind needs a wire value here before it builds.
constexpr std::pair<StructureKind, v1::Structure> kWireStructures[] = {
    // clang-format off
    {StructureKind::kLbvh4, v1::LBVH4},
    {StructureKind::kBinnedSah, v1::BINNED_SAH},
    {StructureKind::kHybrid, v1::HYBRID},
    {StructureKind::kSiblingPair, v1::SIBLING_PAIR},
    {StructureKind::kKdSah, v1::KD_SAH},
    {StructureKind::kKdSiroh, v1::KD_SIROH},
    {StructureKind::kDacrt, v1::DACRT},
    {StructureKind::kBvh8, v1::BVH8},
    // clang-format on
};
static_assert(std::size(kWireStructures) == std::size(kStructureKinds));

// The settings' tables (scene/setting_kinds.h) number their kinds as the proto does.
static_assert(kinds_match_proto<Integrator>(v1::Integrator_ARRAYSIZE));
static_assert(kinds_match_proto<EstimatorKind>(v1::Estimator_ARRAYSIZE));
static_assert(kinds_match_proto<SppmRadius>(v1::SppmRadius_ARRAYSIZE));
static_assert(kinds_match_proto<DensityKernel>(v1::DensityKernel_ARRAYSIZE));
static_assert(kinds_match_proto<BinnedSahReorder>(v1::BinnedSahReorder_ARRAYSIZE));
static_assert(kinds_match_proto<KdTraversal>(v1::KdTraversal_ARRAYSIZE));
static_assert(kinds_match_proto<RefitPolicy>(v1::Refit_ARRAYSIZE));

template <typename Proto, typename Enum>
Proto encode_kind(Enum value) {
  return static_cast<Proto>(kind_wire(value));
}

// A setting's kind from its proto number into `*out`: 0 keeps it, a number of no kind is an error
// that names the field.
template <typename Enum>
absl::Status decode_kind(int wire, std::string_view field, std::string_view name, Enum* out) {
  if (wire == 0) return absl::OkStatus();
  const std::optional<Enum> kind = kind_from_wire<Enum>(static_cast<uint32_t>(wire));
  if (!kind) {
    const std::string_view what = SettingKinds<Enum>::what;
    const bool vowel = std::string_view("aeiou").find(what.front()) != std::string_view::npos;
    return invalid(join_field(field, name),
                   absl::StrCat(wire, " is not ", vowel ? "an " : "a ",
                                absl::string_view(what.data(), what.size())));
  }
  *out = *kind;
  return absl::OkStatus();
}

// One material for the whole mesh: the header names it, and no id per triangle is sent.
bool has_one_material(const Mesh& mesh) {
  return std::all_of(mesh.material_ids.begin(), mesh.material_ids.end(),
                     [&](uint32_t id) { return id == mesh.material_ids.front(); });
}

}  // namespace

uint32_t chunk_crc32(std::string_view bytes) {
  uLong crc = crc32(0L, Z_NULL, 0);
  // zlib takes 32-bit lengths; chunks are 1 MiB, but stay correct for any size.
  while (!bytes.empty()) {
    const size_t n = std::min<size_t>(bytes.size(), 1u << 30);
    crc = crc32(crc, reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uInt>(n));
    bytes.remove_prefix(n);
  }
  return static_cast<uint32_t>(crc);
}

// --- scene model -> wire ---

v1::Vec3 encode_vec3(const Vec3f& v) {
  v1::Vec3 out;
  out.set_x(v.x);
  out.set_y(v.y);
  out.set_z(v.z);
  return out;
}

v1::Material encode_material(const Material& m) {
  v1::Material out;
  out.set_name(m.name);
  switch (m.type) {
    case MaterialType::kDiffuse:
      out.set_type(v1::Material::DIFFUSE);
      break;
    case MaterialType::kMirror:
      out.set_type(v1::Material::MIRROR);
      break;
    case MaterialType::kDielectric:
      out.set_type(v1::Material::DIELECTRIC);
      break;
    case MaterialType::kEmissive:
      out.set_type(v1::Material::EMISSIVE);
      break;
    case MaterialType::kMetallicRoughness:
      out.set_type(v1::Material::METALLIC_ROUGHNESS);
      break;
    case MaterialType::kPhong:
      out.set_type(v1::Material::PHONG);
      break;
  }
  static_assert(kLastMaterialType == MaterialType::kPhong,
                "encode_material and the assembler's decoding know every material type");
  *out.mutable_color() = encode_vec3(m.color);
  out.set_ior(m.ior);
  out.set_metallic(m.metallic);
  out.set_roughness(m.roughness);
  *out.mutable_specular() = encode_vec3(m.specular);
  out.set_exponent(m.exponent);
  *out.mutable_radiance() = encode_vec3(m.radiance);
  out.set_off(m.off);
  if (m.color_map.used()) *out.mutable_color_map() = encode_texture_ref(m.color_map);
  if (m.emission_map.used()) *out.mutable_emission_map() = encode_texture_ref(m.emission_map);
  if (m.metallic_roughness_map.used())
    *out.mutable_metallic_roughness_map() = encode_texture_ref(m.metallic_roughness_map);
  if (m.normal_map.used()) *out.mutable_normal_map() = encode_texture_ref(m.normal_map);
  if (m.normal_scale != 1.0f) out.set_normal_scale(m.normal_scale);
  if (m.roughness_map.used()) *out.mutable_roughness_map() = encode_texture_ref(m.roughness_map);
  if (m.metallic_map.used()) *out.mutable_metallic_map() = encode_texture_ref(m.metallic_map);
  if (m.bump_map.used()) *out.mutable_bump_map() = encode_texture_ref(m.bump_map);
  if (m.bump_scale != 1.0f) out.set_bump_scale(m.bump_scale);
  static_assert(kLastAlphaMode == AlphaMode::kBlend,
                "encode_material and the assembler's decoding know every alpha mode");
  out.set_alpha_mode(static_cast<v1::Material::AlphaMode>(m.alpha_mode));
  if (m.opacity != 1.0f) out.set_opacity(m.opacity);
  if (m.alpha_cutoff != 0.5f) out.set_alpha_cutoff(m.alpha_cutoff);
  if (m.opacity_map.used()) *out.mutable_opacity_map() = encode_texture_ref(m.opacity_map);
  return out;
}

v1::Emitter encode_emitter(const Material& m) {
  v1::Emitter out;
  out.set_material(m.name);
  *out.mutable_radiance() = encode_vec3(m.radiance);
  out.set_off(m.off);
  return out;
}

absl::StatusOr<std::vector<EmitterChange>> decode_emitters(
    const google::protobuf::RepeatedPtrField<v1::Emitter>& emitters, std::string_view field) {
  std::vector<EmitterChange> out;
  for (int i = 0; i < emitters.size(); ++i) {
    const v1::Emitter& in = emitters[i];
    const std::string at = absl::StrCat(as_absl(field), "[", i, "]");
    if (in.material().empty()) return invalid(join_field(at, "material"), "is empty");
    EmitterChange change;
    change.material = in.material();
    if (in.has_radiance()) {
      absl::StatusOr<Vec3f> radiance = decode_vec3(in.radiance(), join_field(at, "radiance"));
      if (!radiance.ok()) return radiance.status();
      change.radiance = *radiance;
    }
    if (in.has_off()) change.off = in.off();
    if (!change.radiance && !change.off) {
      return invalid(at, absl::StrCat("changes nothing of '", in.material(),
                                      "' (give radiance, off or both)"));
    }
    out.push_back(std::move(change));
  }
  return out;
}

v1::Medium encode_medium(const Medium& m) {
  v1::Medium out;
  out.set_name(m.name);
  out.set_type(m.type == MediumType::kGrid ? v1::Medium::GRID : v1::Medium::HOMOGENEOUS);
  *out.mutable_absorption() = encode_vec3(m.absorption);
  *out.mutable_scattering() = encode_vec3(m.scattering);
  out.set_g(m.asymmetry);
  if (m.type == MediumType::kGrid) {
    out.set_grid_bytes(m.grid != nullptr ? m.grid->size() : 0);
    encode_affine(m.grid_to_scene, out.mutable_grid_to_scene());
    out.set_grid_source(m.grid_source);
  }
  return out;
}

// Media by 1 + index, 0 for none, as the proto's defaults want.
uint32_t encode_medium_ref(uint32_t medium) { return medium == kNoMedium ? 0u : medium + 1; }

v1::Light encode_light(const Light& light) {
  v1::Light out;
  out.set_name(light.name);
  switch (light.type) {
    case LightType::kPoint:
      out.set_type(v1::Light::POINT);
      break;
    case LightType::kSpot:
      out.set_type(v1::Light::SPOT);
      break;
    case LightType::kDirectional:
      out.set_type(v1::Light::DIRECTIONAL);
      break;
  }
  *out.mutable_position() = encode_vec3(light.position);
  *out.mutable_direction() = encode_vec3(light.direction);
  *out.mutable_intensity() = encode_vec3(light.intensity);
  out.set_inner_angle_deg(light.inner_angle_deg);
  out.set_outer_angle_deg(light.outer_angle_deg);
  return out;
}

// Textures by 1 + index, 0 for none, as TextureRef's.
v1::Environment encode_environment(const Environment& e) {
  v1::Environment out;
  out.set_texture(e.texture == kNoTexture ? 0u : e.texture + 1);
  *out.mutable_color() = encode_vec3(e.color);
  out.set_intensity(e.intensity);
  out.set_rotation_deg(e.rotation_deg);
  return out;
}

absl::StatusOr<Environment> decode_environment(const v1::Environment& in, size_t textures) {
  Environment e;
  e.present = true;
  if (in.texture() > textures) {
    return invalid("environment.texture",
                   absl::StrCat(in.texture(), " names no texture (the scene has ", textures,
                                " textures; 1 is the first, 0 none)"));
  }
  e.texture = in.texture() == 0 ? kNoTexture : in.texture() - 1;
  if (in.has_color()) {
    absl::StatusOr<Vec3f> color = decode_vec3(in.color(), "environment.color");
    if (!color.ok()) return color.status();
    e.color = *color;
  }
  if (in.has_intensity()) e.intensity = in.intensity();
  e.rotation_deg = in.rotation_deg();
  return e;
}

v1::Camera encode_camera(const Camera& camera) {
  v1::Camera out;
  *out.mutable_position() = encode_vec3(camera.position);
  *out.mutable_look_at() = encode_vec3(camera.look_at);
  *out.mutable_up() = encode_vec3(camera.up);
  out.set_vertical_fov_deg(camera.vertical_fov_deg);
  out.set_width(static_cast<uint32_t>(camera.width));
  out.set_height(static_cast<uint32_t>(camera.height));
  return out;
}

v1::RenderSettings encode_settings(const RenderSettings& s) {
  v1::RenderSettings out;
  out.set_photons_per_pass(s.photons_per_pass);
  out.set_k_nearest(s.k_nearest);
  out.set_max_radius(s.max_radius);
  out.set_kernel(encode_kind<v1::DensityKernel>(s.kernel));
  out.set_max_depth(s.max_depth);
  out.set_max_photon_bounces(s.max_photon_bounces);
  out.set_max_photon_specular_bounces(s.max_photon_specular_bounces);
  out.set_area_light_samples(s.area_light_samples);
  out.set_seed(s.seed);
  out.set_structure(encode_structure(s.structure));
  out.set_integrator(encode_integrator(s.integrator));
  out.set_estimator(encode_estimator(s.estimator));
  out.set_sppm_alpha(s.sppm_alpha);
  out.set_vkde_spread(s.vkde_spread);
  out.set_final_gather(s.final_gather);
  out.set_final_gather_rays(s.final_gather_rays);
  out.set_final_gather_seeds(s.final_gather_seeds);
  out.set_sppm_radius(encode_kind<v1::SppmRadius>(s.sppm_radius));
  v1::BuildOptions& build = *out.mutable_build();
  for (int i = 0; i < s.build.binned_sah.stage_count; ++i) {
    v1::BinnedSahStage& stage = *build.add_binned_sah_stages();
    stage.set_above(s.build.binned_sah.stage[i].above);
    stage.set_bins(s.build.binned_sah.stage[i].bins);
  }
  build.set_binned_sah_reorder(encode_kind<v1::BinnedSahReorder>(s.build.binned_sah.reorder));
  build.set_kd_traversal(encode_kind<v1::KdTraversal>(s.build.kd_traversal));
  build.set_refit(encode_kind<v1::Refit>(s.build.refit));
  build.set_refit_sah_bound(s.build.refit_sah_bound);
  return out;
}

v1::Integrator encode_integrator(Integrator integrator) {
  return encode_kind<v1::Integrator>(integrator);
}

v1::Estimator encode_estimator(EstimatorKind estimator) {
  return encode_kind<v1::Estimator>(estimator);
}

v1::Structure encode_structure(StructureKind kind) {
  for (const auto& [structure_kind, wire_structure] : kWireStructures) {
    if (structure_kind == kind) return wire_structure;
  }
  return v1::STRUCTURE_UNSPECIFIED;
}

v1::SceneHeader encode_scene_header(const Scene& scene, const std::string& name) {
  v1::SceneHeader out;
  out.set_name(name);
  for (const TextureImage& t : scene.textures) {
    v1::TextureHeader* h = out.add_textures();
    h->set_name(t.name);
    h->set_bytes(t.encoded != nullptr ? t.encoded->size() : 0);
  }
  for (const Material& m : scene.materials) *out.add_materials() = encode_material(m);
  for (const Light& l : scene.lights) *out.add_lights() = encode_light(l);
  if (scene.environment.present) *out.mutable_environment() = encode_environment(scene.environment);
  for (const Medium& m : scene.media) *out.add_media() = encode_medium(m);
  out.set_medium(encode_medium_ref(scene.medium));
  *out.mutable_camera() = encode_camera(scene.camera);
  *out.mutable_settings() = encode_settings(scene.settings);
  for (const Mesh& mesh : scene.meshes) {
    v1::MeshHeader* h = out.add_meshes();
    h->set_name(mesh.name);
    h->set_vertex_count(mesh.positions.size());
    h->set_triangle_count(mesh.triangle_count());
    h->set_has_normals(!mesh.normals.empty());
    h->set_has_texcoords(!mesh.uvs.empty());
    h->set_has_tangents(!mesh.tangents.empty());
    h->set_material(mesh.material_ids.empty() ? 0 : mesh.material_ids.front());
    h->set_per_triangle_materials(!has_one_material(mesh));
    h->set_interior_medium(encode_medium_ref(mesh.interior_medium));
  }
  return out;
}

namespace {

// The arrays of one mesh in wire order, with the bytes each sends (empty when not sent).
std::array<std::string_view, kMeshArrays> mesh_arrays(const Mesh& mesh) {
  auto bytes_of = [](const auto& v) {
    return std::string_view(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(v.front()));
  };
  return {std::string_view(),
          bytes_of(mesh.positions),
          bytes_of(mesh.normals),
          bytes_of(mesh.indices),
          has_one_material(mesh) ? std::string_view() : bytes_of(mesh.material_ids),
          bytes_of(mesh.uvs),
          bytes_of(mesh.tangents)};
}

}  // namespace

// A grid medium's buffer, empty for every other medium.
std::string_view grid_of(const Medium& m) {
  if (m.type != MediumType::kGrid || m.grid == nullptr) return {};
  return std::string_view(reinterpret_cast<const char*>(m.grid->data()), m.grid->size());
}

std::string_view file_of(const TextureImage& t) {
  return t.encoded != nullptr ? std::string_view(*t.encoded) : std::string_view();
}

// Emits `bytes` (a grid's buffer, a texture's file) in chunks of at most `max_chunk_bytes`, each
// in the part of `chunk` that `part(chunk)` names and returns; false when `emit` stops early.
template <typename Part>
bool emit_blob(std::string_view bytes, size_t max_chunk_bytes, v1::SceneChunk& chunk, Part part,
               const std::function<bool(v1::SceneChunk& chunk)>& emit) {
  for (size_t offset = 0; offset < bytes.size(); offset += max_chunk_bytes) {
    const std::string_view piece = bytes.substr(offset, max_chunk_bytes);
    auto* blob = part(chunk);
    blob->set_offset(offset);
    blob->set_data(piece.data(), piece.size());
    blob->set_crc32(chunk_crc32(piece));
    if (!emit(chunk)) return false;
  }
  return true;
}

size_t upload_bytes(const Scene& scene) {
  size_t total = 0;
  for (const Mesh& mesh : scene.meshes)
    for (std::string_view a : mesh_arrays(mesh)) total += a.size();
  for (const Medium& m : scene.media) total += grid_of(m).size();
  for (const TextureImage& t : scene.textures) total += file_of(t).size();
  return total;
}

bool for_each_array_chunk(uint32_t mesh, v1::MeshChunk::Array array, std::string_view bytes,
                          size_t max_chunk_bytes, v1::MeshChunk& chunk,
                          const std::function<bool()>& emit) {
  max_chunk_bytes = std::clamp<size_t>(max_chunk_bytes, 16 * sizeof(float), kMaxChunkBytes);
  // Whole elements per chunk, so the receiver can check each chunk on its own.
  const size_t step = max_chunk_bytes / kElementBytes[array] * kElementBytes[array];
  for (size_t offset = 0; offset < bytes.size(); offset += step) {
    const std::string_view piece = bytes.substr(offset, step);
    chunk.set_mesh(mesh);
    chunk.set_array(array);
    chunk.set_offset(offset);
    chunk.set_data(piece.data(), piece.size());
    chunk.set_crc32(chunk_crc32(piece));
    if (!emit()) return false;
  }
  return true;
}

bool for_each_chunk(const Scene& scene, size_t max_chunk_bytes,
                    const std::function<bool(v1::SceneChunk& chunk)>& emit) {
  max_chunk_bytes = std::clamp<size_t>(max_chunk_bytes, 16 * sizeof(float), kMaxChunkBytes);
  v1::SceneChunk chunk;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const std::array<std::string_view, kMeshArrays> arrays = mesh_arrays(scene.meshes[m]);
    for (int a = 1; a < kMeshArrays; ++a) {
      if (!for_each_array_chunk(uint32_t(m), static_cast<v1::MeshChunk::Array>(a), arrays[a],
                                max_chunk_bytes, *chunk.mutable_mesh(),
                                [&] { return emit(chunk); })) {
        return false;
      }
    }
  }
  for (size_t m = 0; m < scene.media.size(); ++m) {
    const auto grid = [m](v1::SceneChunk& c) {
      v1::GridChunk* part = c.mutable_grid();
      part->set_medium(static_cast<uint32_t>(m));
      return part;
    };
    if (!emit_blob(grid_of(scene.media[m]), max_chunk_bytes, chunk, grid, emit)) return false;
  }
  for (size_t t = 0; t < scene.textures.size(); ++t) {
    const auto texture = [t](v1::SceneChunk& c) {
      v1::TextureChunk* part = c.mutable_texture();
      part->set_texture(static_cast<uint32_t>(t));
      return part;
    };
    if (!emit_blob(file_of(scene.textures[t]), max_chunk_bytes, chunk, texture, emit)) {
      return false;
    }
  }
  return true;
}

// --- wire -> scene model ---

absl::StatusOr<Vec3f> decode_vec3(const v1::Vec3& v, std::string_view field) {
  Vec3f out(v.x(), v.y(), v.z());
  if (!is_finite(out)) {
    return invalid(field, absl::StrFormat("(%g, %g, %g) is not finite", v.x(), v.y(), v.z()));
  }
  return out;
}

absl::StatusOr<Light> decode_light(const v1::Light& in, std::string_view field) {
  Light light;
  light.name = in.name();
  switch (in.type()) {
    case v1::Light::POINT:
      light.type = LightType::kPoint;
      break;
    case v1::Light::SPOT:
      light.type = LightType::kSpot;
      break;
    case v1::Light::DIRECTIONAL:
      light.type = LightType::kDirectional;
      break;
    default:
      return invalid(join_field(field, "type"),
                     absl::StrCat(in.type(), " is not a light type (POINT, SPOT or DIRECTIONAL)"));
  }
  // Only the fields the type uses must be set; absent messages read as zero vectors.
  absl::StatusOr<Vec3f> position = decode_vec3(in.position(), join_field(field, "position"));
  if (!position.ok()) return position.status();
  absl::StatusOr<Vec3f> direction = decode_vec3(in.direction(), join_field(field, "direction"));
  if (!direction.ok()) return direction.status();
  absl::StatusOr<Vec3f> intensity = decode_vec3(in.intensity(), join_field(field, "intensity"));
  if (!intensity.ok()) return intensity.status();
  light.position = *position;
  light.direction = *direction;
  light.intensity = *intensity;
  light.inner_angle_deg = in.inner_angle_deg();
  light.outer_angle_deg = in.outer_angle_deg();
  return light;
}

absl::StatusOr<std::vector<Light>> decode_lights(
    const google::protobuf::RepeatedPtrField<v1::Light>& lights, std::string_view field) {
  std::vector<Light> out;
  out.reserve(lights.size());
  for (int i = 0; i < lights.size(); ++i) {
    absl::StatusOr<Light> light =
        decode_light(lights[i], absl::StrCat(as_absl(field), "[", i, "]"));
    if (!light.ok()) return light.status();
    out.push_back(*std::move(light));
  }
  return out;
}

absl::StatusOr<Camera> decode_camera_at(const v1::Camera& in, std::string_view field, int width,
                                        int height) {
  Camera camera;
  absl::StatusOr<Vec3f> position = decode_vec3(in.position(), join_field(field, "position"));
  if (!position.ok()) return position.status();
  absl::StatusOr<Vec3f> look_at = decode_vec3(in.look_at(), join_field(field, "look_at"));
  if (!look_at.ok()) return look_at.status();
  absl::StatusOr<Vec3f> up = decode_vec3(in.up(), join_field(field, "up"));
  if (!up.ok()) return up.status();
  camera.position = *position;
  camera.look_at = *look_at;
  camera.up = *up;
  camera.vertical_fov_deg = in.vertical_fov_deg();
  camera.width = width;
  camera.height = height;
  return camera;
}

absl::StatusOr<Camera> decode_camera(const v1::Camera& in, std::string_view field) {
  absl::StatusOr<Camera> camera = decode_camera_at(in, field, 0, 0);
  if (!camera.ok()) return camera.status();
  // Sizes beyond int would wrap; anything over the limit is refused by validation anyway.
  for (auto [name, value] : {std::pair{"width", in.width()}, std::pair{"height", in.height()}}) {
    if (value == 0 || value > uint32_t(kMaxImageSide)) {
      return invalid(join_field(field, name),
                     absl::StrCat(value, " is outside [1, ", kMaxImageSide, "]"));
    }
  }
  camera->width = static_cast<int>(in.width());
  camera->height = static_cast<int>(in.height());
  return camera;
}

std::optional<StructureKind> decode_structure(v1::Structure structure) {
  for (const auto& [structure_kind, wire_structure] : kWireStructures) {
    if (wire_structure == structure) return structure_kind;
  }
  return std::nullopt;
}

namespace {

// The set fields of `in` over `options`; the stages' values are checked with the other settings
// (validate_settings), only their number here, where it must fit the schedule.
absl::Status apply_build_options(const v1::BuildOptions& in, const std::string& field,
                                 BuildOptions& options) {
  if (in.binned_sah_stages_size() > kMaxBinnedSahStages) {
    return invalid(
        join_field(field, "binned_sah_stages"),
        absl::StrCat(in.binned_sah_stages_size(), " stages; at most ", kMaxBinnedSahStages));
  }
  if (!in.binned_sah_stages().empty()) {
    BinnedSahSchedule& schedule = options.binned_sah;
    std::fill(std::begin(schedule.stage), std::end(schedule.stage), BinnedSahStage{});
    schedule.stage_count = in.binned_sah_stages_size();
    for (int i = 0; i < schedule.stage_count; ++i) {
      schedule.stage[i] = {in.binned_sah_stages(i).above(), in.binned_sah_stages(i).bins()};
    }
  }
  if (absl::Status status = decode_kind(in.binned_sah_reorder(), field, "binned_sah_reorder",
                                        &options.binned_sah.reorder);
      !status.ok()) {
    return status;
  }
  if (absl::Status status =
          decode_kind(in.kd_traversal(), field, "kd_traversal", &options.kd_traversal);
      !status.ok()) {
    return status;
  }
  if (in.has_refit_sah_bound()) options.refit_sah_bound = in.refit_sah_bound();
  return decode_kind(in.refit(), field, "refit", &options.refit);
}

}  // namespace

absl::StatusOr<RenderSettings> apply_settings(const v1::RenderSettings& in,
                                              const RenderSettings& current,
                                              std::string_view field) {
  RenderSettings s = current;
  if (in.has_photons_per_pass()) s.photons_per_pass = in.photons_per_pass();
  if (in.has_k_nearest()) s.k_nearest = in.k_nearest();
  if (in.has_max_radius()) s.max_radius = in.max_radius();
  if (absl::Status status = decode_kind(in.kernel(), field, "kernel", &s.kernel); !status.ok()) {
    return status;
  }
  if (in.has_max_depth()) s.max_depth = in.max_depth();
  if (in.has_max_photon_bounces()) s.max_photon_bounces = in.max_photon_bounces();
  if (in.has_max_photon_specular_bounces())
    s.max_photon_specular_bounces = in.max_photon_specular_bounces();
  if (in.has_area_light_samples()) s.area_light_samples = in.area_light_samples();
  if (in.has_seed()) s.seed = in.seed();
  if (in.structure() != v1::STRUCTURE_UNSPECIFIED) {
    const std::optional<StructureKind> structure = decode_structure(in.structure());
    if (!structure) {
      return invalid(join_field(field, "structure"),
                     absl::StrCat(in.structure(), " is not a structure"));
    }
    s.structure = *structure;
  }
  if (absl::Status status = decode_kind(in.integrator(), field, "integrator", &s.integrator);
      !status.ok()) {
    return status;
  }
  if (absl::Status status = decode_kind(in.estimator(), field, "estimator", &s.estimator);
      !status.ok()) {
    return status;
  }
  if (in.has_sppm_alpha()) s.sppm_alpha = in.sppm_alpha();
  if (in.has_vkde_spread()) s.vkde_spread = in.vkde_spread();
  if (in.has_final_gather()) s.final_gather = in.final_gather();
  if (in.has_final_gather_rays()) s.final_gather_rays = in.final_gather_rays();
  if (in.has_final_gather_seeds()) s.final_gather_seeds = in.final_gather_seeds();
  if (absl::Status status = decode_kind(in.sppm_radius(), field, "sppm_radius", &s.sppm_radius);
      !status.ok()) {
    return status;
  }
  if (absl::Status status = apply_build_options(in.build(), join_field(field, "build"), s.build);
      !status.ok()) {
    return status;
  }
  return s;
}

// --- SceneAssembler ---

absl::Status SceneAssembler::add(const v1::SceneChunk& chunk) {
  const size_t index = chunks_++;
  absl::Status status;
  switch (chunk.payload_case()) {
    case v1::SceneChunk::kHeader:
      status = add_header(chunk.header());
      break;
    case v1::SceneChunk::kMesh:
      status = add_mesh_chunk(chunk.mesh());
      break;
    case v1::SceneChunk::kGrid:
      status = add_grid_chunk(chunk.grid());
      break;
    case v1::SceneChunk::kTexture:
      status = add_texture_chunk(chunk.texture());
      break;
    default:
      status =
          absl::InvalidArgumentError("carries neither a header nor a mesh, grid or texture chunk");
  }
  if (status.ok()) return status;
  return absl::Status(status.code(), absl::StrCat("chunk ", index, ": ", status.message()));
}

absl::StatusOr<uint32_t> SceneAssembler::decode_medium_ref(uint32_t value,
                                                           const std::string& field) const {
  if (value == 0) return kNoMedium;
  if (value > scene_.media.size()) {
    return invalid(field, absl::StrCat(value, " names no medium (the scene has ",
                                       scene_.media.size(), " media; 1 is the first, 0 none)"));
  }
  return value - 1;
}

absl::Status SceneAssembler::add_header(const v1::SceneHeader& header) {
  if (header.placements_size() != 0) {
    return invalid("placements", "are a stored scene's state, never part of an upload");
  }
  if (has_header_) return invalid("header", "a second header (the header comes once, first)");
  name_ = header.name();
  if (size_t(header.textures_size()) > kMaxTextures) {
    return absl::ResourceExhaustedError(
        absl::StrCat("textures: ", header.textures_size(), " exceed the limit of ", kMaxTextures));
  }
  for (int i = 0; i < header.textures_size(); ++i) {
    const v1::TextureHeader& in = header.textures(i);
    const std::string field = absl::StrCat("textures[", i, "] '", in.name(), "'");
    if (in.bytes() == 0) return invalid(join_field(field, "bytes"), "is 0");
    if (in.bytes() > kMaxTextureFileBytes) {
      return absl::ResourceExhaustedError(absl::StrCat(
          field, ".bytes: ", in.bytes(), " exceed the limit of ", kMaxTextureFileBytes));
    }
    TextureImage t;
    t.name = in.name().empty() ? absl::StrCat("texture", i) : in.name();
    scene_.textures.push_back(std::move(t));
    texture_declared_.push_back(in.bytes());
    texture_received_.push_back(0);
    texture_files_.emplace_back();
    bytes_declared_ += in.bytes();
  }
  for (int i = 0; i < header.materials_size(); ++i) {
    const v1::Material& in = header.materials(i);
    const std::string field = absl::StrCat("materials[", i, "]");
    Material m;
    m.name = in.name().empty() ? absl::StrCat("material", i) : in.name();
    switch (in.type()) {
      case v1::Material::DIFFUSE:
        m.type = MaterialType::kDiffuse;
        break;
      case v1::Material::MIRROR:
        m.type = MaterialType::kMirror;
        break;
      case v1::Material::DIELECTRIC:
        m.type = MaterialType::kDielectric;
        break;
      case v1::Material::EMISSIVE:
        m.type = MaterialType::kEmissive;
        break;
      case v1::Material::METALLIC_ROUGHNESS:
        m.type = MaterialType::kMetallicRoughness;
        break;
      case v1::Material::PHONG:
        m.type = MaterialType::kPhong;
        break;
      default:
        return invalid(join_field(field, "type"),
                       absl::StrCat(in.type(), " is not a material type"));
    }
    absl::StatusOr<Vec3f> color = decode_vec3(in.color(), join_field(field, "color"));
    if (!color.ok()) return color.status();
    absl::StatusOr<Vec3f> radiance = decode_vec3(in.radiance(), join_field(field, "radiance"));
    if (!radiance.ok()) return radiance.status();
    absl::StatusOr<Vec3f> specular = decode_vec3(in.specular(), join_field(field, "specular"));
    if (!specular.ok()) return specular.status();
    m.color = *color;
    m.radiance = *radiance;
    m.off = in.off();
    m.ior = in.ior();
    // Range checks are validate_scene's, as for the colours.
    m.metallic = in.metallic();
    m.roughness = in.roughness();
    m.specular = *specular;
    m.exponent = in.exponent();
    if (in.has_normal_scale()) m.normal_scale = in.normal_scale();
    if (in.has_bump_scale()) m.bump_scale = in.bump_scale();
    if (!v1::Material::AlphaMode_IsValid(in.alpha_mode())) {
      return invalid(
          join_field(field, "alpha_mode"),
          absl::StrCat(in.alpha_mode(), " is not an alpha mode (OPAQUE, MASK or BLEND)"));
    }
    m.alpha_mode = static_cast<AlphaMode>(in.alpha_mode());
    if (in.has_opacity()) m.opacity = in.opacity();
    if (in.has_alpha_cutoff()) m.alpha_cutoff = in.alpha_cutoff();
    for (const auto& [map, name, has, get] :
         {std::tuple{&m.color_map, "color_map", &v1::Material::has_color_map,
                     &v1::Material::color_map},
          std::tuple{&m.emission_map, "emission_map", &v1::Material::has_emission_map,
                     &v1::Material::emission_map},
          std::tuple{&m.metallic_roughness_map, "metallic_roughness_map",
                     &v1::Material::has_metallic_roughness_map,
                     &v1::Material::metallic_roughness_map},
          std::tuple{&m.roughness_map, "roughness_map", &v1::Material::has_roughness_map,
                     &v1::Material::roughness_map},
          std::tuple{&m.metallic_map, "metallic_map", &v1::Material::has_metallic_map,
                     &v1::Material::metallic_map},
          std::tuple{&m.normal_map, "normal_map", &v1::Material::has_normal_map,
                     &v1::Material::normal_map},
          std::tuple{&m.bump_map, "bump_map", &v1::Material::has_bump_map, &v1::Material::bump_map},
          std::tuple{&m.opacity_map, "opacity_map", &v1::Material::has_opacity_map,
                     &v1::Material::opacity_map}}) {
      if (!(in.*has)()) continue;
      absl::StatusOr<TextureRef> ref =
          decode_texture_ref((in.*get)(), join_field(field, name), scene_.textures.size());
      if (!ref.ok()) return ref.status();
      *map = *ref;
    }
    scene_.materials.push_back(std::move(m));
  }
  for (int i = 0; i < header.media_size(); ++i) {
    const v1::Medium& in = header.media(i);
    const std::string field = absl::StrCat("media[", i, "]");
    Medium m;
    m.name = in.name().empty() ? absl::StrCat("medium", i) : in.name();
    if (in.type() != v1::Medium::HOMOGENEOUS && in.type() != v1::Medium::GRID) {
      return invalid(join_field(field, "type"),
                     absl::StrCat(in.type(), " is not a medium type (HOMOGENEOUS or GRID)"));
    }
    m.type = in.type() == v1::Medium::GRID ? MediumType::kGrid : MediumType::kHomogeneous;
    uint64_t grid_bytes = 0;
    if (absl::StatusOr<uint64_t> bytes = decode_grid_header(in, field, &m); bytes.ok()) {
      grid_bytes = *bytes;
    } else {
      return bytes.status();
    }
    grid_declared_.push_back(grid_bytes);
    grid_received_.push_back(0);
    grids_.emplace_back();
    bytes_declared_ += grid_bytes;
    absl::StatusOr<Vec3f> absorption =
        decode_vec3(in.absorption(), join_field(field, "absorption"));
    if (!absorption.ok()) return absorption.status();
    absl::StatusOr<Vec3f> scattering =
        decode_vec3(in.scattering(), join_field(field, "scattering"));
    if (!scattering.ok()) return scattering.status();
    m.absorption = *absorption;
    m.scattering = *scattering;
    m.asymmetry = in.g();
    scene_.media.push_back(std::move(m));
  }
  absl::StatusOr<uint32_t> medium = decode_medium_ref(header.medium(), "medium");
  if (!medium.ok()) return medium.status();
  scene_.medium = *medium;
  absl::StatusOr<std::vector<Light>> lights = decode_lights(header.lights(), "lights");
  if (!lights.ok()) return lights.status();
  scene_.lights = *std::move(lights);
  if (header.has_environment()) {
    absl::StatusOr<Environment> environment =
        decode_environment(header.environment(), scene_.textures.size());
    if (!environment.ok()) return environment.status();
    scene_.environment = *environment;
  }
  absl::StatusOr<Camera> camera = decode_camera(header.camera(), "camera");
  if (!camera.ok()) return camera.status();
  scene_.camera = *camera;
  absl::StatusOr<RenderSettings> settings =
      apply_settings(header.settings(), RenderSettings{}, "settings");
  if (!settings.ok()) return settings.status();
  scene_.settings = *settings;

  progress_.resize(header.meshes_size());
  counts_.resize(header.meshes_size());
  uint64_t scene_triangles = 0;
  for (int i = 0; i < header.meshes_size(); ++i) {
    const v1::MeshHeader& h = header.meshes(i);
    const std::string field = absl::StrCat("meshes[", i, "] '", h.name(), "'");
    // Limits first: nothing is allocated for a header that asks for absurd sizes.
    if (h.vertex_count() > kMaxVerticesPerMesh) {
      return absl::ResourceExhaustedError(absl::StrCat(field, ".vertex_count: ", h.vertex_count(),
                                                       " exceeds the limit of ",
                                                       kMaxVerticesPerMesh));
    }
    if (h.triangle_count() > kMaxTrianglesPerMesh) {
      return absl::ResourceExhaustedError(
          absl::StrCat(field, ".triangle_count: ", h.triangle_count(), " exceeds the limit of ",
                       kMaxTrianglesPerMesh));
    }
    if (h.triangle_count() == 0) return invalid(join_field(field, "triangle_count"), "is 0");
    // Each mesh is within its limit here, so the sum cannot overflow.
    scene_triangles += h.triangle_count();
    if (scene_triangles > kMaxSceneTriangles) {
      return absl::ResourceExhaustedError(
          absl::StrCat("meshes: the header declares ", scene_triangles, " triangles in meshes[0..",
                       i, "] alone, more than the limit of ", kMaxSceneTriangles, " per scene"));
    }
    if (!h.per_triangle_materials() && h.material() >= scene_.materials.size()) {
      return invalid(join_field(field, "material"),
                     absl::StrCat(h.material(), " is out of range (the scene has ",
                                  scene_.materials.size(), " materials)"));
    }
    if (h.has_tangents() && !h.has_normals()) {
      return invalid(join_field(field, "has_tangents"),
                     "is set without has_normals (a tangent frame needs both)");
    }
    counts_[i] = {.vertices = h.vertex_count(),
                  .triangles = h.triangle_count(),
                  .has_normals = h.has_normals(),
                  .has_texcoords = h.has_texcoords(),
                  .has_tangents = h.has_tangents(),
                  .per_triangle_materials = h.per_triangle_materials(),
                  .material = h.material()};
    for (int a = 1; a < kMeshArrays; ++a) bytes_declared_ += expected_bytes(counts_[i], a);
    // Arrays are allocated as their data arrives, after the server has checked the declared
    // bytes against its memory budget; a one-material mesh's ids are filled in by finish().
    Mesh mesh;
    mesh.name = h.name().empty() ? absl::StrCat("mesh", i) : h.name();
    absl::StatusOr<uint32_t> interior =
        decode_medium_ref(h.interior_medium(), join_field(field, "interior_medium"));
    if (!interior.ok()) return interior.status();
    mesh.interior_medium = *interior;
    scene_.meshes.push_back(std::move(mesh));
  }
  has_header_ = true;
  return absl::OkStatus();
}

absl::StatusOr<uint64_t> SceneAssembler::decode_grid_header(const v1::Medium& in,
                                                            const std::string& field,
                                                            Medium* m) const {
  if (m->type != MediumType::kGrid) {
    if (in.grid_bytes() != 0 || in.grid_to_scene_size() != 0) {
      return invalid(join_field(field, "grid_bytes"), "a HOMOGENEOUS medium carries no grid");
    }
    return 0;
  }
  if (in.grid_bytes() == 0) return invalid(join_field(field, "grid_bytes"), "is 0");
  if (in.grid_bytes() > kMaxGridBytes) {
    return absl::ResourceExhaustedError(absl::StrCat(field, ".grid_bytes: ", in.grid_bytes(),
                                                     " exceeds the limit of ", kMaxGridBytes));
  }
  absl::StatusOr<Affine> placed =
      decode_affine(in.grid_to_scene(), join_field(field, "grid_to_scene"));
  if (!placed.ok()) return placed.status();
  m->grid_to_scene = *placed;
  m->grid_source = in.grid_source();
  return in.grid_bytes();
}

absl::Status SceneAssembler::add_grid_chunk(const v1::GridChunk& chunk) {
  if (!has_header_) return invalid("grid", "arrives before the scene header");
  if (chunk.medium() >= scene_.media.size() ||
      scene_.media[chunk.medium()].type != MediumType::kGrid) {
    return invalid("grid.medium", absl::StrCat(chunk.medium(), " is not a GRID medium's index"));
  }
  const uint32_t m = chunk.medium();
  const std::string where = absl::StrCat("medium '", scene_.media[m].name, "' grid");
  return receive_blob_chunk("grid", where, chunk, grid_received_[m], grid_declared_[m],
                            bytes_received_, [&](const std::string& data, uint64_t at) {
                              if (grids_[m] == nullptr) {
                                grids_[m] = std::make_shared<AlignedBytes>(grid_declared_[m]);
                              }
                              std::memcpy(grids_[m]->data() + at, data.data(), data.size());
                            });
}

absl::Status SceneAssembler::add_texture_chunk(const v1::TextureChunk& chunk) {
  if (!has_header_) return invalid("texture", "arrives before the scene header");
  if (chunk.texture() >= scene_.textures.size()) {
    return invalid("texture.texture",
                   absl::StrCat(chunk.texture(), " is out of range (the header declares ",
                                scene_.textures.size(), " textures)"));
  }
  const uint32_t t = chunk.texture();
  const std::string where = absl::StrCat("texture '", scene_.textures[t].name, "'");
  return receive_blob_chunk("texture", where, chunk, texture_received_[t], texture_declared_[t],
                            bytes_received_, [&](const std::string& data, uint64_t) {
                              if (texture_files_[t] == nullptr) {
                                texture_files_[t] = std::make_shared<std::string>();
                                texture_files_[t]->reserve(texture_declared_[t]);
                              }
                              texture_files_[t]->append(data);
                            });
}

absl::Status SceneAssembler::add_mesh_chunk(const v1::MeshChunk& chunk) {
  if (!has_header_) return invalid("mesh", "arrives before the scene header");
  if (chunk.mesh() >= scene_.meshes.size()) {
    return invalid("mesh.mesh", absl::StrCat(chunk.mesh(), " is out of range (the header declares ",
                                             scene_.meshes.size(), " meshes)"));
  }
  const int a = chunk.array();
  if (a < 1 || a >= kMeshArrays) {
    return invalid("mesh.array", absl::StrCat(a, " is not an array kind"));
  }
  Mesh& mesh = scene_.meshes[chunk.mesh()];
  const MeshHeaderCounts& counts = counts_[chunk.mesh()];
  const std::string where = absl::StrCat("mesh '", mesh.name, "' ", kArrayNames[a]);
  const std::string& data = chunk.data();
  if (data.size() > kMaxChunkBytes) {
    return invalid("mesh.data", absl::StrCat(where, ": ", data.size(), " bytes exceed the ",
                                             kMaxChunkBytes, "-byte chunk limit"));
  }
  if (data.empty()) return invalid("mesh.data", absl::StrCat(where, ": is empty"));
  if (data.size() % kElementBytes[a] != 0) {
    return invalid("mesh.data",
                   absl::StrCat(where, ": ", data.size(), " bytes are not a whole number of ",
                                kElementBytes[a], "-byte elements"));
  }
  if (chunk_crc32(data) != chunk.crc32()) {
    return invalid("mesh.crc32", absl::StrFormat("%s: checksum %08x does not match the data (%08x)",
                                                 where, chunk.crc32(), chunk_crc32(data)));
  }
  size_t& received = progress_[chunk.mesh()].received[a];
  if (chunk.offset() != received) {
    return invalid("mesh.offset", absl::StrCat(where, ": offset ", chunk.offset(), " but ",
                                               received, " bytes arrived so far"));
  }
  const size_t expected = expected_bytes(counts, a);
  if (received + data.size() > expected) {
    return invalid("mesh.data",
                   absl::StrCat(where, ": ", received + data.size(), " bytes exceed the ", expected,
                                " the header declares"));
  }
  // Checks per element, so the error names the vertex or triangle like a scene file's would.
  const auto bad = [&](const std::string& problem) {
    return invalid("mesh.data", absl::StrCat(where, ": ", problem));
  };
  const auto not_finite = [&](size_t vertex, std::initializer_list<float> values) {
    return bad(absl::StrCat("vertex ", vertex, " is (", absl::StrJoin(values, ", "),
                            "), not finite"));
  };
  absl::Status appended;
  switch (a) {
    case v1::MeshChunk::POSITIONS:
    case v1::MeshChunk::NORMALS:
      appended = append_elements(a == v1::MeshChunk::POSITIONS ? mesh.positions : mesh.normals,
                                 counts.vertices, data, received, [&](Vec3f v, size_t i) {
                                   return is_finite(v) ? absl::OkStatus()
                                                        : not_finite(i, {v.x, v.y, v.z});
                                 });
      break;
    case v1::MeshChunk::INDICES:
      appended = append_elements(mesh.indices, 3 * counts.triangles, data, received,
                                 [&](uint32_t vertex, size_t i) {
                                   if (vertex < counts.vertices) return absl::OkStatus();
                                   return bad(absl::StrCat("triangle ", i / 3, " refers to vertex ",
                                                           vertex, " of ", counts.vertices));
                                 });
      break;
    case v1::MeshChunk::MATERIAL_IDS:
      appended = append_elements(mesh.material_ids, counts.triangles, data, received,
                                 [&](uint32_t material, size_t i) {
                                   if (material < scene_.materials.size()) return absl::OkStatus();
                                   return bad(absl::StrCat("triangle ", i, " uses material ",
                                                           material, " of ",
                                                           scene_.materials.size()));
                                 });
      break;
    case v1::MeshChunk::TEXCOORDS:
      appended = append_elements(mesh.uvs, counts.vertices, data, received, [&](Vec2f uv, size_t i) {
        return std::isfinite(uv.x) && std::isfinite(uv.y) ? absl::OkStatus()
                                                          : not_finite(i, {uv.x, uv.y});
      });
      break;
    case v1::MeshChunk::TANGENTS:
      appended = append_elements(mesh.tangents, counts.vertices, data, received,
                                 [&](const Vec4f& t, size_t i) {
                                   absl::Status s = check_tangent(t);
                                   if (s.ok()) return s;
                                   return bad(absl::StrCat("vertex ", i, " is ", s.message()));
                                 });
      break;
  }
  if (!appended.ok()) return appended;
  received += data.size();
  bytes_received_ += data.size();
  return absl::OkStatus();
}

absl::StatusOr<Scene> SceneAssembler::finish() {
  if (!has_header_) return invalid("header", "the upload ended before the scene header");
  for (size_t m = 0; m < scene_.meshes.size(); ++m) {
    for (int a = 1; a < kMeshArrays; ++a) {
      const size_t expected = expected_bytes(counts_[m], a);
      const size_t got = progress_[m].received[a];
      if (got != expected) {
        return invalid(absl::StrCat("meshes[", m, "] '", scene_.meshes[m].name, "'"),
                       absl::StrCat(kArrayNames[a], " has ", got, " bytes but the header declares ",
                                    expected, " (", kElementBytes[a], " per element)"));
      }
    }
  }
  for (size_t m = 0; m < scene_.media.size(); ++m) {
    if (grid_received_[m] != grid_declared_[m]) {
      return invalid(absl::StrCat("media[", m, "] '", scene_.media[m].name, "'"),
                     absl::StrCat("grid has ", grid_received_[m], " bytes but the header declares ",
                                  grid_declared_[m]));
    }
    scene_.media[m].grid = std::move(grids_[m]);
  }
  for (size_t t = 0; t < scene_.textures.size(); ++t) {
    if (texture_received_[t] != texture_declared_[t]) {
      return invalid(absl::StrCat("textures[", t, "] '", scene_.textures[t].name, "'"),
                     absl::StrCat("has ", texture_received_[t], " bytes but the header declares ",
                                  texture_declared_[t]));
    }
    scene_.textures[t].encoded = std::move(texture_files_[t]);
  }
  for (size_t m = 0; m < scene_.meshes.size(); ++m) {
    if (!counts_[m].per_triangle_materials)
      scene_.meshes[m].material_ids.assign(counts_[m].triangles, counts_[m].material);
  }
  return std::move(scene_);
}

v1::MeshUpdate encode_mesh_change(const MeshChange& change) {
  v1::MeshUpdate out;
  out.set_mesh(change.mesh);
  if (change.transform) encode_affine(*change.transform, out.mutable_transform());
  const auto add_vectors = [](const std::vector<Vec3f>& vectors,
                              google::protobuf::RepeatedField<float>* to) {
    to->Reserve(int(3 * vectors.size()));
    for (const Vec3f& v : vectors) {
      to->Add(v.x);
      to->Add(v.y);
      to->Add(v.z);
    }
  };
  if (change.positions) add_vectors(*change.positions, out.mutable_positions());
  if (change.normals) add_vectors(*change.normals, out.mutable_normals());
  return out;
}

absl::StatusOr<std::vector<MeshChange>> decode_mesh_changes(
    const google::protobuf::RepeatedPtrField<v1::MeshUpdate>& meshes, std::string_view field) {
  std::vector<MeshChange> changes;
  for (int i = 0; i < meshes.size(); ++i) {
    const v1::MeshUpdate& in = meshes[i];
    const std::string at = absl::StrCat(as_absl(field), "[", i, "]");
    MeshChange& change = changes.emplace_back();
    if (in.mesh().empty()) return invalid(join_field(at, "mesh"), "is missing");
    change.mesh = in.mesh();
    if (in.transform_size() != 0) {
      absl::StatusOr<Affine> t = decode_affine(in.transform(), join_field(at, "transform"));
      if (!t.ok()) return t.status();
      change.transform = *t;
    }
    for (const auto& [values, name, out] :
         {std::tuple{&in.positions(), "positions", &change.positions},
          std::tuple{&in.normals(), "normals", &change.normals}}) {
      if (values->empty()) continue;
      if (values->size() % 3 != 0) {
        return invalid(join_field(at, name),
                       absl::StrCat("has ", values->size(), " numbers, not three per vertex"));
      }
      std::vector<Vec3f>& vectors = out->emplace();
      vectors.reserve(size_t(values->size()) / 3);
      for (int k = 0; k < values->size(); k += 3) {
        const Vec3f v{values->Get(k), values->Get(k + 1), values->Get(k + 2)};
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) {
          return invalid(absl::StrCat(join_field(at, name), "[", k / 3, "]"),
                         absl::StrFormat("(%g, %g, %g) is not finite", v.x, v.y, v.z));
        }
        vectors.push_back(v);
      }
    }
  }
  return changes;
}

}  // namespace caustica::wire
