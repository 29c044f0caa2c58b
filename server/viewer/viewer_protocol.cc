#include "server/viewer/viewer_protocol.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <initializer_list>
#include <nlohmann/json.hpp>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "proto/wire/bearer_token.h"
#include "server/viewer/viewer_geometry.h"

namespace caustica::server::viewer {
namespace {

using nlohmann::json;

// Names tried in order; the first one this build's Encoding enum has wins.
constexpr std::initializer_list<const char*> kFrameEncodingPreference = {"JPEG", "PNG"};

struct FieldRules {
  const char* type;
  RequestType request;
  std::initializer_list<const char*> fields;  // besides "type" and "id"
};

constexpr FieldRules kRules[] = {
    {"hello", RequestType::kHello, {"token"}},
    {"list", RequestType::kList, {}},
    {"open", RequestType::kOpen, {"scene", "passes", "strips"}},
    {"move_light", RequestType::kMoveLight, {"light", "u", "v"}},
    {"set_intensity", RequestType::kSetIntensity, {"light", "intensity"}},
    {"set_emitter", RequestType::kSetEmitter, {"emitter", "on", "radiance"}},
    {"set_environment", RequestType::kSetEnvironment, {"intensity", "rotation"}},
    {"orbit", RequestType::kOrbit, {"dx", "dy"}},
    {"zoom", RequestType::kZoom, {"steps"}},
};

absl::Status invalid(std::string_view type, std::string_view field, std::string_view what) {
  return absl::InvalidArgumentError(
      absl::StrCat(std::string(type), ".", std::string(field), ": ", std::string(what)));
}

absl::StatusOr<double> number_field(const json& message, std::string_view type, const char* name,
                                    double low, double high) {
  if (!message.contains(name)) return invalid(type, name, "is missing");
  const json& value = message.at(name);
  if (!value.is_number()) return invalid(type, name, "must be a number");
  const double number = value.get<double>();
  if (!std::isfinite(number) || number < low || number > high) {
    return invalid(type, name, absl::StrCat("must be in [", low, ", ", high, "]"));
  }
  return number;
}

absl::StatusOr<uint32_t> index_field(const json& message, std::string_view type, const char* name,
                                     uint32_t high) {
  if (!message.contains(name)) return invalid(type, name, "is missing");
  const json& value = message.at(name);
  if (!value.is_number_integer() || value.get<int64_t>() < 0 || value.get<int64_t>() > high) {
    return invalid(type, name, absl::StrCat("must be an integer in [0, ", high, "]"));
  }
  return static_cast<uint32_t>(value.get<int64_t>());
}

absl::StatusOr<std::string> string_field(const json& message, std::string_view type,
                                         const char* name, bool required) {
  if (!message.contains(name)) {
    if (required) return invalid(type, name, "is missing");
    return std::string();
  }
  const json& value = message.at(name);
  if (!value.is_string()) return invalid(type, name, "must be a string");
  return value.get<std::string>();
}

json vec_json(const v1::Vec3& v) { return json::array({v.x(), v.y(), v.z()}); }

double brightest_channel(const v1::Vec3& v) { return std::max({v.x(), v.y(), v.z()}); }

// `colour` scaled so that its brightest channel is `brightest`; grey when it was black.
v1::Vec3 with_brightest(const v1::Vec3& colour, double brightest) {
  const double current = brightest_channel(colour);
  v1::Vec3 out;
  if (current > 0) {
    const double scale = brightest / current;
    out.set_x(static_cast<float>(colour.x() * scale));
    out.set_y(static_cast<float>(colour.y() * scale));
    out.set_z(static_cast<float>(colour.z() * scale));
  } else {
    const auto value = static_cast<float>(brightest);
    out.set_x(value);
    out.set_y(value);
    out.set_z(value);
  }
  return out;
}

const char* light_type_name(v1::Light::Type type) {
  switch (type) {
    case v1::Light::POINT:
      return "point";
    case v1::Light::SPOT:
      return "spot";
    case v1::Light::DIRECTIONAL:
      return "directional";
    default:
      return "unknown";
  }
}

json light_json(const v1::Light& light, size_t index, bool viewer_light, const v1::Camera& camera) {
  const bool draggable = is_draggable(light);
  json entry = {{"index", index},
                {"name", light.name()},
                {"type", light_type_name(light.type())},
                {"intensity", brightest_channel(light.intensity())},
                {"draggable", draggable},
                {"viewer_light", viewer_light}};
  if (draggable) {
    entry["position"] = vec_json(light.position());
    const std::optional<ImagePoint> seen = project(camera, to_vec3d(light.position()));
    entry["visible"] = seen.has_value();
    if (seen) {
      entry["u"] = seen->u;
      entry["v"] = seen->v;
    }
  } else {
    entry["direction"] = vec_json(light.direction());
  }
  return entry;
}

#define ASSIGN_OR_RETURN_FIELD(target, expression) \
  do {                                             \
    auto value_or = (expression);                  \
    if (!value_or.ok()) return value_or.status();  \
    target = *value_or;                            \
  } while (false)

}  // namespace

nlohmann::json timings_json(const v1::StageTimings& t) {
  return {{"structure_build_ms", t.structure_build_ms()},
          {"photon_trace_ms", t.photon_trace_ms()},
          {"photon_map_build_ms", t.photon_map_build_ms()},
          {"render_ms", t.render_ms()},
          {"resolve_ms", t.resolve_ms()},
          {"encode_ms", t.encode_ms()},
          {"queue_ms", t.queue_ms()}};
}

nlohmann::json epochs_json(const v1::Epochs& epochs) {
  return {{"geometry", epochs.geometry()},
          {"lights", epochs.lights()},
          {"camera", epochs.camera()},
          {"settings", epochs.settings()}};
}

std::optional<int64_t> refused_request_id(std::string_view text) {
  if (text.size() > kMaxControlMessageBytes) return std::nullopt;
  const json message = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!message.is_object() || !message.contains("id") || !message.at("id").is_number_integer()) {
    return std::nullopt;
  }
  return message.at("id").get<int64_t>();
}

