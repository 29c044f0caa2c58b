#include "renderer/scene/mesh_assimp.h"

#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cmath>
#include <exception>
#include <initializer_list>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "renderer/scene/affine.h"
#include "renderer/scene/mesh_scene.h"
#include "renderer/scene/scene_limits.h"
#include "renderer/scene/status_util.h"
#include "renderer/scene/texture_files.h"
#include "renderer/scene/transform.h"

namespace caustica {
namespace {

// Assimp splits meshes by primitive type (SortByPType) and triangulates polygons; we keep the
// triangle meshes. Joining identical vertices matters for formats that store every face corner
// separately (STL, OFF exporters), which would otherwise triple the vertex count.
constexpr unsigned kPostProcess = aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                  aiProcess_SortByPType | aiProcess_ValidateDataStructure;

Affine to_affine(const aiMatrix4x4& m) {
  Affine a;
  a.m = {{{m.a1, m.a2, m.a3, m.a4}, {m.b1, m.b2, m.b3, m.b4}, {m.c1, m.c2, m.c3, m.c4}}};
  return a;
}

constexpr double kRadiansToDegrees = 180.0 / 3.14159265358979323846;
// A camera's vertical angle below the first is taken for an importer's mistake and replaced by
// the second (add_camera).
constexpr double kMinCameraFovDeg = 1;
constexpr double kAssumedCameraFovDeg = 40;

Vec3f to_vec3(const aiColor3D& c) { return {c.r, c.g, c.b}; }
Vec3f to_vec3(const aiVector3D& v) { return {v.x, v.y, v.z}; }

Vec3f clamp01(Vec3f c) {
  return {std::clamp(c.x, 0.0f, 1.0f), std::clamp(c.y, 0.0f, 1.0f), std::clamp(c.z, 0.0f, 1.0f)};
}

// "model.fbx: material 'steel': ", for warnings.
std::string material_where(const std::string& file_name, const std::string& material) {
  return absl::StrCat(file_name, ": material '", material, "': ");
}

// A colour of the file, clamped to [0, 1] with a warning when it is not (0.8 grey when it is not
// finite): validation would refuse the whole model for one exporter's overbright colour.
Vec3f reflectance(Vec3f color, const char* what, const std::string& where,
                  std::vector<std::string>* warnings) {
  if (!is_finite(color)) return Vec3f(0.8f);
  const Vec3f clamped = clamp01(color);
  if (!(clamped == color)) {
    warnings->push_back(absl::StrCat(where, what, " (", color.x, ", ", color.y, ", ", color.z,
                                     ") clamped to [0, 1]"));
  }
  return clamped;
}

// A metalness or roughness factor of the file, clamped to [0, 1] with a warning when it is not
// (`fallback` when it is not finite).
float unit_factor(float value, float fallback, const char* what, const std::string& where,
                  std::vector<std::string>* warnings) {
  if (!std::isfinite(value)) {
    warnings->push_back(
        absl::StrCat(where, what, " ", value, " is not finite; ", fallback, " instead"));
    return fallback;
  }
  const float clamped = std::clamp(value, 0.0f, 1.0f);
  if (clamped != value) {
    warnings->push_back(absl::StrCat(where, what, " ", value, " clamped to [0, 1]"));
  }
  return clamped;
}

// Assimp's shading models whose surfaces have no highlight, whatever specular colour the file
// also stores: flat and Gouraud (COLLADA's lambert, FBX's and 3DS's diffuse materials), the
// diffuse-only Oren-Nayar and Minnaert, and unlit.
bool has_no_highlight(int shading_model) {
  return shading_model == aiShadingMode_Flat || shading_model == aiShadingMode_Gouraud ||
         shading_model == aiShadingMode_OrenNayar || shading_model == aiShadingMode_Minnaert ||
         shading_model == aiShadingMode_NoShading;
}

// The same rules as OBJ's MTL and glTF, in the terms Assimp normalises every format's materials
// to, each model taken as the file states it: transparency (a dielectric); a glTF-like metalness
// factor, with its roughness (metallic-roughness); a specular colour with a shininess under a
// shading model that has highlights (modified Phong); else the diffuse (or PBR base) colour.
// Emission comes on top. Mirrors are not guessed: Assimp's reflectivity means different things per
// format. A 3DS file's emission is its self-illumination percentage (Assimp reads p% as grey
// p/100), which in 3D Studio replaced a surface's shading by its own colour and lit nothing else:
// such a file emits nothing (`self_illumination`), with a warning naming the material.
Material convert_material(const aiMaterial& source, size_t index, const std::string& file_name,
                          bool self_illumination, std::vector<std::string>* warnings) {
  Material m;
  aiString name;
  m.name = source.Get(AI_MATKEY_NAME, name) == AI_SUCCESS && name.length > 0
               ? std::string(name.C_Str())
               : absl::StrCat("material ", index);
  const std::string where = material_where(file_name, m.name);
  std::optional<Vec3f> base, diffuse;
  if (aiColor4D c; source.Get(AI_MATKEY_BASE_COLOR, c) == AI_SUCCESS) base = Vec3f(c.r, c.g, c.b);
  if (aiColor3D c; source.Get(AI_MATKEY_COLOR_DIFFUSE, c) == AI_SUCCESS) diffuse = to_vec3(c);
  const Vec3f albedo = base.value_or(diffuse.value_or(Vec3f(0.8f)));
  aiColor3D emissive(0, 0, 0);
  Vec3f emission(0);
  if (source.Get(AI_MATKEY_COLOR_EMISSIVE, emissive) == AI_SUCCESS) {
    emission = to_vec3(emissive);
    float strength = 1;
    if (source.Get(AI_MATKEY_EMISSIVE_INTENSITY, strength) == AI_SUCCESS)
      emission = emission * strength;
  }
  if (self_illumination && !is_black(emission)) {
    warnings->push_back(absl::StrCat(where, "3DS self-illumination ", emission.x * 100,
                                     "% shades the surface and lights nothing; it emits nothing"));
    emission = Vec3f(0);
  }
  float opacity = 1;
  source.Get(AI_MATKEY_OPACITY, opacity);
  float transmission = 0;
  source.Get(AI_MATKEY_TRANSMISSION_FACTOR, transmission);
  // A metalness is what marks a metallic-roughness material: Assimp's FBX importer derives a
  // roughness factor, 1 - sqrt(shininess) / 10, for every Phong material, an approximation of its
  // own rather than anything the file states.
  float metallic = 0, roughness = 0.5f;  // 0.5: the scene format's default, for one left out
  const bool has_metallic = source.Get(AI_MATKEY_METALLIC_FACTOR, metallic) == AI_SUCCESS;
  source.Get(AI_MATKEY_ROUGHNESS_FACTOR, roughness);
  aiColor3D specular_color(0, 0, 0);
  float shininess = 0, shininess_strength = 1;
  int shading_model = aiShadingMode_Phong;
  const bool has_specular = source.Get(AI_MATKEY_COLOR_SPECULAR, specular_color) == AI_SUCCESS;
  source.Get(AI_MATKEY_SHININESS, shininess);
  source.Get(AI_MATKEY_SHININESS_STRENGTH, shininess_strength);
  source.Get(AI_MATKEY_SHADING_MODEL, shading_model);
  const Vec3f specular = to_vec3(specular_color) * shininess_strength;

  // Emission comes on top of what the surface reflects; a surface that reflects nothing is a
  // light.
  if (is_finite(emission)) {
    m.radiance =
        Vec3f(std::max(emission.x, 0.0f), std::max(emission.y, 0.0f), std::max(emission.z, 0.0f));
  }
  const bool transparent = opacity < 1 || transmission > 0;
  if (!is_black(m.radiance) && !transparent && is_finite(albedo) && is_black(albedo)) {
    m.type = MaterialType::kEmissive;
    m.color = Vec3f(0);
  } else if (transparent) {
    m.type = MaterialType::kDielectric;
    float ior = 1.5f;
    // Many exporters write 1 (or nothing) when they mean "not set".
    if (source.Get(AI_MATKEY_REFRACTI, ior) != AI_SUCCESS || !(ior > 1)) ior = 1.5f;
    m.ior = ior;
  } else if (has_metallic) {
    m.type = MaterialType::kMetallicRoughness;
    m.color = reflectance(albedo, "base colour", where, warnings);
    m.metallic = unit_factor(metallic, 0, "metallic factor", where, warnings);
    m.roughness = unit_factor(roughness, 0.5f, "roughness factor", where, warnings);
  } else if (has_specular && is_finite(specular) && !is_black(specular) && shininess > 0 &&
             std::isfinite(shininess) && !has_no_highlight(shading_model)) {
    m.type = MaterialType::kPhong;
    // Negative channels are an exporter's mistake; overbright ones are scaled down with the
    // other lobe below, keeping the hue.
    const auto non_negative = [](Vec3f c) {
      return Vec3f(std::max(c.x, 0.0f), std::max(c.y, 0.0f), std::max(c.z, 0.0f));
    };
    const Vec3f kd = diffuse.value_or(albedo);
    m.color = is_finite(kd) ? non_negative(kd) : Vec3f(0.8f);
    m.specular = non_negative(specular);
    m.exponent = shininess;
    const Vec3f sum = m.color + m.specular;
    if (const float scale = conserve_phong_energy(&m); scale != 1) {
      warnings->push_back(absl::StrCat(where, "diffuse + specular colour (", sum.x, ", ", sum.y,
                                       ", ", sum.z, ") exceeds 1; both scaled by ", scale,
                                       " so that it reflects no more than it receives"));
    }
  } else {
    m.type = MaterialType::kDiffuse;
    m.color = reflectance(albedo, "diffuse colour", where, warnings);
  }
  return m;
}

class AssimpReader {
 public:
  AssimpReader(const aiScene& scene, const std::filesystem::path& path)
      : scene_(scene),
        file_name_(path.filename().string()),
        is_3ds_(absl::AsciiStrToLower(path.extension().string()) == ".3ds"),
        textures_(path) {}

