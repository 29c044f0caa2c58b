#include "renderer/scene/scene_json.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "renderer/accel/build_options.h"
#include "renderer/accel/structure_kind.h"
#include "renderer/scene/density_grid.h"
#include "renderer/scene/json_fields.h"
#include "renderer/scene/mesh_file.h"
#include "renderer/scene/scene_limits.h"
#include "renderer/scene/shapes.h"
#include "renderer/scene/status_util.h"
#include "renderer/scene/texture_files.h"
#include "renderer/scene/transform.h"

namespace caustica {
namespace {

constexpr Presence kRequired = Presence::kRequired;
constexpr Presence kOptional = Presence::kOptional;

// nlohmann reports a byte offset; people want line:column. The offset is 1-based and points at
// the character that could not be parsed.
absl::Status syntax_error(absl::string_view text, const Json::parse_error& error,
                          absl::string_view source_name) {
  const size_t offset = std::min<size_t>(error.byte > 0 ? error.byte - 1 : 0, text.size());
  const absl::string_view before = text.substr(0, offset);
  const size_t line = 1 + std::count(before.begin(), before.end(), '\n');
  const size_t line_start = before.rfind('\n');
  const size_t column = line_start == absl::string_view::npos ? offset + 1 : offset - line_start;
  // Keep nlohmann's description, without its own "[json.exception...] ... column N: " prefix.
  absl::string_view description = error.what();
  if (const size_t at = description.find("column "); at != absl::string_view::npos) {
    if (const size_t colon = description.find(": ", at); colon != absl::string_view::npos) {
      description.remove_prefix(colon + 2);
    }
  }
  return absl::InvalidArgumentError(
      absl::StrCat(source_name, ":", line, ":", column, ": JSON syntax error: ", description));
}

// Sizes of procedural shapes: required, and a zero or negative one is a mistake.
absl::StatusOr<float> read_positive(JsonObject& object, absl::string_view key) {
  float value = 0;
  SCENE_RETURN_IF_ERROR(object.read(key, kRequired, &value));
  if (!(value > 0)) {
    return invalid_field(object.field_path(key), absl::StrCat("must be > 0, got ", value));
  }
  return value;
}

absl::StatusOr<std::vector<Vec3f>> read_points(JsonObject& object, absl::string_view key) {
  SCENE_ASSIGN_OR_RETURN(const Json* array, object.find(key, kRequired));
  const std::string path = object.field_path(key);
  SCENE_RETURN_IF_ERROR(json_expect_array(*array, path));
  std::vector<Vec3f> points;
  points.reserve(array->size());
  for (size_t i = 0; i < array->size(); ++i) {
    SCENE_ASSIGN_OR_RETURN(const Vec3f p, json_to_vec3((*array)[i], element_path(path, i)));
    points.push_back(p);
  }
  return points;
}

}  // namespace

std::string shape_label(absl::string_view path, absl::string_view scene_name,
                        absl::string_view file_part) {
  std::string label(path);
  if (!scene_name.empty()) absl::StrAppend(&label, " '", scene_name, "'");
  if (!file_part.empty()) absl::StrAppend(&label, " (", file_part, ")");
  return label;
}

ShapeLabel parse_shape_label(absl::string_view label) {
  ShapeLabel out;
  if (!absl::StartsWith(label, "shapes[")) return out;
  const size_t close = label.find(']');
  if (close == absl::string_view::npos) return out;
  out.path = label.substr(0, close + 1);
  absl::string_view rest = label.substr(close + 1);
  if (absl::ConsumePrefix(&rest, " '")) {
    // The name runs to the last quote before the file's part, which may itself hold quotes.
    const size_t part = rest.rfind("' (");
    const size_t end = absl::EndsWith(rest, "'") ? rest.size() - 1 : part;
    if (end != absl::string_view::npos) out.name = rest.substr(0, end);
  }
  return out;
}

namespace {

// One of `choices` (a name and the value it stands for) by the name `key` holds; `what` names
// the kind in the error, which lists the names.
template <typename T>
absl::Status read_choice(JsonObject& object, const char* key, const char* what,
                         std::initializer_list<std::pair<const char*, T>> choices, T* out) {
  std::string name;
  SCENE_RETURN_IF_ERROR(object.read(key, kRequired, &name));
  std::string expected;
  size_t i = 0;
  for (const auto& [choice, value] : choices) {
    if (name == choice) {
      *out = value;
      return absl::OkStatus();
    }
    const char* separator = i == 0 ? "" : i + 1 == choices.size() ? " or " : ", ";
    absl::StrAppend(&expected, separator, choice);
    ++i;
  }
  return invalid_field(object.field_path(key),
                       absl::StrCat("unknown ", what, " '", name, "' (expected ", expected, ")"));
}

// A setting of several kinds (scene/setting_kinds.h) by the name `key` holds, when it is there.
template <typename Enum>
absl::Status read_kind(JsonObject& object, const char* key, Enum* out) {
  if (!object.has(key)) return absl::OkStatus();
  std::string name;
  SCENE_RETURN_IF_ERROR(object.read(key, kRequired, &name));
  const std::optional<Enum> kind = parse_kind<Enum>(name);
  if (!kind) return invalid_field(object.field_path(key), unknown_kind_message<Enum>(name));
  *out = *kind;
  return absl::OkStatus();
}

class SceneReader {
 public:
  explicit SceneReader(const std::filesystem::path& base_dir) : base_dir_(base_dir) {}