absl::StatusOr<ViewerRequest> parse_request(std::string_view text) {
  if (text.size() > kMaxControlMessageBytes) {
    return absl::InvalidArgumentError(absl::StrCat("message of ", text.size(),
                                                   " bytes: control messages are at most ",
                                                   kMaxControlMessageBytes));
  }
  const json message = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (message.is_discarded()) {
    return absl::InvalidArgumentError("not JSON: control messages are JSON objects");
  }
  if (!message.is_object()) {
    return absl::InvalidArgumentError("not a JSON object: control messages are JSON objects");
  }
  if (!message.contains("type") || !message.at("type").is_string()) {
    return absl::InvalidArgumentError("type: is missing (a string such as \"open\")");
  }
  const std::string type = message.at("type").get<std::string>();
  const FieldRules* rules = nullptr;
  std::vector<std::string> known_types;
  for (const FieldRules& candidate : kRules) {
    known_types.push_back(candidate.type);
    if (type == candidate.type) rules = &candidate;
  }
  if (rules == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat("type: unknown message type '", type,
                                                   "' (expected ", absl::StrJoin(known_types, ", "),
                                                   ")"));
  }
  for (const auto& [name, value] : message.items()) {
    if (name == "type" || name == "id") continue;
    bool known = false;
    for (const char* field : rules->fields) known = known || name == field;
    if (!known) {
      std::vector<std::string> allowed = {"type", "id"};
      allowed.insert(allowed.end(), rules->fields.begin(), rules->fields.end());
      return invalid(
          type, name,
          absl::StrCat("unknown field (", type, " takes ", absl::StrJoin(allowed, ", "), ")"));
    }
  }
  ViewerRequest request;
  request.type = rules->request;
  if (message.contains("id")) {
    if (!message.at("id").is_number_integer()) return invalid(type, "id", "must be an integer");
    request.id = message.at("id").get<int64_t>();
  }
  switch (request.type) {
    case RequestType::kHello:
      ASSIGN_OR_RETURN_FIELD(request.token, string_field(message, type, "token", false));
      // The session sends the token as gRPC metadata, which cannot carry every byte.
      if (absl::Status token = wire::check_bearer_token(request.token, "hello.token");
          !token.ok()) {
        return token;
      }
      break;
    case RequestType::kList:
      break;
    case RequestType::kOpen:
      ASSIGN_OR_RETURN_FIELD(request.scene, string_field(message, type, "scene", true));
      if (request.scene.empty()) return invalid(type, "scene", "is empty");
      if (message.contains("passes")) {
        ASSIGN_OR_RETURN_FIELD(request.passes, index_field(message, type, "passes", 1u << 16));
      }
      if (message.contains("strips")) {
        ASSIGN_OR_RETURN_FIELD(request.strips, index_field(message, type, "strips", 16));
      }
      break;
    case RequestType::kMoveLight:
      ASSIGN_OR_RETURN_FIELD(request.light, index_field(message, type, "light", 1u << 16));
      // A drag may leave the picture; far outside it the move would be meaningless.
      ASSIGN_OR_RETURN_FIELD(request.u, number_field(message, type, "u", -10, 10));
      ASSIGN_OR_RETURN_FIELD(request.v, number_field(message, type, "v", -10, 10));
      break;
    case RequestType::kSetIntensity:
      ASSIGN_OR_RETURN_FIELD(request.light, index_field(message, type, "light", 1u << 16));
      ASSIGN_OR_RETURN_FIELD(request.intensity, number_field(message, type, "intensity", 0, 1e15));
      break;
    case RequestType::kSetEmitter:
      ASSIGN_OR_RETURN_FIELD(request.emitter, index_field(message, type, "emitter", 1u << 16));
      if (message.contains("on")) {
        if (!message.at("on").is_boolean()) return invalid(type, "on", "must be true or false");
        request.on = message.at("on").get<bool>();
      }
      if (message.contains("radiance")) {
        ASSIGN_OR_RETURN_FIELD(request.radiance, number_field(message, type, "radiance", 0, 1e15));
      }
      if (!request.on && !request.radiance) {
        return absl::InvalidArgumentError(
            "set_emitter: says nothing to change (give \"on\", \"radiance\" or both)");
      }
      break;
    case RequestType::kSetEnvironment:
      if (message.contains("intensity")) {
        ASSIGN_OR_RETURN_FIELD(request.environment_intensity,
                               number_field(message, type, "intensity", 0, 1e15));
      }
      if (message.contains("rotation")) {
        ASSIGN_OR_RETURN_FIELD(request.rotation,
                               number_field(message, type, "rotation", -3600, 3600));
      }
      if (!request.environment_intensity && !request.rotation) {
        return absl::InvalidArgumentError(
            "set_environment: says nothing to change (give \"intensity\", \"rotation\" or "
            "both)");
      }
      break;
    case RequestType::kOrbit:
      ASSIGN_OR_RETURN_FIELD(request.dx, number_field(message, type, "dx", -10, 10));
      ASSIGN_OR_RETURN_FIELD(request.dy, number_field(message, type, "dy", -10, 10));
      break;
    case RequestType::kZoom:
      ASSIGN_OR_RETURN_FIELD(request.steps, number_field(message, type, "steps", -100, 100));
      break;
  }
  return request;
}

