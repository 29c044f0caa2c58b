#include "renderer/scene/mesh_gltf.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <exception>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/strip.h"
#include "renderer/scene/file_io.h"
#include "renderer/scene/gltf_model.h"
#include "renderer/scene/scene_limits.h"
#include "renderer/scene/status_util.h"
#include "renderer/scene/texture_files.h"
#include "renderer/scene/transform.h"
#include "renderer/scene/validate.h"

namespace caustica {
namespace {

using Json = nlohmann::json;

constexpr double kRadiansToDegrees = 180.0 / 3.14159265358979323846;

TextureWrap wrap_mode(int gltf) {
  switch (gltf) {
    case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE:
      return TextureWrap::kClampToEdge;
    case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT:
      return TextureWrap::kMirroredRepeat;
    default:
      return TextureWrap::kRepeat;
  }
}

// Two numbers of an extension's array member, or `fallback`.
Vec2f extension_pair(const tinygltf::Value& extension, const std::string& key, Vec2f fallback) {
  if (!extension.Has(key)) return fallback;
  const tinygltf::Value& v = extension.Get(key);
  if (!v.IsArray() || v.ArrayLen() < 2 || !v.Get(0).IsNumber() || !v.Get(1).IsNumber()) {
    return fallback;
  }
  return {static_cast<float>(v.Get(0).GetNumberAsDouble()),
          static_cast<float>(v.Get(1).GetNumberAsDouble())};
}

// A number inside a material extension, e.g. KHR_materials_ior.ior, or `fallback`.
double extension_number(const tinygltf::ExtensionMap& extensions, const std::string& extension,
                        const std::string& key, double fallback) {
  const auto it = extensions.find(extension);
  if (it == extensions.end() || !it->second.IsObject() || !it->second.Has(key)) return fallback;
  const tinygltf::Value& value = it->second.Get(key);
  return value.IsNumber() ? value.GetNumberAsDouble() : fallback;
}

Vec3f to_vec3(const std::vector<double>& v, Vec3f fallback) {
  if (v.size() < 3) return fallback;
  return {static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])};
}

Material convert_material(const tinygltf::Material& gltf, size_t index) {
  Material m;
  m.name = gltf.name.empty() ? absl::StrCat("material ", index) : gltf.name;
  const tinygltf::PbrMetallicRoughness& pbr = gltf.pbrMetallicRoughness;
  const Vec3f base_color = to_vec3(pbr.baseColorFactor, Vec3f(1));
  const Vec3f emission =
      to_vec3(gltf.emissiveFactor, Vec3f(0)) *
      static_cast<float>(extension_number(gltf.extensions, "KHR_materials_emissive_strength",
                                          "emissiveStrength", 1.0));
  const double transmission =
      extension_number(gltf.extensions, "KHR_materials_transmission", "transmissionFactor", 0.0);
  // The file's model is ours: its factors are taken as they are (tinygltf fills in the
  // specification's defaults, metallic and roughness 1). A transmitting material is glass, rough
  // by its roughness; emission comes on top of any kind (glTF adds it to what the surface
  // reflects), and a surface that reflects nothing but emits is a light.
  m.radiance = emission;
  if (!is_black(emission) && is_black(base_color) && transmission <= 0) {
    m.type = MaterialType::kEmissive;
    m.color = Vec3f(0);
  } else if (transmission > 0) {
    m.type = MaterialType::kDielectric;
    m.ior = static_cast<float>(extension_number(gltf.extensions, "KHR_materials_ior", "ior", 1.5));
    m.roughness = static_cast<float>(pbr.roughnessFactor);
  } else {
    m.type = MaterialType::kMetallicRoughness;
    m.color = base_color;
    m.metallic = static_cast<float>(pbr.metallicFactor);
    m.roughness = static_cast<float>(pbr.roughnessFactor);
  }
  return m;
}