  // What the mesh files' loaders warned of, each after the field of the shape that named it.
  std::vector<std::string>& warnings() { return warnings_; }

  absl::StatusOr<Scene> read(const Json& root) {
    SCENE_ASSIGN_OR_RETURN(JsonObject top, JsonObject::open(root, ""));
    SCENE_ASSIGN_OR_RETURN(const Json* camera, top.find("camera", kRequired));
    SCENE_RETURN_IF_ERROR(read_camera(*camera));
    SCENE_ASSIGN_OR_RETURN(const Json* settings, top.find("settings", kOptional));
    if (settings != nullptr) SCENE_RETURN_IF_ERROR(read_settings(*settings));
    SCENE_ASSIGN_OR_RETURN(const Json* materials, top.find("materials", kOptional));
    if (materials != nullptr) {
      SCENE_RETURN_IF_ERROR(
          read_named_entries(*materials, "materials",
                             [this](const std::string& name, const Json& v, std::string path) {
                               return read_material(name, v, std::move(path));
                             }));
    }
    SCENE_ASSIGN_OR_RETURN(const Json* environment, top.find("environment", kOptional));
    if (environment != nullptr) SCENE_RETURN_IF_ERROR(read_environment(*environment));
    // Model files' textures, which shapes bring, follow.
    scene_.textures = scene_textures_.take();
    SCENE_ASSIGN_OR_RETURN(const Json* media, top.find("media", kOptional));
    if (media != nullptr) {
      SCENE_RETURN_IF_ERROR(read_named_entries(
          *media, "media", [this](const std::string& name, const Json& v, std::string path) {
            return read_medium(name, v, std::move(path));
          }));
    }
    SCENE_ASSIGN_OR_RETURN(const Json* medium, top.find("medium", kOptional));
    if (medium != nullptr) {
      SCENE_ASSIGN_OR_RETURN(scene_.medium, medium_named(*medium, "medium"));
    }
    // Lights before shapes: lights[i] of the file stays scene.lights[i], and lights that come
    // with mesh files follow.
    SCENE_ASSIGN_OR_RETURN(const Json* lights, top.find("lights", kOptional));
    if (lights != nullptr) SCENE_RETURN_IF_ERROR(read_lights(*lights));
    SCENE_ASSIGN_OR_RETURN(const Json* shapes, top.find("shapes", kOptional));
    SCENE_RETURN_IF_ERROR(top.finish());
    if (shapes != nullptr) SCENE_RETURN_IF_ERROR(read_shapes(*shapes));
    return std::move(scene_);
  }

 private:
  absl::Status read_camera(const Json& value) {
    SCENE_ASSIGN_OR_RETURN(JsonObject object, JsonObject::open(value, "camera"));
    Camera& camera = scene_.camera;
    SCENE_RETURN_IF_ERROR(object.read("position", kRequired, &camera.position));
    SCENE_RETURN_IF_ERROR(object.read("look_at", kRequired, &camera.look_at));
    SCENE_RETURN_IF_ERROR(object.read("up", kOptional, &camera.up));
    SCENE_RETURN_IF_ERROR(object.read("fov", kRequired, &camera.vertical_fov_deg));
    SCENE_RETURN_IF_ERROR(object.read_integer("width", kRequired, &camera.width));
    SCENE_RETURN_IF_ERROR(object.read_integer("height", kRequired, &camera.height));
    return object.finish();
  }