bool is_draggable(const v1::Light& light) {
  return light.type() == v1::Light::POINT || light.type() == v1::Light::SPOT;
}

SceneLights scene_lights(const v1::SceneInfo& info, const v1::Light& viewer_light) {
  SceneLights scene;
  scene.lights.assign(info.light_list().begin(), info.light_list().end());
  scene.emitters.assign(info.emitters().begin(), info.emitters().end());
  if (info.has_environment()) scene.environment = info.environment();
  scene.epoch = info.epochs().lights();
  if (std::none_of(scene.lights.begin(), scene.lights.end(), is_draggable)) {
    scene.viewer_light = viewer_light;
  }
  return scene;
}

absl::StatusOr<v1::UpdateLightsRequest> light_update(const ViewerRequest& request,
                                                     const SceneLights& scene,
                                                     const v1::Camera& camera,
                                                     double pivot_distance) {
  v1::UpdateLightsRequest update;
  // Every change is made against the state the page shows, so another client's change in
  // between is refused rather than overwritten.
  update.set_expected_lights_epoch(scene.epoch);
  if (request.type == RequestType::kSetEmitter) {
    if (request.emitter >= scene.emitters.size()) {
      return invalid("set_emitter", "emitter",
                     absl::StrCat(request.emitter, " is not an emitter (the scene has ",
                                  scene.emitters.size(), " emissive material(s))"));
    }
    const v1::Emitter& current = scene.emitters[request.emitter];
    update.set_keep_lights(true);
    v1::Emitter& change = *update.add_emitters();
    change.set_material(current.material());
    if (request.radiance)
      *change.mutable_radiance() = with_brightest(current.radiance(), *request.radiance);
    if (request.on) change.set_off(!*request.on);
    return update;
  }
  if (request.type == RequestType::kSetEnvironment) {
    if (!scene.environment) {
      return absl::FailedPreconditionError(
          "set_environment: the scene has no environment to change");
    }
    update.set_keep_lights(true);
    if (request.environment_intensity)
      update.set_environment_intensity(float(*request.environment_intensity));
    if (request.rotation) update.set_environment_rotation_deg(float(*request.rotation));
    return update;
  }
  const char* type = request.type == RequestType::kMoveLight ? "move_light" : "set_intensity";
  if (request.type != RequestType::kMoveLight && request.type != RequestType::kSetIntensity) {
    return absl::InternalError("light_update: not a light change");
  }
  std::vector<v1::Light> lights = scene.lights;
  const size_t count = lights.size() + (scene.viewer_light ? 1 : 0);
  if (request.light >= count) {
    return invalid(
        type, "light",
        absl::StrCat(request.light, " is not a light (the scene message lists ", count, ")"));
  }
  // The offered viewer light joins the scene's lights with its first change.
  if (request.light == lights.size()) lights.push_back(*scene.viewer_light);
  v1::Light& light = lights[request.light];
  if (request.type == RequestType::kMoveLight) {
    if (!is_draggable(light)) {
      return invalid(type, "light",
                     absl::StrCat("light ", request.light, " ('", light.name(), "') is ",
                                  light_type_name(light.type()),
                                  ": only point and spot lights have a position to drag"));
    }
    *light.mutable_position() = to_proto(move_in_image_plane(camera, to_vec3d(light.position()),
                                                             request.u, request.v, pivot_distance));
  } else {
    // Keeps the light's colour: every channel scales by the same factor.
    *light.mutable_intensity() = with_brightest(light.intensity(), request.intensity);
  }
  for (const v1::Light& each : lights) *update.add_lights() = each;
  return update;
}