  absl::StatusOr<MeshFile> read() {
    if (scene_.mRootNode == nullptr) return absl::InvalidArgumentError("the file has no nodes");
    for (unsigned i = 0; i < scene_.mNumMaterials; ++i) {
      Material m = convert_material(*scene_.mMaterials[i], i, file_name_, is_3ds_, &file_.warnings);
      m.color_map = texture_map(*scene_.mMaterials[i], m.name,
                                {aiTextureType_BASE_COLOR, aiTextureType_DIFFUSE});
      // A 3DS self-illumination map, like its percentage, is shading, not light.
      if (!is_3ds_) {
        m.emission_map = texture_map(*scene_.mMaterials[i], m.name,
                                     {aiTextureType_EMISSION_COLOR, aiTextureType_EMISSIVE});
      }
      const aiMaterial& source = *scene_.mMaterials[i];
      m.normal_map = texture_map(source, m.name, {aiTextureType_NORMALS});
      // A height map (a 3DS or OBJ bump map) becomes a normal map at upload, scaled by the bump
      // amount the file gives.
      m.bump_map = texture_map(source, m.name, {aiTextureType_HEIGHT});
      if (float bump = 1; m.bump_map.used() &&
                          source.Get(AI_MATKEY_BUMPSCALING, bump) == AI_SUCCESS &&
                          std::isfinite(bump) && bump != 0) {
        m.bump_scale = std::clamp(bump, -kMaxBumpScale, kMaxBumpScale);
      }
      if (m.type == MaterialType::kMetallicRoughness) {
        // Separate maps, or one image for both packed as glTF packs it.
        m.roughness_map = texture_map(source, m.name, {aiTextureType_DIFFUSE_ROUGHNESS});
        m.metallic_map = texture_map(source, m.name, {aiTextureType_METALNESS});
        if (m.roughness_map.used() && m.roughness_map.texture == m.metallic_map.texture) {
          m.metallic_roughness_map = m.roughness_map;
          m.roughness_map = m.metallic_map = TextureRef{};
        } else if (m.roughness_map.used() && m.metallic_map.used() &&
                   !m.roughness_map.samples_like(m.metallic_map)) {
          file_.warnings.push_back(absl::StrCat(
              file_name_, ": material '", m.name,
              "': its metalness map is not read: it wraps unlike its roughness map, with which "
              "it would be packed into one map"));
          m.metallic_map = TextureRef{};
        }
      }
      m.opacity_map = texture_map(*scene_.mMaterials[i], m.name, {aiTextureType_OPACITY});
      if (m.opacity_map.used()) m.alpha_mode = AlphaMode::kBlend;
      note_unread_maps(source, m);
      file_.materials.push_back(std::move(m));
    }
    unread_maps_.warn(file_name_, file_.warnings);
    file_.textures = textures_.take();
    SCENE_RETURN_IF_ERROR(visit_tree());
    if (file_.meshes.empty()) {
      if (skipped_meshes_ > 0) {
        return absl::InvalidArgumentError(absl::StrCat("has only point and line meshes (",
                                                       skipped_meshes_, " of them), no triangles"));
      }
      return absl::InvalidArgumentError("has no triangle meshes");
    }
    if (is_3ds_ && scene_.mNumCameras + scene_.mNumLights > 0) {
      // Assimp 5.2.5 leaves a 3DS file's cameras and lights at its nodes' origins, which carry
      // no translation: Sponza's camera and sun would both stand at (0, 0, 0) on its floor.
      file_.warnings.push_back(absl::StrCat(
          file_name_, ": its ", scene_.mNumCameras, " camera(s) and ", scene_.mNumLights,
          " light(s) are ignored: Assimp reads no position for a 3DS file's cameras and lights"));
    } else {
      for (unsigned i = 0; i < scene_.mNumCameras; ++i) {
        if (scene_.mCameras[i] != nullptr) add_camera(*scene_.mCameras[i], i);
      }
      const Bounds bounds = mesh_bounds(file_.meshes);
      for (unsigned i = 0; i < scene_.mNumLights; ++i) {
        if (scene_.mLights[i] != nullptr) add_light(*scene_.mLights[i], i, bounds);
      }
    }
    return std::move(file_);
  }