  absl::Status read_settings(const Json& value) {
    SCENE_ASSIGN_OR_RETURN(JsonObject object, JsonObject::open(value, "settings"));
    RenderSettings& s = scene_.settings;
    SCENE_RETURN_IF_ERROR(object.read_integer("photons", kOptional, &s.photons_per_pass));
    SCENE_RETURN_IF_ERROR(object.read_integer("k", kOptional, &s.k_nearest));
    SCENE_RETURN_IF_ERROR(object.read("max_radius", kOptional, &s.max_radius));
    SCENE_RETURN_IF_ERROR(read_kind(object, "kernel", &s.kernel));
    SCENE_RETURN_IF_ERROR(object.read_integer("max_depth", kOptional, &s.max_depth));
    SCENE_RETURN_IF_ERROR(
        object.read_integer("max_photon_bounces", kOptional, &s.max_photon_bounces));
    SCENE_RETURN_IF_ERROR(object.read_integer("max_photon_specular_bounces", kOptional,
                                              &s.max_photon_specular_bounces));
    SCENE_RETURN_IF_ERROR(
        object.read_integer("area_light_samples", kOptional, &s.area_light_samples));
    SCENE_RETURN_IF_ERROR(object.read_integer("passes", kOptional, &s.passes));
    SCENE_RETURN_IF_ERROR(object.read_integer("seed", kOptional, &s.seed));
    SCENE_RETURN_IF_ERROR(read_kind(object, "integrator", &s.integrator));
    SCENE_RETURN_IF_ERROR(read_kind(object, "estimator", &s.estimator));
    SCENE_RETURN_IF_ERROR(object.read("sppm_alpha", kOptional, &s.sppm_alpha));
    SCENE_RETURN_IF_ERROR(object.read("vkde_spread", kOptional, &s.vkde_spread));
    SCENE_RETURN_IF_ERROR(object.read("final_gather", kOptional, &s.final_gather));
    SCENE_RETURN_IF_ERROR(
        object.read_integer("final_gather_rays", kOptional, &s.final_gather_rays));
    SCENE_RETURN_IF_ERROR(
        object.read_integer("final_gather_seeds", kOptional, &s.final_gather_seeds));
    SCENE_RETURN_IF_ERROR(read_kind(object, "sppm_radius", &s.sppm_radius));
    if (object.has("structure")) {
      std::string structure;
      SCENE_RETURN_IF_ERROR(object.read("structure", kRequired, &structure));
      const std::optional<StructureKind> kind = parse_structure_kind(structure);
      if (!kind) {
        return invalid_field(object.field_path("structure"), unknown_structure_message(structure));
      }
      s.structure = *kind;
    }
    SCENE_ASSIGN_OR_RETURN(const Json* build, object.find("build", kOptional));
    if (build != nullptr) SCENE_RETURN_IF_ERROR(read_build(*build, object.field_path("build")));
    return object.finish();
  }

  // settings.build: what the structure's builder is told (accel/build_options.h).
  absl::Status read_build(const Json& value, std::string path) {
    SCENE_ASSIGN_OR_RETURN(JsonObject object, JsonObject::open(value, std::move(path)));
    BuildOptions& b = scene_.settings.build;
    if (object.has("binned_sah_stages")) {
      std::string stages;
      SCENE_RETURN_IF_ERROR(object.read("binned_sah_stages", kRequired, &stages));
      if (std::optional<std::string> problem = parse_binned_sah_stages(stages, b.binned_sah)) {
        return invalid_field(object.field_path("binned_sah_stages"), *problem);
      }
    }
    SCENE_RETURN_IF_ERROR(read_kind(object, "binned_sah_reorder", &b.binned_sah.reorder));
    SCENE_RETURN_IF_ERROR(read_kind(object, "kd_traversal", &b.kd_traversal));
    SCENE_RETURN_IF_ERROR(read_kind(object, "refit", &b.refit));
    SCENE_RETURN_IF_ERROR(object.read("refit_sah_bound", kOptional, &b.refit_sah_bound));
    return object.finish();
  }

  // An object of named entries ("materials", "media"), each read by read_entry(name, value,
  // path).
  template <typename ReadEntry>
  absl::Status read_named_entries(const Json& value, const char* key, ReadEntry read_entry) {
    SCENE_ASSIGN_OR_RETURN(const JsonObject object, JsonObject::open(value, key));
    for (const auto& [name, entry] : value.items()) {
      SCENE_RETURN_IF_ERROR(read_entry(name, entry, object.field_path(name)));
    }
    return absl::OkStatus();
  }

  // The index `ids` gives the name that `value` holds at `path`; `what` and `where` name the kind
  // of entry and the list it should be in.
  static absl::StatusOr<uint32_t> index_named(
      const std::map<std::string, uint32_t, std::less<>>& ids, const Json& value,
      const std::string& path, absl::string_view what, absl::string_view where) {
    SCENE_ASSIGN_OR_RETURN(const std::string name, json_to_string(value, path));
    const auto it = ids.find(name);
    if (it == ids.end()) {
      return invalid_field(path,
                           absl::StrCat("unknown ", what, " '", name, "' (not in ", where, ")"));
    }
    return it->second;
  }