absl::StatusOr<Light> convert_light(const tinygltf::Light& gltf, size_t index) {
  Light light;
  light.name = gltf.name.empty() ? absl::StrCat("light ", index) : gltf.name;
  // Lights sit at the node's origin and shine down the node's -z axis.
  light.position = {0, 0, 0};
  light.direction = {0, 0, -1};
  light.intensity = to_vec3(gltf.color, Vec3f(1)) * static_cast<float>(gltf.intensity);
  if (gltf.type == "point") {
    light.type = LightType::kPoint;
  } else if (gltf.type == "spot") {
    light.type = LightType::kSpot;
    light.inner_angle_deg = static_cast<float>(gltf.spot.innerConeAngle * kRadiansToDegrees);
    light.outer_angle_deg = static_cast<float>(gltf.spot.outerConeAngle * kRadiansToDegrees);
  } else if (gltf.type == "directional") {
    light.type = LightType::kDirectional;
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat("light ", index, " has unknown type '", gltf.type, "'"));
  }
  return light;
}

const char* mode_name(int mode) {
  switch (mode) {
    case TINYGLTF_MODE_POINTS:
      return "POINTS";
    case TINYGLTF_MODE_LINE:
      return "LINES";
    case TINYGLTF_MODE_LINE_LOOP:
      return "LINE_LOOP";
    case TINYGLTF_MODE_LINE_STRIP:
      return "LINE_STRIP";
    case TINYGLTF_MODE_TRIANGLES:
      return "TRIANGLES";
    case TINYGLTF_MODE_TRIANGLE_STRIP:
      return "TRIANGLE_STRIP";
    case TINYGLTF_MODE_TRIANGLE_FAN:
      return "TRIANGLE_FAN";
    default:
      return "unknown-mode";
  }
}

// Triangle list of a strip or fan, as the glTF 2.0 specification (3.7.2.1) orders their corners:
// strip triangle i is (v[i], v[i+1], v[i+2]) for even i and (v[i], v[i+2], v[i+1]) for odd i, so
// that every triangle has the winding of the first; fan triangle i is (v[0], v[i+1], v[i+2]).
// Triangles that repeat a vertex index are dropped: strips use them to stitch runs together and
// they have no area. Triangles with distinct indices but coincident positions are kept, as in
// TRIANGLES mode. The parity of a strip triangle counts the dropped ones, so windings stay right.
std::vector<uint32_t> triangulate_strip_or_fan(const std::vector<uint32_t>& v, int mode) {
  std::vector<uint32_t> triangles;
  triangles.reserve(3 * (v.size() - 2));
  for (size_t i = 0; i + 2 < v.size(); ++i) {
    uint32_t a, b, c;
    if (mode == TINYGLTF_MODE_TRIANGLE_FAN) {
      a = v[0], b = v[i + 1], c = v[i + 2];
    } else if (i % 2 == 0) {
      a = v[i], b = v[i + 1], c = v[i + 2];
    } else {
      a = v[i], b = v[i + 2], c = v[i + 1];
    }
    if (a == b || b == c || a == c) continue;
    triangles.insert(triangles.end(), {a, b, c});
  }
  return triangles;
}

class GltfReader {
 public:
  GltfReader(const tinygltf::Model& model, const std::filesystem::path& path, ImageBytes images)
      : model_(model),
        file_name_(path.filename().string()),
        images_(std::move(images)),
        textures_(path) {}