 private:
  // Where a camera or light named `name` stands: the world transform of the node of that name
  // (Assimp ties them to nodes by name), or none when no node has it.
  Affine node_world(const aiString& name) const {
    const auto it = node_worlds_.find(std::string(name.C_Str()));
    return it == node_worlds_.end() ? Affine() : it->second;
  }

  // "model.dae: camera 0 'Camera'", for warnings.
  std::string named(const char* what, unsigned index, const aiString& name) const {
    return absl::StrCat(file_name_, ": ", what, " ", index, name.length > 0 ? " '" : "",
                        name.C_Str(), name.length > 0 ? "'" : "");
  }

  // A camera as glTF's are read: its node's transform applied to its position, view direction and
  // up; the horizontal angle and aspect turned into a vertical angle and an image width. Assimp's
  // documentation calls mHorizontalFOV half the angle, but its COLLADA, 3DS and FBX importers store
  // the whole one, and so it is read.
  void add_camera(const aiCamera& source, unsigned index) {
    const std::string where = named("camera", index, source.mName);
    if (source.mOrthographicWidth > 0) {
      file_.warnings.push_back(absl::StrCat(where,
                                            " is orthographic; only perspective cameras "
                                            "are used"));
      return;
    }
    const Affine to_world = node_world(source.mName);
    const Vec3f position = to_world.apply_to_point(to_vec3(source.mPosition));
    const Vec3f forward = to_world.apply_to_vector(to_vec3(source.mLookAt));
    Vec3f up = to_world.apply_to_vector(to_vec3(source.mUp));
    // Assimp's 3DS importer gives the up vector along the look-at vector; the scene's up then.
    if (!(length_squared(cross(forward, up)) >
          1e-12f * length_squared(forward) * length_squared(up))) {
      up = std::fabs(normalize(forward).y) < 0.99f ? Vec3f(0, 1, 0) : Vec3f(0, 0, 1);
    }
    const double aspect = source.mAspect > 0 ? source.mAspect : 1.0;
    double vertical =
        2 * std::atan(std::tan(0.5 * source.mHorizontalFOV) / aspect) * kRadiansToDegrees;
    // Assimp 5.2.5 gives a COLLADA camera with only a yfov its default angle turned to radians
    // twice (0.79 degrees): no camera anyone renders through.
    if (vertical > 0 && vertical < kMinCameraFovDeg) {
      file_.warnings.push_back(absl::StrCat(where, ": Assimp reports a field of view of ", vertical,
                                            " degrees; ", kAssumedCameraFovDeg,
                                            " degrees instead"));
      vertical = kAssumedCameraFovDeg;
    }
    if (!is_finite(position) || !(length_squared(forward) > 0) ||
        !(length_squared(cross(forward, up)) > 0) || !(vertical > 0 && vertical < 180)) {
      file_.warnings.push_back(absl::StrCat(where,
                                            " has a field of view outside (0, 180) degrees or a "
                                            "degenerate direction; skipped"));
      return;
    }
    Camera camera;
    camera.position = position;
    camera.look_at = position + normalize(forward);
    camera.up = normalize(up);
    camera.vertical_fov_deg = static_cast<float>(vertical);
    if (source.mAspect > 0 && source.mAspect <= kMaxImageSide) {
      camera.width =
          static_cast<int>(std::clamp(std::lround(camera.height * double(source.mAspect)), 1L,
                                      static_cast<long>(kMaxImageSide)));
    }
    file_.cameras.push_back(camera);
  }