  // A material's map: an image file beside the scene file, as a string or as
  // {"file": ..., "wrap": "repeat" | "clamp" | "mirror"} (docs/scene-format.md, "Textures"). Each
  // file becomes one texture of the scene however many maps name it.
  absl::StatusOr<TextureRef> read_map(JsonObject& material, absl::string_view key) {
    SCENE_ASSIGN_OR_RETURN(const Json* value, material.find(key, kOptional));
    TextureRef ref;
    if (value == nullptr) return ref;
    const std::string path = material.field_path(key);
    std::string file;
    std::string wrap = "repeat";
    if (value->is_string()) {
      SCENE_ASSIGN_OR_RETURN(file, json_to_string(*value, path));
    } else {
      SCENE_ASSIGN_OR_RETURN(JsonObject object, JsonObject::open(*value, path));
      SCENE_RETURN_IF_ERROR(object.read("file", kRequired, &file));
      SCENE_RETURN_IF_ERROR(object.read("wrap", kOptional, &wrap));
      SCENE_RETURN_IF_ERROR(object.finish());
    }
    if (wrap == "repeat") {
      ref.wrap_u = ref.wrap_v = TextureWrap::kRepeat;
    } else if (wrap == "clamp") {
      ref.wrap_u = ref.wrap_v = TextureWrap::kClampToEdge;
    } else if (wrap == "mirror") {
      ref.wrap_u = ref.wrap_v = TextureWrap::kMirroredRepeat;
    } else {
      return invalid_field(
          absl::StrCat(path, ".wrap"),
          absl::StrCat("unknown wrap '", wrap, "' (expected repeat, clamp or mirror)"));
    }
    absl::StatusOr<uint32_t> texture = scene_textures_.read(file);
    if (!texture.ok()) return annotate(texture.status(), path);
    ref.texture = *texture;
    return ref;
  }

  absl::Status read_material(const std::string& name, const Json& value, std::string path) {
    SCENE_ASSIGN_OR_RETURN(JsonObject object, JsonObject::open(value, std::move(path)));
    Material material;
    material.name = name;
    std::string type;
    SCENE_RETURN_IF_ERROR(object.read("type", kRequired, &type));
    if (type == "diffuse") {
      material.type = MaterialType::kDiffuse;
      SCENE_RETURN_IF_ERROR(object.read("albedo", kRequired, &material.color));
    } else if (type == "mirror") {
      material.type = MaterialType::kMirror;
      SCENE_RETURN_IF_ERROR(object.read("reflectance", kRequired, &material.color));
    } else if (type == "dielectric") {
      material.type = MaterialType::kDielectric;
      SCENE_RETURN_IF_ERROR(object.read("ior", kOptional, &material.ior));
      SCENE_RETURN_IF_ERROR(object.read("roughness", kOptional, &material.roughness));
    } else if (type == "emissive") {
      material.type = MaterialType::kEmissive;
      material.color = Vec3f(0);
      SCENE_RETURN_IF_ERROR(object.read("radiance", kRequired, &material.radiance));
    } else if (type == "metallic_roughness") {
      material.type = MaterialType::kMetallicRoughness;
      // Half rough: a scene that names no roughness gets a visible highlight, neither a mirror
      // nor a matte surface.
      material.roughness = 0.5f;
      SCENE_RETURN_IF_ERROR(object.read("color", kOptional, &material.color));
      SCENE_RETURN_IF_ERROR(object.read("metallic", kOptional, &material.metallic));
      SCENE_RETURN_IF_ERROR(object.read("roughness", kOptional, &material.roughness));
      SCENE_ASSIGN_OR_RETURN(material.metallic_roughness_map,
                             read_map(object, "metallic_roughness_map"));
      SCENE_ASSIGN_OR_RETURN(material.roughness_map, read_map(object, "roughness_map"));
      SCENE_ASSIGN_OR_RETURN(material.metallic_map, read_map(object, "metallic_map"));
    } else if (type == "phong") {
      material.type = MaterialType::kPhong;
      // The defaults sum to 1: white light is all reflected, mostly diffusely.
      material.specular = Vec3f(0.2f);
      SCENE_RETURN_IF_ERROR(object.read("color", kOptional, &material.color));
      SCENE_RETURN_IF_ERROR(object.read("specular", kOptional, &material.specular));
      SCENE_RETURN_IF_ERROR(object.read("exponent", kOptional, &material.exponent));
    } else {
      return invalid_field(object.field_path("type"),
                           absl::StrCat("unknown material type '", type,
                                        "' (expected diffuse, mirror, dielectric, emissive, "
                                        "metallic_roughness or phong)"));
    }
    // Any other kind may also emit from its front face, as a model file's emissive surfaces do.
    if (material.type != MaterialType::kEmissive)
      SCENE_RETURN_IF_ERROR(object.read("radiance", kOptional, &material.radiance));
    SCENE_ASSIGN_OR_RETURN(material.color_map, read_map(object, "color_map"));
    SCENE_ASSIGN_OR_RETURN(material.emission_map, read_map(object, "emission_map"));
    SCENE_ASSIGN_OR_RETURN(material.normal_map, read_map(object, "normal_map"));
    SCENE_RETURN_IF_ERROR(object.read("normal_scale", kOptional, &material.normal_scale));
    SCENE_ASSIGN_OR_RETURN(material.bump_map, read_map(object, "bump_map"));
    SCENE_RETURN_IF_ERROR(object.read("bump_scale", kOptional, &material.bump_scale));
    if (object.has("alpha_mode")) {
      SCENE_RETURN_IF_ERROR(read_choice(object, "alpha_mode", "alpha mode",
                                        {std::pair{"opaque", AlphaMode::kOpaque},
                                         {"mask", AlphaMode::kMask},
                                         {"blend", AlphaMode::kBlend}},
                                        &material.alpha_mode));
    }
    SCENE_RETURN_IF_ERROR(object.read("opacity", kOptional, &material.opacity));
    SCENE_RETURN_IF_ERROR(object.read("alpha_cutoff", kOptional, &material.alpha_cutoff));
    SCENE_ASSIGN_OR_RETURN(material.opacity_map, read_map(object, "opacity_map"));
    SCENE_RETURN_IF_ERROR(object.finish());
    material_ids_[name] = static_cast<uint32_t>(scene_.materials.size());
    scene_.materials.push_back(std::move(material));
    return absl::OkStatus();
  }