  absl::StatusOr<MeshFile> read() {
    warn_of_unread_extensions();
    for (size_t i = 0; i < model_.materials.size(); ++i) {
      const tinygltf::Material& gltf = model_.materials[i];
      Material m = convert_material(gltf, i);
      m.color_map = texture_ref(gltf.pbrMetallicRoughness.baseColorTexture.index,
                                gltf.pbrMetallicRoughness.baseColorTexture.texCoord,
                                gltf.pbrMetallicRoughness.baseColorTexture.extensions, m.name);
      m.emission_map = texture_ref(gltf.emissiveTexture.index, gltf.emissiveTexture.texCoord,
                                   gltf.emissiveTexture.extensions, m.name);
      if (m.type == MaterialType::kMetallicRoughness) {
        const tinygltf::TextureInfo& mr = gltf.pbrMetallicRoughness.metallicRoughnessTexture;
        m.metallic_roughness_map = texture_ref(mr.index, mr.texCoord, mr.extensions, m.name);
      }
      m.normal_map = texture_ref(gltf.normalTexture.index, gltf.normalTexture.texCoord,
                                 gltf.normalTexture.extensions, m.name);
      if (m.normal_map.used()) m.normal_scale = float(gltf.normalTexture.scale);
      // The base colour's alpha: its factor's fourth number times the texture's alpha channel.
      if (gltf.alphaMode == "MASK") {
        m.alpha_mode = AlphaMode::kMask;
      } else if (gltf.alphaMode == "BLEND") {
        m.alpha_mode = AlphaMode::kBlend;
      } else if (gltf.alphaMode != "OPAQUE" && !gltf.alphaMode.empty()) {
        return absl::InvalidArgumentError(absl::StrCat("material '", m.name, "': alphaMode '",
                                                       gltf.alphaMode,
                                                       "' is not OPAQUE, MASK or BLEND"));
      }
      if (m.alpha_mode != AlphaMode::kOpaque) {
        const std::vector<double>& factor = gltf.pbrMetallicRoughness.baseColorFactor;
        m.opacity = factor.size() >= 4 ? static_cast<float>(factor[3]) : 1.0f;
        m.alpha_cutoff = static_cast<float>(gltf.alphaCutoff);
        m.opacity_map = m.color_map;
      }
      volume_of_material_.push_back(volume_medium(gltf, m));
      file_.materials.push_back(std::move(m));
    }
    file_.textures = textures_.take();
    node_seen_.assign(model_.nodes.size(), false);
    for (const int root : gltf_root_nodes(model_)) SCENE_RETURN_IF_ERROR(visit_tree(root));
    if (file_.meshes.empty() && skipped_primitives_ > 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("the default scene has only point and line primitives (",
                       skipped_primitives_, " of them), no triangles to render"));
    }
    return std::move(file_);
  }

 private:
  // The extensions the file uses that the reader does not read (KHR_materials_clearcoat,
  // _specular, ...), named in one warning, so that a model that differs from its author's renders
  // says why. Those it requires are named as such.
  void warn_of_unread_extensions() {
    static constexpr std::string_view kRead[] = {
        "KHR_lights_punctual",  "KHR_materials_emissive_strength",
        "KHR_materials_ior",    "KHR_materials_transmission",
        "KHR_materials_volume", "KHR_texture_transform",
    };
    std::vector<std::string> unread;
    for (const std::string& used : model_.extensionsUsed) {
      if (std::find(std::begin(kRead), std::end(kRead), used) != std::end(kRead)) continue;
      const bool required =
          std::find(model_.extensionsRequired.begin(), model_.extensionsRequired.end(), used) !=
          model_.extensionsRequired.end();
      unread.push_back(required ? absl::StrCat(used, " (required)") : used);
    }
    if (unread.empty()) return;
    file_.warnings.push_back(absl::StrCat(file_name_,
                                          ": extensions not read (the file is read as "
                                          "core glTF 2.0 states it): ",
                                          absl::StrJoin(unread, ", ")));
  }

  // A material's texture `index` (its textureInfo's) as the scene's: the image once per file, the
  // sampler's wrap modes and KHR_texture_transform. Maps on a second set of coordinates, or whose
  // image did not load, are left out with a warning.
  TextureRef texture_ref(int index, int texcoord, const tinygltf::ExtensionMap& extensions,
                         const std::string& material) {
    TextureRef ref;
    if (index < 0) return ref;
    const std::string where = absl::StrCat(file_name_, ": material '", material, "'");
    if (size_t(index) >= model_.textures.size()) {
      file_.warnings.push_back(absl::StrCat(where, " refers to missing texture ", index));
      return ref;
    }
    const tinygltf::Texture& texture = model_.textures[size_t(index)];
    const int image = texture.source;
    if (image < 0 || size_t(image) >= model_.images.size() || size_t(image) >= images_.size() ||
        images_[size_t(image)].empty()) {
      file_.warnings.push_back(absl::StrCat(where, ": texture ", index,
                                            " has no image that could be read; the material "
                                            "keeps its factor alone"));
      return ref;
    }
    const auto transform = extensions.find("KHR_texture_transform");
    if (transform != extensions.end() && transform->second.Has("texCoord") &&
        transform->second.Get("texCoord").IsNumber()) {
      texcoord = transform->second.Get("texCoord").GetNumberAsInt();
    }
    if (texcoord != 0) {
      file_.warnings.push_back(absl::StrCat(where, ": texture ", index, " reads TEXCOORD_",
                                            texcoord, ", but only TEXCOORD_0 is read; left out"));
      return ref;
    }
    const tinygltf::Image& source = model_.images[size_t(image)];
    const std::string name =
        !source.uri.empty() && !absl::StartsWith(source.uri, "data:")
            ? source.uri
            : (!source.name.empty() ? source.name : absl::StrCat("image ", image));
    ref.texture = textures_.from_bytes(absl::StrCat("image ", image), name, images_[size_t(image)]);
    if (texture.sampler >= 0 && size_t(texture.sampler) < model_.samplers.size()) {
      const tinygltf::Sampler& sampler = model_.samplers[size_t(texture.sampler)];
      ref.wrap_u = wrap_mode(sampler.wrapS);
      ref.wrap_v = wrap_mode(sampler.wrapT);
    }
    if (transform != extensions.end() && transform->second.IsObject()) {
      const tinygltf::Value& t = transform->second;
      ref.transform.offset = extension_pair(t, "offset", Vec2f{0.0f, 0.0f});
      ref.transform.scale = extension_pair(t, "scale", Vec2f{1.0f, 1.0f});
      if (t.Has("rotation") && t.Get("rotation").IsNumber()) {
        ref.transform.rotation = static_cast<float>(t.Get("rotation").GetNumberAsDouble());
      }
    }
    return ref;
  }

  // KHR_materials_volume of a transmitting material: the medium inside, which absorbs per unit of
  // length -ln(attenuationColor) / attenuationDistance (the distance is in the file's world
  // units, so node scales do not change it), or kNoMedium where nothing is absorbed. The
  // thickness factor and texture, a rasterizer's stand-in for the distance a ray travels inside,
  // are not needed by a ray tracer, which measures it.
  uint32_t volume_medium(const tinygltf::Material& gltf, const Material& m) {
    const auto it = gltf.extensions.find("KHR_materials_volume");
    if (it == gltf.extensions.end() || m.type != MaterialType::kDielectric) return kNoMedium;
    const double distance =
        extension_number(gltf.extensions, "KHR_materials_volume", "attenuationDistance", INFINITY);
    Vec3f color(1.0f);
    if (it->second.Has("attenuationColor")) {
      const tinygltf::Value& c = it->second.Get("attenuationColor");
      if (c.IsArray() && c.ArrayLen() >= 3) {
        for (int k = 0; k < 3; ++k)
          if (c.Get(k).IsNumber()) (&color.x)[k] = float(c.Get(k).GetNumberAsDouble());
      }
    }
    const std::string where = absl::StrCat(file_name_, ": material '", m.name, "'");
    if (!(distance > 0) || !std::isfinite(color.x + color.y + color.z) || color.x < 0 ||
        color.y < 0 || color.z < 0) {
      file_.warnings.push_back(
          absl::StrCat(where, ": KHR_materials_volume's attenuation (distance ", distance,
                       ", colour (", color.x, ", ", color.y, ", ", color.z,
                       ")) is not a positive distance and a colour >= 0; nothing "
                       "is absorbed inside"));
      return kNoMedium;
    }
    if (std::isinf(distance) || (color.x >= 1 && color.y >= 1 && color.z >= 1)) return kNoMedium;
    // A channel of colour 0 absorbs everything; the floor keeps the coefficient finite.
    const auto coefficient = [&](float c) {
      return float(-std::log(std::clamp(double(c), 1e-6, 1.0)) / distance);
    };
    Medium medium;
    medium.name = absl::StrCat(m.name, " (volume)");
    medium.absorption = {coefficient(color.x), coefficient(color.y), coefficient(color.z)};
    file_.media.push_back(std::move(medium));
    return uint32_t(file_.media.size() - 1);
  }

  // A primitive of a material with a volume encloses its medium, where it is closed; else a
  // warning says that its attenuation is left out.
  void enclose_volume(int material, Mesh* mesh) {
    if (material < 0 || size_t(material) >= volume_of_material_.size()) return;
    const uint32_t medium = volume_of_material_[size_t(material)];
    if (medium == kNoMedium) return;
    if (absl::Status closed = check_closed(*mesh, mesh->name, file_.media[medium].name);
        !closed.ok()) {
      file_.warnings.push_back(
          absl::StrCat(closed.message(), "; its KHR_materials_volume attenuation is left out"));
      return;
    }
    mesh->interior_medium = medium;
  }

  // Iterative, so a hostile chain of nodes cannot overflow the stack; glTF nodes form a forest,
  // so a node reached twice means a cycle or a shared child, both invalid.
  absl::Status visit_tree(int root) {
    std::vector<std::pair<int, Affine>> pending = {{root, Affine()}};
    while (!pending.empty()) {
      const auto [index, parent] = pending.back();
      pending.pop_back();
      if (index < 0 || static_cast<size_t>(index) >= model_.nodes.size()) {
        return absl::InvalidArgumentError(absl::StrCat("node ", index, " does not exist"));
      }
      if (node_seen_[index]) {
        return absl::InvalidArgumentError(
            absl::StrCat("node ", index, " is reached twice: the node hierarchy is not a tree"));
      }
      node_seen_[index] = true;
      const tinygltf::Node& node = model_.nodes[index];
      const Affine world = parent * gltf_local_transform(node);
      SCENE_RETURN_IF_ERROR(add_node_meshes(node, index, world));
      SCENE_RETURN_IF_ERROR(add_node_light(node, world));
      SCENE_RETURN_IF_ERROR(add_node_camera(node, index, world));
      // Reversed onto the stack, so that meshes come out in document order.
      for (auto child = node.children.rbegin(); child != node.children.rend(); ++child) {
        pending.emplace_back(*child, world);
      }
    }
    return absl::OkStatus();
  }

  absl::Status add_node_meshes(const tinygltf::Node& node, int node_index, const Affine& world) {
    if (node.mesh < 0) return absl::OkStatus();
    if (static_cast<size_t>(node.mesh) >= model_.meshes.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat("node ", node_index, " refers to missing mesh ", node.mesh));
    }
    const tinygltf::Mesh& gltf_mesh = model_.meshes[node.mesh];
    for (size_t p = 0; p < gltf_mesh.primitives.size(); ++p) {
      const tinygltf::Primitive& primitive = gltf_mesh.primitives[p];
      // Errors get the file name from load_gltf; mesh names need it themselves.
      const std::string name = gltf_primitive_name(model_, node_index, p);
      // tinygltf leaves mode at -1 when the file omits it; glTF's default is TRIANGLES.
      const int mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;
      if (mode > TINYGLTF_MODE_TRIANGLE_FAN) {
        return absl::InvalidArgumentError(
            absl::StrCat(name, ": unknown primitive mode ", mode, " (glTF 2.0 defines 0 to 6)"));
      }
      if (!gltf_draws_triangles(primitive)) {
        // Points and lines have no area to hit. Files often carry them as helpers (wireframes,
        // markers) next to the surfaces, so they are skipped with a warning; a file with nothing
        // else is an error in read().
        ++skipped_primitives_;
        file_.warnings.push_back(absl::StrCat(file_name_, ": ", name, ": skipped ", mode_name(mode),
                                              " primitive (no surface to render)"));
        continue;
      }
      SCENE_ASSIGN_OR_RETURN(Mesh mesh, convert_primitive(primitive, mode, name));
      mesh.name = absl::StrCat(file_name_, ": ", name);
      transform_mesh(world, &mesh);
      enclose_volume(primitive.material, &mesh);
      file_.meshes.push_back(std::move(mesh));
    }
    return absl::OkStatus();
  }

  absl::StatusOr<Mesh> convert_primitive(const tinygltf::Primitive& primitive, int mode,
                                         const std::string& name) const {
    constexpr int kFloat = TINYGLTF_COMPONENT_TYPE_FLOAT;
    constexpr int kUbyte = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
    constexpr int kUshort = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    constexpr int kUint = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    Mesh mesh;
    const auto position = primitive.attributes.find("POSITION");
    if (position == primitive.attributes.end()) {
      return absl::InvalidArgumentError(absl::StrCat(name, ": no POSITION attribute"));
    }
    SCENE_ASSIGN_OR_RETURN(const AccessorView positions,
                           AccessorView::open(model_, position->second, TINYGLTF_TYPE_VEC3,
                                              {kFloat}, absl::StrCat(name, ": POSITION")));
    const size_t vertex_count = positions.count();
    if (vertex_count > kMaxVerticesPerMesh) {
      return absl::InvalidArgumentError(
          absl::StrCat(name, ": ", vertex_count, " vertices exceed the limit"));
    }
    mesh.positions.resize(vertex_count);
    for (size_t i = 0; i < vertex_count; ++i) mesh.positions[i] = positions.get_vec3(i);

    // glTF gives every attribute of a primitive the same count; another count is a broken file.
    const auto same_count = [&](const AccessorView& view, const char* attribute) {
      if (view.count() == vertex_count) return absl::OkStatus();
      return absl::InvalidArgumentError(absl::StrCat(name, ": ", attribute, " has ", view.count(),
                                                     " elements but POSITION has ", vertex_count));
    };
    if (const auto normal = primitive.attributes.find("NORMAL");
        normal != primitive.attributes.end()) {
      SCENE_ASSIGN_OR_RETURN(const AccessorView normals,
                             AccessorView::open(model_, normal->second, TINYGLTF_TYPE_VEC3,
                                                {kFloat}, absl::StrCat(name, ": NORMAL")));
      SCENE_RETURN_IF_ERROR(same_count(normals, "NORMAL"));
      mesh.normals.resize(vertex_count);
      for (size_t i = 0; i < vertex_count; ++i) mesh.normals[i] = normals.get_vec3(i);
    }
    if (const auto uv = primitive.attributes.find("TEXCOORD_0"); uv != primitive.attributes.end()) {
      SCENE_ASSIGN_OR_RETURN(
          const AccessorView uvs,
          AccessorView::open(model_, uv->second, TINYGLTF_TYPE_VEC2, {kFloat, kUbyte, kUshort},
                             absl::StrCat(name, ": TEXCOORD_0")));
      SCENE_RETURN_IF_ERROR(same_count(uvs, "TEXCOORD_0"));
      mesh.uvs.resize(vertex_count);
      for (size_t i = 0; i < vertex_count; ++i) {
        mesh.uvs[i] = {static_cast<float>(uvs.get(i, 0)), static_cast<float>(uvs.get(i, 1))};
      }
    }
    // Tangents mean something only beside normals; without them a renderer derives its own.
    if (const auto tangent = primitive.attributes.find("TANGENT");
        tangent != primitive.attributes.end() && !mesh.normals.empty()) {
      SCENE_ASSIGN_OR_RETURN(const AccessorView tangents,
                             AccessorView::open(model_, tangent->second, TINYGLTF_TYPE_VEC4,
                                                {kFloat}, absl::StrCat(name, ": TANGENT")));
      SCENE_RETURN_IF_ERROR(same_count(tangents, "TANGENT"));
      mesh.tangents.resize(vertex_count);
      for (size_t i = 0; i < vertex_count; ++i) {
        const Vec4f t{
            static_cast<float>(tangents.get(i, 0)), static_cast<float>(tangents.get(i, 1)),
            static_cast<float>(tangents.get(i, 2)), static_cast<float>(tangents.get(i, 3))};
        if (absl::Status bad = check_tangent(t); !bad.ok()) {
          return absl::InvalidArgumentError(
              absl::StrCat(name, ": TANGENT ", i, " ", bad.message()));
        }
        mesh.tangents[i] = t;
      }
    }

    // The primitive's vertex sequence: its indices, or every vertex in order without them.
    std::vector<uint32_t> sequence;
    if (primitive.indices >= 0) {
      SCENE_ASSIGN_OR_RETURN(
          const AccessorView indices,
          AccessorView::open(model_, primitive.indices, TINYGLTF_TYPE_SCALAR,
                             {kUbyte, kUshort, kUint}, absl::StrCat(name, ": indices")));
      sequence.resize(indices.count());
      for (size_t i = 0; i < indices.count(); ++i) {
        const double index = indices.get(i, 0);
        if (index >= static_cast<double>(vertex_count)) {
          return absl::InvalidArgumentError(absl::StrCat(
              name, ": index ", i, " is ", index, ", out of range (", vertex_count, " vertices)"));
        }
        sequence[i] = static_cast<uint32_t>(index);
      }
    } else {
      sequence.resize(vertex_count);
      for (size_t i = 0; i < vertex_count; ++i) sequence[i] = static_cast<uint32_t>(i);
    }
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      if (sequence.size() % 3 != 0) {
        return absl::InvalidArgumentError(
            absl::StrCat(name, ": ", sequence.size(), " indices is not a multiple of 3"));
      }
      mesh.indices = std::move(sequence);
    } else {
      if (sequence.size() < 3) {
        return absl::InvalidArgumentError(absl::StrCat(name, ": ", mode_name(mode), " of ",
                                                       sequence.size(),
                                                       " vertices has no triangle (needs 3)"));
      }
      mesh.indices = triangulate_strip_or_fan(sequence, mode);
    }
    if (mesh.triangle_count() > kMaxTrianglesPerMesh) {
      return absl::InvalidArgumentError(absl::StrCat(name, ": too many triangles"));
    }

    uint32_t material = kNoMaterial;
    if (primitive.material >= 0) {
      if (static_cast<size_t>(primitive.material) >= model_.materials.size()) {
        return absl::InvalidArgumentError(
            absl::StrCat(name, ": refers to missing material ", primitive.material));
      }
      material = static_cast<uint32_t>(primitive.material);
    }
    mesh.material_ids.assign(mesh.triangle_count(), material);
    return mesh;
  }

  // A glTF camera looks down its node's -z axis with +y up. Cameras matter only to a bare mesh
  // file's scene (a JSON scene has its own), so one that cannot be used is skipped with a warning
  // instead of failing the file; that includes orthographic ones, which a pinhole cannot match.
  absl::Status add_node_camera(const tinygltf::Node& node, int node_index, const Affine& world) {
    if (node.camera < 0) return absl::OkStatus();
    const std::string where =
        absl::StrCat(file_name_, ": camera ", node.camera, " at node '",
                     node.name.empty() ? absl::StrCat(node_index) : node.name, "'");
    if (static_cast<size_t>(node.camera) >= model_.cameras.size()) {
      file_.warnings.push_back(absl::StrCat(where, " does not exist; skipped"));
      return absl::OkStatus();
    }
    const tinygltf::Camera& gltf = model_.cameras[node.camera];
    if (gltf.type != "perspective") {
      file_.warnings.push_back(
          absl::StrCat(where, " is ", gltf.type, "; only perspective cameras are used"));
      return absl::OkStatus();
    }
    const double yfov_deg = gltf.perspective.yfov * kRadiansToDegrees;
    const Vec3f forward = world.apply_to_vector(Vec3f(0, 0, -1));
    const Vec3f up = world.apply_to_vector(Vec3f(0, 1, 0));
    if (!(yfov_deg > 0 && yfov_deg < 180) || !(length_squared(forward) > 0) ||
        !(length_squared(cross(forward, up)) > 0)) {
      file_.warnings.push_back(absl::StrCat(where,
                                            " has a yfov outside (0, pi) radians or a "
                                            "degenerate node transform; skipped"));
      return absl::OkStatus();
    }
    Camera camera;
    camera.position = world.apply_to_point(Vec3f(0, 0, 0));
    camera.look_at = camera.position + normalize(forward);
    camera.up = normalize(up);
    camera.vertical_fov_deg = static_cast<float>(yfov_deg);
    // The image keeps the default height; a given aspect ratio sets the width.
    const double aspect = gltf.perspective.aspectRatio;
    if (aspect > 0 && aspect <= kMaxImageSide) {
      camera.width = static_cast<int>(
          std::clamp(std::lround(camera.height * aspect), 1L, static_cast<long>(kMaxImageSide)));
    }
    file_.cameras.push_back(camera);
    return absl::OkStatus();
  }

  // KHR_lights_punctual puts {"light": index} into the node's extensions.
  absl::Status add_node_light(const tinygltf::Node& node, const Affine& world) {
    const auto it = node.extensions.find("KHR_lights_punctual");
    if (it == node.extensions.end()) return absl::OkStatus();
    if (!it->second.IsObject() || !it->second.Has("light") || !it->second.Get("light").IsNumber()) {
      return absl::InvalidArgumentError(
          absl::StrCat("node '", node.name, "': KHR_lights_punctual without a light index"));
    }
    // As a double: GetNumberAsInt converts 1e10 or -1e10 to int unchecked, which is undefined.
    const double number = it->second.Get("light").GetNumberAsDouble();
    if (!(number >= 0 && number < static_cast<double>(model_.lights.size())) ||
        number != std::floor(number)) {
      return absl::InvalidArgumentError(
          absl::StrCat("node '", node.name, "' refers to missing light ", number));
    }
    const size_t index = static_cast<size_t>(number);
    SCENE_ASSIGN_OR_RETURN(Light light, convert_light(model_.lights[index], index));
    transform_light(world, &light);
    file_.lights.push_back(std::move(light));
    return absl::OkStatus();
  }

  const tinygltf::Model& model_;
  std::string file_name_;
  ImageBytes images_;
  TextureTable textures_;
  std::vector<bool> node_seen_;
  size_t skipped_primitives_ = 0;
  MeshFile file_;
  std::vector<uint32_t> volume_of_material_;  // each material's medium, or kNoMedium
};

}  // namespace

absl::StatusOr<MeshFile> load_gltf(const std::filesystem::path& path) {
  ImageBytes images;
  absl::StatusOr<tinygltf::Model> model = load_gltf_model(path, &images);
  if (!model.ok()) return model.status();
  absl::StatusOr<MeshFile> file = GltfReader(*model, path, std::move(images)).read();
  if (!file.ok()) return annotate(file.status(), path.string());
  return file;
}

}  // namespace caustica