  // A point, spot or directional light. Assimp folds the light's strength into its diffuse colour
  // and keeps the file's attenuation 1 / (c + l d + q d^2), which a physical light has as
  // 1 / d^2 alone: the intensity is the colour times d^2 times the attenuation at d, the distance
  // from the light to the model's centre, so that the model is lit there as the file says (and
  // exactly the colour over q for a purely quadratic falloff).
  void add_light(const aiLight& source, unsigned index, const Bounds& bounds) {
    const std::string where = named("light", index, source.mName);
    Light light;
    light.name =
        source.mName.length > 0 ? std::string(source.mName.C_Str()) : absl::StrCat("light ", index);
    switch (source.mType) {
      case aiLightSource_POINT:
        light.type = LightType::kPoint;
        break;
      case aiLightSource_SPOT:
        light.type = LightType::kSpot;
        break;
      case aiLightSource_DIRECTIONAL:
        light.type = LightType::kDirectional;
        break;
      default:
        file_.warnings.push_back(absl::StrCat(where,
                                              " is an ambient or area light, which has no "
                                              "counterpart; skipped"));
        return;
    }
    const Affine to_world = node_world(source.mName);
    light.position = to_world.apply_to_point(to_vec3(source.mPosition));
    const Vec3f direction = to_world.apply_to_vector(to_vec3(source.mDirection));
    if (light.type != LightType::kPoint) {
      if (!(length_squared(direction) > 0)) {
        file_.warnings.push_back(absl::StrCat(where, " has no direction; skipped"));
        return;
      }
      light.direction = normalize(direction);
    }
    const Vec3f color = to_vec3(source.mColorDiffuse);
    if (!is_finite(color) || !is_finite(light.position)) {
      file_.warnings.push_back(absl::StrCat(where,
                                            " has a colour or position that is not finite; "
                                            "skipped"));
      return;
    }
    light.intensity =
        Vec3f(std::max(color.x, 0.0f), std::max(color.y, 0.0f), std::max(color.z, 0.0f));
    if (light.type == LightType::kSpot) {
      // Assimp gives the cones' full angles.
      light.outer_angle_deg =
          std::clamp(float(0.5 * source.mAngleOuterCone * kRadiansToDegrees), 0.01f, 90.0f);
      light.inner_angle_deg = std::clamp(float(0.5 * source.mAngleInnerCone * kRadiansToDegrees),
                                         0.0f, light.outer_angle_deg);
    }
    if (light.type != LightType::kDirectional) {
      const float radius = bounds.empty() ? 1.0f : 0.5f * length(bounds.size());
      const float d = std::max(bounds.empty() ? radius : length(bounds.center() - light.position),
                               1e-3f * radius);
      float c = source.mAttenuationConstant, l = source.mAttenuationLinear,
            q = source.mAttenuationQuadratic;
      if (!(c >= 0 && l >= 0 && q >= 0) || !(c + l + q > 0)) c = 1, l = 0, q = 0;
      const float falloff = c + l * d + q * d * d;
      light.intensity = light.intensity * (d * d / falloff);
    }
    file_.lights.push_back(light);
  }