  absl::Status read_medium(const std::string& name, const Json& value, std::string path) {
    SCENE_ASSIGN_OR_RETURN(JsonObject object, JsonObject::open(value, std::move(path)));
    Medium medium;
    medium.name = name;
    SCENE_RETURN_IF_ERROR(read_choice(
        object, "type", "medium type",
        {std::pair{"homogeneous", MediumType::kHomogeneous}, {"grid", MediumType::kGrid}},
        &medium.type));
    SCENE_RETURN_IF_ERROR(object.read("absorption", kRequired, &medium.absorption));
    SCENE_RETURN_IF_ERROR(object.read("scattering", kRequired, &medium.scattering));
    SCENE_RETURN_IF_ERROR(object.read("g", kOptional, &medium.asymmetry));
    if (medium.type == MediumType::kGrid) SCENE_RETURN_IF_ERROR(read_grid(object, &medium));
    SCENE_RETURN_IF_ERROR(object.finish());
    medium_ids_[name] = static_cast<uint32_t>(scene_.media.size());
    scene_.media.push_back(std::move(medium));
    return absl::OkStatus();
  }

  // A grid medium's "file" (a NanoVDB file, relative to the scene file), the "grid" in it to
  // read (its first by default) and its "transform" into the scene.
  absl::Status read_grid(JsonObject& object, Medium* medium) {
    std::string file, grid_name;
    SCENE_RETURN_IF_ERROR(object.read("file", kRequired, &file));
    SCENE_RETURN_IF_ERROR(object.read("grid", kOptional, &grid_name));
    SCENE_ASSIGN_OR_RETURN(const Json* transform, object.find("transform", kOptional));
    if (transform != nullptr) {
      SCENE_ASSIGN_OR_RETURN(medium->grid_to_scene,
                             read_transform(*transform, object.field_path("transform")));
    }
    SCENE_ASSIGN_OR_RETURN(
        medium->grid, read_density_grid(base_dir_ / file, grid_name, object.field_path("file")));
    medium->grid_source = grid_name.empty() ? file : absl::StrCat(file, " (", grid_name, ")");
    return absl::OkStatus();
  }

  // The index of the medium `value` names, at `path`.
  absl::StatusOr<uint32_t> medium_named(const Json& value, const std::string& path) {
    return index_named(medium_ids_, value, path, "medium", "media");
  }

  // The medium a shape encloses ("medium"), or kNoMedium.
  absl::StatusOr<uint32_t> read_interior_medium(JsonObject& shape) {
    SCENE_ASSIGN_OR_RETURN(const Json* value, shape.find("medium", kOptional));
    if (value == nullptr) return kNoMedium;
    return medium_named(*value, shape.field_path("medium"));
  }

