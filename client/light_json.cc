// Lights files and animation scripts (see light_json.h).
#include "client/light_json.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "absl/strings/str_cat.h"
#include "proto/wire/scene_wire.h"
#include "renderer/scene/json_fields.h"
#include "renderer/scene/scene_json.h"

namespace caustica::client {
namespace {

using Json = nlohmann::json;

constexpr int64_t kMaxPasses = 100000;  // the scene format's limit on settings.passes

absl::string_view as_absl(std::string_view s) { return {s.data(), s.size()}; }

absl::Status invalid(std::string_view source, std::string_view field, std::string_view problem) {
  return absl::InvalidArgumentError(
      absl::StrCat(as_absl(source), ": ", as_absl(field), ": ", as_absl(problem)));
}

absl::StatusOr<Json> parse_json(std::string_view text, std::string_view source) {
  try {
    return Json::parse(text, /*cb=*/nullptr, /*allow_exceptions=*/true, /*ignore_comments=*/true);
  } catch (const Json::exception&) {
    // The scene loader parses with the same options and reports the error as line:column; it
    // fails on this text at the same place.
    absl::Status status = scene_from_json(as_absl(text), {}, as_absl(source)).status();
    if (status.ok())
      status = absl::InvalidArgumentError(absl::StrCat(as_absl(source), ": bad JSON"));
    return status;
  }
}

// The scene loader's reading of `lights` (a JSON array), wrapped in the smallest scene it
// accepts: the loader's light reader is not exposed on its own.
absl::StatusOr<std::vector<v1::Light>> read_lights(const Json& lights, std::string_view context) {
  const Json wrapper = {
      {"camera",
       {{"position", {0, 0, 1}}, {"look_at", {0, 0, 0}}, {"fov", 45}, {"width", 1}, {"height", 1}}},
      {"lights", lights}};
  absl::StatusOr<Scene> scene = scene_from_json(wrapper.dump(), {}, as_absl(context));
  if (!scene.ok()) return scene.status();
  std::vector<v1::Light> out;
  out.reserve(scene->lights.size());
  for (const Light& light : scene->lights) out.push_back(wire::encode_light(light));
  return out;
}

// Fails on the first key of `object` not in `known`, listing those that are.
absl::Status check_keys(const Json& object, std::initializer_list<std::string_view> known,
                        std::string_view source, std::string_view path) {
  for (const auto& [key, value] : object.items()) {
    bool found = false;
    for (std::string_view k : known) found = found || key == k;
    if (!found) {
      std::string expected;
      for (std::string_view k : known) {
        absl::StrAppend(&expected, expected.empty() ? "" : ", ", as_absl(k));
      }
      return invalid(source, path.empty() ? key : absl::StrCat(as_absl(path), ".", key),
                     absl::StrCat("unknown key (expected ", expected, ")"));
    }
  }
  return absl::OkStatus();
}

// A keyframe's camera, read by the scene loader as a scene file's camera without its size (the
// animation keeps the scene's): position, look_at, up and fov. Sent with width and height 0.
absl::StatusOr<v1::Camera> read_camera(const Json& camera, std::string_view source,
                                       const std::string& path) {
  if (!camera.is_object()) {
    return invalid(source, path, absl::StrCat("expected an object, got ", camera.dump()));
  }
  if (absl::Status s = check_keys(camera, {"position", "look_at", "up", "fov"}, source, path);
      !s.ok()) {
    return s;
  }
  Json sized = camera;
  sized["width"] = 1;
  sized["height"] = 1;
  // Its errors read "s.json: keyframes[3]: camera.fov: ...", as a light's do.
  const std::string keyframe = path.substr(0, path.rfind('.'));
  absl::StatusOr<Scene> scene = scene_from_json(Json{{"camera", sized}}.dump(), {},
                                                absl::StrCat(as_absl(source), ": ", keyframe));
  if (!scene.ok()) return scene.status();
  v1::Camera out = wire::encode_camera(scene->camera);
  out.clear_width();
  out.clear_height();
  return out;
}

// A keyframe's pass count: an integer in [0, kMaxPasses], whole floats allowed as in scene files.
absl::StatusOr<uint32_t> read_passes(const Json& value, std::string_view source,
                                     const std::string& field) {
  const bool whole = value.is_number() && std::isfinite(value.get<double>()) &&
                     value.get<double>() == std::floor(value.get<double>());
  if (!whole || value.get<double>() < 0 || value.get<double>() > kMaxPasses) {
    return invalid(
        source, field,
        absl::StrCat("expected an integer from 0 to ", kMaxPasses, ", got ", value.dump()));
  }
  return static_cast<uint32_t>(value.get<double>());
}

// A JsonObject's errors ("keyframes[3].meshes[0].mesh: ...") after the source's name.
absl::Status sourced(std::string_view source, const absl::Status& status) {
  if (status.ok()) return status;
  return absl::Status(status.code(), absl::StrCat(as_absl(source), ": ", status.message()));
}

// A keyframe's "emitters": [{"material": name, "radiance": [r, g, b], "off": bool}, ...].
absl::Status read_emitters(const Json& emitters, const std::string& path, v1::Keyframe* out) {
  SCENE_RETURN_IF_ERROR(json_expect_array(emitters, path));
  for (size_t i = 0; i < emitters.size(); ++i) {
    SCENE_ASSIGN_OR_RETURN(JsonObject object, JsonObject::open(emitters[i], element_path(path, i)));
    v1::Emitter& emitter = *out->add_emitters();
    std::string material;
    SCENE_RETURN_IF_ERROR(object.read("material", Presence::kRequired, &material));
    emitter.set_material(material);
    if (object.has("radiance")) {
      Vec3f radiance;
      SCENE_RETURN_IF_ERROR(object.read("radiance", Presence::kRequired, &radiance));
      *emitter.mutable_radiance() = wire::encode_vec3(radiance);
    }
    if (object.has("off")) {
      bool off = false;
      SCENE_RETURN_IF_ERROR(object.read("off", Presence::kRequired, &off));
      emitter.set_off(off);
    }
    SCENE_RETURN_IF_ERROR(object.finish());
  }
  return absl::OkStatus();
}

// A keyframe's "meshes": [{"mesh": name, "transform": {...}}, ...], each transform a scene file's
// shape transform placing the mesh as uploaded.
absl::Status read_meshes(const Json& meshes, const std::string& path, v1::Keyframe* out) {
  SCENE_RETURN_IF_ERROR(json_expect_array(meshes, path));
  for (size_t i = 0; i < meshes.size(); ++i) {
    SCENE_ASSIGN_OR_RETURN(JsonObject object, JsonObject::open(meshes[i], element_path(path, i)));
    MeshChange change;
    SCENE_RETURN_IF_ERROR(object.read("mesh", Presence::kRequired, &change.mesh));
    SCENE_ASSIGN_OR_RETURN(const Json* transform, object.find("transform", Presence::kRequired));
    SCENE_ASSIGN_OR_RETURN(change.transform,
                           read_transform(*transform, object.field_path("transform")));
    SCENE_RETURN_IF_ERROR(object.finish());
    *out->add_meshes() = wire::encode_mesh_change(change);
  }
  return absl::OkStatus();
}

// A keyframe's "environment": {"intensity": x, "rotation": degrees}, each optional.
absl::Status read_environment(const Json& environment, const std::string& path, v1::Keyframe* out) {
  SCENE_ASSIGN_OR_RETURN(JsonObject object, JsonObject::open(environment, path));
  if (object.has("intensity")) {
    float intensity = 0;
    SCENE_RETURN_IF_ERROR(object.read("intensity", Presence::kRequired, &intensity));
    out->set_environment_intensity(intensity);
  }
  if (object.has("rotation")) {
    float rotation = 0;
    SCENE_RETURN_IF_ERROR(object.read("rotation", Presence::kRequired, &rotation));
    out->set_environment_rotation_deg(rotation);
  }
  return object.finish();
}

}  // namespace

absl::StatusOr<std::vector<v1::Light>> parse_lights_file(std::string_view text,
                                                         std::string_view source_name) {
  absl::StatusOr<Json> root = parse_json(text, source_name);
  if (!root.ok()) return root.status();
  if (root->is_array()) return read_lights(*root, source_name);
  if (!root->is_object() || !root->contains("lights")) {
    return absl::InvalidArgumentError(
        absl::StrCat(as_absl(source_name), ": expected {\"lights\": [...]} or an array of lights"));
  }
  if (absl::Status s = check_keys(*root, {"lights"}, source_name, ""); !s.ok()) return s;
  return read_lights((*root)["lights"], source_name);
}

absl::StatusOr<std::vector<v1::Keyframe>> parse_animation_script(std::string_view text,
                                                                 std::string_view source_name) {
  absl::StatusOr<Json> root = parse_json(text, source_name);
  if (!root.ok()) return root.status();
  if (!root->is_object()) {
    return absl::InvalidArgumentError(
        absl::StrCat(as_absl(source_name), ": expected {\"keyframes\": [...]}"));
  }
  if (absl::Status s = check_keys(*root, {"keyframes"}, source_name, ""); !s.ok()) return s;
  const auto keyframes = root->find("keyframes");
  if (keyframes == root->end() || !keyframes->is_array() || keyframes->empty()) {
    return invalid(source_name, "keyframes", "expected a non-empty array of keyframes");
  }
  std::vector<v1::Keyframe> out;
  for (size_t i = 0; i < keyframes->size(); ++i) {
    const Json& entry = (*keyframes)[i];
    const std::string path = absl::StrCat("keyframes[", i, "]");
    if (!entry.is_object()) {
      return invalid(source_name, path, absl::StrCat("expected an object, got ", entry.dump()));
    }
    if (absl::Status s =
            check_keys(entry, {"lights", "passes", "camera", "emitters", "environment", "meshes"},
                       source_name, path);
        !s.ok()) {
      return s;
    }
    v1::Keyframe keyframe;
    // Without "lights" the keyframe keeps those the one before left; an empty array keeps only
    // the scene's area lights.
    if (entry.contains("lights")) {
      absl::StatusOr<std::vector<v1::Light>> lights =
          read_lights(entry["lights"], absl::StrCat(as_absl(source_name), ": ", path));
      if (!lights.ok()) return lights.status();
      for (v1::Light& light : *lights) *keyframe.add_lights() = std::move(light);
    } else {
      keyframe.set_keep_lights(true);
    }
    if (entry.contains("emitters")) {
      if (absl::Status s = read_emitters(entry["emitters"], path + ".emitters", &keyframe); !s.ok())
        return sourced(source_name, s);
    }
    if (entry.contains("environment")) {
      if (absl::Status s = read_environment(entry["environment"], path + ".environment", &keyframe);
          !s.ok())
        return sourced(source_name, s);
    }
    if (entry.contains("meshes")) {
      if (absl::Status s = read_meshes(entry["meshes"], path + ".meshes", &keyframe); !s.ok())
        return sourced(source_name, s);
    }
    if (entry.contains("passes")) {
      absl::StatusOr<uint32_t> passes =
          read_passes(entry["passes"], source_name, absl::StrCat(path, ".passes"));
      if (!passes.ok()) return passes.status();
      keyframe.set_passes(*passes);
    }
    if (entry.contains("camera")) {
      absl::StatusOr<v1::Camera> camera =
          read_camera(entry["camera"], source_name, absl::StrCat(path, ".camera"));
      if (!camera.ok()) return camera.status();
      *keyframe.mutable_camera() = *std::move(camera);
    }
    out.push_back(std::move(keyframe));
  }
  return out;
}

}  // namespace caustica::client