  // Iterative, so that a deep hierarchy cannot overflow the stack.
  absl::Status visit_tree() {
    std::vector<std::pair<const aiNode*, Affine>> pending = {{scene_.mRootNode, Affine()}};
    while (!pending.empty()) {
      const auto [node, parent] = pending.back();
      pending.pop_back();
      const Affine world = parent * to_affine(node->mTransformation);
      node_worlds_.emplace(std::string(node->mName.C_Str()), world);
      for (unsigned i = 0; i < node->mNumMeshes; ++i) {
        SCENE_RETURN_IF_ERROR(add_mesh(*node, node->mMeshes[i], world));
      }
      for (unsigned c = node->mNumChildren; c-- > 0;) {
        if (node->mChildren[c] != nullptr) pending.emplace_back(node->mChildren[c], world);
      }
    }
    return absl::OkStatus();
  }

  absl::Status add_mesh(const aiNode& node, unsigned index, const Affine& world) {
    if (index >= scene_.mNumMeshes || scene_.mMeshes[index] == nullptr) {
      return absl::InvalidArgumentError(
          absl::StrCat("node '", node.mName.C_Str(), "' refers to missing mesh ", index));
    }
    const aiMesh& source = *scene_.mMeshes[index];
    const std::string name =
        absl::StrCat("mesh '", source.mName.C_Str(), "' at node '", node.mName.C_Str(), "'");
    if ((source.mPrimitiveTypes & aiPrimitiveType_TRIANGLE) == 0) {
      ++skipped_meshes_;
      file_.warnings.push_back(
          absl::StrCat(file_name_, ": ", name, ": skipped point/line mesh (no surface to render)"));
      return absl::OkStatus();
    }
    if (source.mNumVertices > kMaxVerticesPerMesh) {
      return absl::InvalidArgumentError(absl::StrCat(
          name, ": ", source.mNumVertices, " vertices exceed the limit of ", kMaxVerticesPerMesh));
    }
    if (source.mNumFaces > kMaxTrianglesPerMesh) {
      return absl::InvalidArgumentError(absl::StrCat(
          name, ": ", source.mNumFaces, " faces exceed the limit of ", kMaxTrianglesPerMesh));
    }
    total_triangles_ += source.mNumFaces;
    if (total_triangles_ > kMaxSceneTriangles) {
      return absl::InvalidArgumentError(absl::StrCat(
          name, ": the node hierarchy instances more than ", kMaxSceneTriangles, " triangles"));
    }
    Mesh mesh;
    mesh.name = absl::StrCat(file_name_, ": ", name);
    mesh.positions.resize(source.mNumVertices);
    for (unsigned v = 0; v < source.mNumVertices; ++v) {
      const aiVector3D& p = source.mVertices[v];
      mesh.positions[v] = {p.x, p.y, p.z};
    }
    if (source.HasNormals()) {
      mesh.normals.resize(source.mNumVertices);
      for (unsigned v = 0; v < source.mNumVertices; ++v) {
        const aiVector3D& n = source.mNormals[v];
        mesh.normals[v] = {n.x, n.y, n.z};
      }
    }
    // Assimp keeps bitangents where glTF keeps their sign; the sign says whether the file's
    // bitangent is cross(normal, tangent) or its opposite.
    if (source.HasNormals() && source.HasTangentsAndBitangents()) {
      mesh.tangents.resize(source.mNumVertices);
      for (unsigned v = 0; v < source.mNumVertices; ++v) {
        const aiVector3D& t = source.mTangents[v];
        const aiVector3D& b = source.mBitangents[v];
        const Vec3f tangent{t.x, t.y, t.z};
        // Assimp marks a tangent it could not derive (degenerate texture coordinates) with NaN;
        // a zero tangent says the same to the renderer.
        if (!is_finite(tangent)) {
          mesh.tangents[v] = {0.0f, 0.0f, 0.0f, 1.0f};
          continue;
        }
        const float sign =
            dot(cross(mesh.normals[v], tangent), Vec3f{b.x, b.y, b.z}) < 0.0f ? -1.0f : 1.0f;
        mesh.tangents[v] = {t.x, t.y, t.z, sign};
      }
    }
    if (source.HasTextureCoords(0)) {
      mesh.uvs.resize(source.mNumVertices);
      for (unsigned v = 0; v < source.mNumVertices; ++v) {
        const aiVector3D& uv = source.mTextureCoords[0][v];
        mesh.uvs[v] = {uv.x, 1.0f - uv.y};  // v down the image, as glTF's
      }
    }
    mesh.indices.reserve(3 * size_t{source.mNumFaces});
    for (unsigned f = 0; f < source.mNumFaces; ++f) {
      const aiFace& face = source.mFaces[f];
      // After Triangulate and SortByPType a triangle mesh holds triangles only; anything else
      // would be a point or line that slipped through, with no area.
      if (face.mNumIndices != 3) continue;
      for (unsigned k = 0; k < 3; ++k) {
        if (face.mIndices[k] >= source.mNumVertices) {
          return absl::InvalidArgumentError(absl::StrCat(name, ": face ", f, " vertex index ",
                                                         face.mIndices[k], " is out of range (",
                                                         source.mNumVertices, " vertices)"));
        }
        mesh.indices.push_back(face.mIndices[k]);
      }
    }
    if (mesh.indices.empty()) return absl::OkStatus();
    uint32_t material = kNoMaterial;
    if (source.mMaterialIndex < file_.materials.size()) material = source.mMaterialIndex;
    mesh.material_ids.assign(mesh.triangle_count(), material);
    transform_mesh(world, &mesh);
    file_.meshes.push_back(std::move(mesh));
    return absl::OkStatus();
  }