void apply_light_update(SceneLights& scene, const v1::UpdateLightsRequest& update, uint64_t epoch) {
  scene.epoch = epoch;
  if (!update.keep_lights()) {
    scene.lights.assign(update.lights().begin(), update.lights().end());
    if (std::any_of(scene.lights.begin(), scene.lights.end(), is_draggable)) {
      scene.viewer_light.reset();
    }
  }
  if (scene.environment) {
    if (update.has_environment_intensity())
      scene.environment->set_intensity(update.environment_intensity());
    if (update.has_environment_rotation_deg())
      scene.environment->set_rotation_deg(update.environment_rotation_deg());
  }
  for (const v1::Emitter& change : update.emitters()) {
    for (v1::Emitter& emitter : scene.emitters) {
      if (emitter.material() != change.material()) continue;
      if (change.has_radiance()) *emitter.mutable_radiance() = change.radiance();
      if (change.has_off()) emitter.set_off(change.off());
    }
  }
}

json lights_json(const SceneLights& scene, const v1::Camera& camera) {
  json lights = json::array();
  for (size_t i = 0; i < scene.lights.size(); ++i) {
    lights.push_back(light_json(scene.lights[i], i, false, camera));
  }
  if (scene.viewer_light) {
    lights.push_back(light_json(*scene.viewer_light, scene.lights.size(), true, camera));
  }
  return lights;
}