  // {"map": image file, "color": [r, g, b], "intensity": x, "rotation": degrees}, every key
  // optional (docs/scene-format.md, "Environment").
  absl::Status read_environment(const Json& value) {
    SCENE_ASSIGN_OR_RETURN(JsonObject object, JsonObject::open(value, "environment"));
    Environment& e = scene_.environment;
    e.present = true;
    SCENE_ASSIGN_OR_RETURN(const Json* map, object.find("map", kOptional));
    if (map != nullptr) {
      SCENE_ASSIGN_OR_RETURN(const std::string file,
                             json_to_string(*map, object.field_path("map")));
      absl::StatusOr<uint32_t> texture = scene_textures_.read(file);
      if (!texture.ok()) return annotate(texture.status(), object.field_path("map"));
      e.texture = *texture;
    }
    SCENE_RETURN_IF_ERROR(object.read("color", kOptional, &e.color));
    SCENE_RETURN_IF_ERROR(object.read("intensity", kOptional, &e.intensity));
    SCENE_RETURN_IF_ERROR(object.read("rotation", kOptional, &e.rotation_deg));
    return object.finish();
  }

  absl::Status read_lights(const Json& value) {
    SCENE_RETURN_IF_ERROR(json_expect_array(value, "lights"));
    for (size_t i = 0; i < value.size(); ++i) {
      SCENE_RETURN_IF_ERROR(read_light(value[i], element_path("lights", i)));
    }
    return absl::OkStatus();
  }

  absl::Status read_light(const Json& value, std::string path) {
    SCENE_ASSIGN_OR_RETURN(JsonObject object, JsonObject::open(value, std::move(path)));
    Light light;
    std::string type;
    SCENE_RETURN_IF_ERROR(object.read("type", kRequired, &type));
    SCENE_RETURN_IF_ERROR(object.read("name", kOptional, &light.name));
    if (type == "point") {
      light.type = LightType::kPoint;
      SCENE_RETURN_IF_ERROR(object.read("position", kRequired, &light.position));
      SCENE_RETURN_IF_ERROR(object.read("intensity", kRequired, &light.intensity));
    } else if (type == "spot") {
      light.type = LightType::kSpot;
      SCENE_RETURN_IF_ERROR(object.read("position", kRequired, &light.position));
      SCENE_RETURN_IF_ERROR(object.read("direction", kRequired, &light.direction));
      SCENE_RETURN_IF_ERROR(object.read("intensity", kRequired, &light.intensity));
      SCENE_RETURN_IF_ERROR(object.read("inner_angle", kOptional, &light.inner_angle_deg));
      SCENE_RETURN_IF_ERROR(object.read("outer_angle", kOptional, &light.outer_angle_deg));
    } else if (type == "directional") {
      light.type = LightType::kDirectional;
      SCENE_RETURN_IF_ERROR(object.read("direction", kRequired, &light.direction));
      SCENE_RETURN_IF_ERROR(object.read("irradiance", kRequired, &light.intensity));
    } else {
      return invalid_field(
          object.field_path("type"),
          absl::StrCat("unknown light type '", type, "' (expected point, spot or directional)"));
    }
    SCENE_RETURN_IF_ERROR(object.finish());
    // A zero direction stays zero for validation to report.
    if (length_squared(light.direction) > 0) light.direction = normalize(light.direction);
    scene_.lights.push_back(std::move(light));
    return absl::OkStatus();
  }

  absl::Status read_shapes(const Json& value) {
    SCENE_RETURN_IF_ERROR(json_expect_array(value, "shapes"));
    for (size_t i = 0; i < value.size(); ++i) {
      SCENE_RETURN_IF_ERROR(read_shape(value[i], element_path("shapes", i)));
    }
    return absl::OkStatus();
  }

  // The material a shape names, or nullopt when it names none (allowed only when optional).
  absl::StatusOr<std::optional<uint32_t>> read_material_ref(JsonObject& shape, Presence presence) {
    SCENE_ASSIGN_OR_RETURN(const Json* value, shape.find("material", presence));
    if (value == nullptr) return std::nullopt;
    return index_named(material_ids_, *value, shape.field_path("material"), "material",
                       "materials");
  }

  absl::Status read_shape(const Json& value, std::string path) {
    SCENE_ASSIGN_OR_RETURN(JsonObject shape, JsonObject::open(value, std::move(path)));
    std::string type, name;
    SCENE_RETURN_IF_ERROR(shape.read("type", kRequired, &type));
    SCENE_RETURN_IF_ERROR(shape.read("name", kOptional, &name));
    if (type == "mesh") return read_mesh_shape(shape, name);

    SCENE_ASSIGN_OR_RETURN(const std::optional<uint32_t> material,
                           read_material_ref(shape, kRequired));
    SCENE_ASSIGN_OR_RETURN(const uint32_t interior, read_interior_medium(shape));
    Mesh mesh;
    if (type == "quad") {
      SCENE_ASSIGN_OR_RETURN(mesh, read_quad(shape));
    } else if (type == "triangles") {
      SCENE_ASSIGN_OR_RETURN(mesh, read_triangles(shape));
    } else if (type == "sphere") {
      SCENE_ASSIGN_OR_RETURN(mesh, read_sphere(shape));
    } else if (type == "ring") {
      SCENE_ASSIGN_OR_RETURN(mesh, read_ring(shape));
    } else {
      return invalid_field(shape.field_path("type"),
                           absl::StrCat("unknown shape type '", type,
                                        "' (expected quad, triangles, sphere, ring or mesh)"));
    }
    SCENE_RETURN_IF_ERROR(shape.finish());
    mesh.name = shape_label(shape.path(), name, "");
    mesh.material_ids.assign(mesh.triangle_count(), *material);
    mesh.interior_medium = interior;
    scene_.meshes.push_back(std::move(mesh));
    return absl::OkStatus();
  }