  // The maps of `material`, read as `read`, that no material model reads (a 3DS file's specular
  // maps, metalness and roughness maps of a material that is not metallic-roughness), gathered by
  // kind for one warning each.
  void note_unread_maps(const aiMaterial& material, const Material& read) {
    const bool pbr = read.type == MaterialType::kMetallicRoughness;
    static constexpr std::pair<aiTextureType, const char*> kUnread[] = {
        {aiTextureType_DISPLACEMENT, "displacement"},
        {aiTextureType_SPECULAR, "specular"},
        {aiTextureType_SHININESS, "shininess"},
        {aiTextureType_AMBIENT, "ambient"},
        {aiTextureType_LIGHTMAP, "light"},
        {aiTextureType_AMBIENT_OCCLUSION, "ambient occlusion"},
        {aiTextureType_REFLECTION, "reflection"},
        {aiTextureType_METALNESS, "metalness"},
        {aiTextureType_DIFFUSE_ROUGHNESS, "roughness"},
        {aiTextureType_UNKNOWN, "unknown"},
    };
    for (const auto& [type, kind] : kUnread) {
      if (pbr && (type == aiTextureType_METALNESS || type == aiTextureType_DIFFUSE_ROUGHNESS))
        continue;
      for (unsigned t = 0; t < material.GetTextureCount(type); ++t) {
        aiString file;
        if (material.GetTexture(type, t, &file) != AI_SUCCESS) continue;
        unread_maps_.note(kind, file.C_Str());
      }
    }
  }