json emitters_json(const SceneLights& scene) {
  json emitters = json::array();
  for (size_t i = 0; i < scene.emitters.size(); ++i) {
    const v1::Emitter& emitter = scene.emitters[i];
    emitters.push_back({{"index", i},
                        {"material", emitter.material()},
                        {"radiance", vec_json(emitter.radiance())},
                        {"brightness", brightest_channel(emitter.radiance())},
                        {"on", !emitter.off()}});
  }
  return emitters;
}

json environment_json(const SceneLights& scene) {
  if (!scene.environment) return nullptr;
  return {{"intensity", scene.environment->intensity()},
          {"rotation", scene.environment->rotation_deg()}};
}

std::string error_message(const absl::Status& status, std::optional<int64_t> id) {
  json message = {{"type", "error"},
                  {"code", absl::StatusCodeToString(status.code())},
                  {"message", std::string(status.message())}};
  if (id) message["id"] = *id;
  return message.dump(-1, ' ', false, json::error_handler_t::replace);
}

std::string encoding_name(v1::Encoding encoding) {
  switch (encoding) {
    case v1::PNG:
      return "png";
    case v1::EXR:
      return "exr";
    case v1::RAW:
    case v1::ENCODING_UNSPECIFIED:
      return "raw";
    default:
      break;
  }
  std::string name = v1::Encoding_Name(encoding);
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return name;
}

std::string encoding_mime_type(v1::Encoding encoding) {
  const std::string name = encoding_name(encoding);
  if (name == "png") return "image/png";
  if (name == "jpeg" || name == "jpg") return "image/jpeg";
  if (name == "webp") return "image/webp";
  return "application/octet-stream";
}

v1::Encoding preferred_frame_encoding() {
  for (const char* name : kFrameEncodingPreference) {
    v1::Encoding encoding;
    if (v1::Encoding_Parse(name, &encoding)) return encoding;
  }
  return v1::PNG;
}

std::string frame_message(const v1::Frame& header, std::string_view data) {
  const v1::StageTimings& t = header.timings();
  json fields = {{"scene", header.scene_id()},
                 {"frame", header.frame_number()},
                 {"width", header.width()},
                 {"height", header.height()},
                 {"passes", header.passes()},
                 {"encoding", encoding_name(header.encoding())},
                 {"mime", encoding_mime_type(header.encoding())},
                 {"epochs", epochs_json(header.epochs())},
                 {"photons", header.photons_emitted()},
                 {"timings", timings_json(t)}};
  if (header.strip_bytes_size() > 0) {
    // The page decodes each strip on its own and draws it below the ones before.
    fields["strip_bytes"] =
        std::vector<uint32_t>(header.strip_bytes().begin(), header.strip_bytes().end());
    fields["strip_rows"] =
        std::vector<uint32_t>(header.strip_rows().begin(), header.strip_rows().end());
  }
  const std::string text = fields.dump(-1, ' ', false, json::error_handler_t::replace);
  std::string message;
  message.reserve(4 + text.size() + data.size());
  const auto length = static_cast<uint32_t>(text.size());
  for (int shift = 0; shift < 32; shift += 8) message.push_back(static_cast<char>(length >> shift));
  message += text;
  message += data;
  return message;
}

}  // namespace caustica::server::viewer