  absl::StatusOr<Mesh> read_quad(JsonObject& shape) {
    SCENE_ASSIGN_OR_RETURN(const std::vector<Vec3f> points, read_points(shape, "vertices"));
    if (points.size() != 4) {
      return invalid_field(shape.field_path("vertices"),
                           absl::StrCat("a quad needs 4 vertices, got ", points.size()));
    }
    return make_quad({points[0], points[1], points[2], points[3]});
  }

  absl::StatusOr<Mesh> read_triangles(JsonObject& shape) {
    Mesh mesh;
    SCENE_ASSIGN_OR_RETURN(mesh.positions, read_points(shape, "vertices"));
    SCENE_ASSIGN_OR_RETURN(const Json* indices, shape.find("indices", kRequired));
    const std::string path = shape.field_path("indices");
    SCENE_RETURN_IF_ERROR(json_expect_array(*indices, path));
    if (indices->size() % 3 != 0) {
      return invalid_field(path, absl::StrCat(indices->size(), " indices is not a multiple of 3"));
    }
    mesh.indices.reserve(indices->size());
    for (size_t i = 0; i < indices->size(); ++i) {
      const std::string index_path = element_path(path, i);
      SCENE_ASSIGN_OR_RETURN(const int64_t index,
                             json_to_integer((*indices)[i], index_path, 0, UINT32_MAX));
      if (static_cast<uint64_t>(index) >= mesh.positions.size()) {
        return invalid_field(index_path,
                             absl::StrCat("vertex index ", index, " is out of range (there are ",
                                          mesh.positions.size(), " vertices)"));
      }
      mesh.indices.push_back(static_cast<uint32_t>(index));
    }
    return mesh;
  }

  // Rejects tessellations beyond the triangle limit before any memory is spent on them.
  static absl::Status check_triangle_budget(const JsonObject& shape, size_t triangles) {
    if (triangles > kMaxTrianglesPerMesh) {
      return invalid_field(
          shape.path(), absl::StrCat("tessellation gives ", triangles,
                                     " triangles, more than the limit of ", kMaxTrianglesPerMesh));
    }
    return absl::OkStatus();
  }

  absl::StatusOr<Mesh> read_sphere(JsonObject& shape) {
    Vec3f center;
    int rings = 32, segments = 64;
    SCENE_RETURN_IF_ERROR(shape.read("center", kRequired, &center));
    SCENE_ASSIGN_OR_RETURN(const float radius, read_positive(shape, "radius"));
    SCENE_RETURN_IF_ERROR(shape.read_integer("rings", kOptional, &rings, 2, 1 << 20));
    SCENE_RETURN_IF_ERROR(shape.read_integer("segments", kOptional, &segments, 3, 1 << 20));
    SCENE_RETURN_IF_ERROR(check_triangle_budget(shape, sphere_triangle_count(rings, segments)));
    return make_sphere(center, radius, rings, segments);
  }

  absl::StatusOr<Mesh> read_ring(JsonObject& shape) {
    Vec3f center;
    int segments = 128;
    SCENE_RETURN_IF_ERROR(shape.read("center", kRequired, &center));
    SCENE_ASSIGN_OR_RETURN(const float radius, read_positive(shape, "radius"));
    SCENE_ASSIGN_OR_RETURN(const float thickness, read_positive(shape, "thickness"));
    SCENE_ASSIGN_OR_RETURN(const float height, read_positive(shape, "height"));
    SCENE_RETURN_IF_ERROR(shape.read_integer("segments", kOptional, &segments, 3, 1 << 24));
    SCENE_RETURN_IF_ERROR(check_triangle_budget(shape, ring_triangle_count(segments)));
    return make_ring(center, radius, thickness, height, segments);
  }