  // The first texture of `types` Assimp reports for a material (base colour or diffuse, emission
  // colour or emissive, normals, heights, ...): a file beside the model, or one the model embeds in
  // a file format's bytes. Embedded raw texels are left out with a warning.
  TextureRef texture_map(const aiMaterial& material, const std::string& name,
                         std::initializer_list<aiTextureType> types) {
    TextureRef ref;
    aiString file;
    aiTextureMapMode modes[2] = {aiTextureMapMode_Wrap, aiTextureMapMode_Wrap};
    unsigned uv_index = 0;
    bool found = false;
    for (const aiTextureType type : types) {
      if (material.GetTextureCount(type) > 0 &&
          material.GetTexture(type, 0, &file, nullptr, &uv_index, nullptr, nullptr, modes) ==
              AI_SUCCESS) {
        found = true;
        break;
      }
    }
    if (!found || file.length == 0) return ref;
    if (uv_index != 0) {
      file_.warnings.push_back(absl::StrCat(file_name_, ": material '", name,
                                            "': its texture reads UV set ", uv_index,
                                            ", but only the first is read; left out"));
      return ref;
    }
    if (const aiTexture* embedded = scene_.GetEmbeddedTexture(file.C_Str()); embedded != nullptr) {
      if (embedded->mHeight != 0) {
        file_.warnings.push_back(absl::StrCat(file_name_, ": material '", name,
                                              "': its embedded texture is raw texels, which are "
                                              "not read; left out"));
        return ref;
      }
      ref.texture = textures_.from_bytes(
          absl::StrCat("embedded ", file.C_Str()), absl::StrCat(file_name_, " ", file.C_Str()),
          std::string(reinterpret_cast<const char*>(embedded->pcData), embedded->mWidth));
    } else {
      ref.texture = textures_.from_file(file.C_Str(), file_.warnings);
    }
    const auto wrap = [](aiTextureMapMode mode) {
      return mode == aiTextureMapMode_Clamp    ? TextureWrap::kClampToEdge
             : mode == aiTextureMapMode_Mirror ? TextureWrap::kMirroredRepeat
                                               : TextureWrap::kRepeat;
    };
    ref.wrap_u = wrap(modes[0]);
    ref.wrap_v = wrap(modes[1]);
    return ref;
  }

  const aiScene& scene_;
  std::string file_name_;
  bool is_3ds_;
  TextureTable textures_;
  size_t skipped_meshes_ = 0;
  size_t total_triangles_ = 0;
  std::unordered_map<std::string, Affine> node_worlds_;  // the first node of each name
  UnreadMaps unread_maps_;
  MeshFile file_;
};

}  // namespace

bool assimp_reads_extension(std::string_view extension) {
  if (extension.size() < 2 || extension[0] != '.') return false;
  Assimp::Importer importer;
  return importer.IsExtensionSupported(std::string(extension));
}

absl::StatusOr<MeshFile> load_assimp(const std::filesystem::path& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    return absl::NotFoundError(absl::StrCat(path.string(), ": file not found"));
  }
  // Assimp reads the whole file into memory; the same cap as for every other mesh file.
  if (const uintmax_t size = std::filesystem::file_size(path, error);
      !error && size > kMaxFileBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat(path.string(), ": ", size, " bytes exceed the limit of ", kMaxFileBytes));
  }
  Assimp::Importer importer;
  const aiScene* scene = nullptr;
  try {
    scene = importer.ReadFile(path.string(), kPostProcess);
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat(path.string(), ": Assimp could not read it: ", e.what()));
  }
  if (scene == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat(path.string(), ": Assimp could not read it: ",
                     absl::StripTrailingAsciiWhitespace(importer.GetErrorString())));
  }
  if ((scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) != 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        path.string(), ": Assimp read it only partially (the scene is marked incomplete)"));
  }
  absl::StatusOr<MeshFile> file = AssimpReader(*scene, path).read();
  if (!file.ok()) return annotate(file.status(), path.string());
  return file;
}

}  // namespace caustica