  absl::Status read_mesh_shape(JsonObject& shape, const std::string& name) {
    std::string file;
    SCENE_RETURN_IF_ERROR(shape.read("file", kRequired, &file));
    SCENE_ASSIGN_OR_RETURN(const std::optional<uint32_t> material_override,
                           read_material_ref(shape, kOptional));
    SCENE_ASSIGN_OR_RETURN(const uint32_t interior, read_interior_medium(shape));
    // Absent means untouched: even an identity matrix would smear one NaN over x, y and z.
    std::optional<Affine> transform;
    SCENE_ASSIGN_OR_RETURN(const Json* transform_value, shape.find("transform", kOptional));
    if (transform_value != nullptr) {
      SCENE_ASSIGN_OR_RETURN(transform,
                             read_transform(*transform_value, shape.field_path("transform")));
    }
    SCENE_RETURN_IF_ERROR(shape.finish());

    const std::filesystem::path file_path = base_dir_ / file;
    absl::StatusOr<MeshFile> loaded = load_mesh_file(file_path);
    if (!loaded.ok()) return annotate(loaded.status(), shape.field_path("file"));
    MeshFile& mesh_file = *loaded;

    const std::string file_name = file_path.filename().string();
    for (const std::string& warning : mesh_file.warnings)
      warnings_.push_back(absl::StrCat(shape.field_path("file"), ": ", warning));
    const uint32_t first_material = static_cast<uint32_t>(scene_.materials.size());
    // The media the file's meshes enclose join the scene's, unless the shape names its own medium
    // or material; a transform's scale stretches the distances they absorb over.
    const auto first_medium = static_cast<uint32_t>(scene_.media.size());
    if (interior == kNoMedium && !material_override) {
      const double scale = transform ? std::cbrt(std::fabs(transform->determinant())) : 1.0;
      for (Medium& medium : mesh_file.media) {
        medium.name = absl::StrCat(file_name, ":", medium.name);
        medium.absorption = medium.absorption / float(scale);
        medium.scattering = medium.scattering / float(scale);
        scene_.media.push_back(std::move(medium));
      }
    }
    if (!material_override) {
      // The file's textures join the scene's, and its materials' maps follow them.
      const auto first_texture = static_cast<uint32_t>(scene_.textures.size());
      for (TextureImage& texture : mesh_file.textures)
        scene_.textures.push_back(std::move(texture));
      for (Material& material : mesh_file.materials) {
        material.name = absl::StrCat(file_name, ":", material.name);
        for (auto [map, name] : material.maps()) {
          if (map->used()) map->texture += first_texture;
        }
        scene_.materials.push_back(std::move(material));
      }
    }
    for (Mesh& mesh : mesh_file.meshes) {
      for (uint32_t& id : mesh.material_ids) {
        if (material_override) {
          id = *material_override;
        } else if (id == kNoMaterial) {
          return invalid_field(
              shape.field_path("material"),
              absl::StrCat("is required: ", mesh.name, " has triangles without a material"));
        } else {
          id += first_material;
        }
      }
      if (transform) transform_mesh(*transform, &mesh);
      mesh.name = shape_label(shape.path(), name, mesh.name);
      if (interior != kNoMedium || material_override) {
        mesh.interior_medium = interior;
      } else if (mesh.interior_medium != kNoMedium) {
        mesh.interior_medium += first_medium;
      }
      scene_.meshes.push_back(std::move(mesh));
    }
    for (Light& light : mesh_file.lights) {
      if (transform) transform_light(*transform, &light);
      scene_.lights.push_back(std::move(light));
    }
    return absl::OkStatus();
  }

  std::filesystem::path base_dir_;
  // The images the scene file's own maps name, which become the first of the scene's textures.
  TextureTable scene_textures_{base_dir_ / "scene.json"};
  Scene scene_;
  std::map<std::string, uint32_t, std::less<>> material_ids_;
  std::map<std::string, uint32_t, std::less<>> medium_ids_;
  std::vector<std::string> warnings_;
};

}  // namespace

absl::StatusOr<Scene> scene_from_json(absl::string_view json_text,
                                      const std::filesystem::path& base_dir,
                                      absl::string_view source_name,
                                      std::vector<std::string>* warnings) {
  Json root;
  // nlohmann reports errors by exception; they stop here, as module borders require.
  try {
    root = Json::parse(json_text, /*cb=*/nullptr, /*allow_exceptions=*/true,
                       /*ignore_comments=*/true);
  } catch (const Json::parse_error& error) {
    return syntax_error(json_text, error, source_name);
  } catch (const Json::exception& error) {
    return absl::InvalidArgumentError(absl::StrCat(source_name, ": JSON error: ", error.what()));
  }
  SceneReader reader(base_dir);
  absl::StatusOr<Scene> scene = reader.read(root);
  if (!scene.ok()) return annotate(scene.status(), source_name);
  if (warnings != nullptr)
    for (const std::string& warning : reader.warnings())
      warnings->push_back(absl::StrCat(source_name, ": ", warning));
  return scene;
}

}  // namespace caustica
