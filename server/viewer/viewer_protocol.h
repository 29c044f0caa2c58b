// The viewer's WebSocket protocol (docs/viewer.md): the browser's JSON control messages, checked
// field by field so that a mistake comes back as a message that names it, and the binary frame
// messages the server pushes (a little-endian u32 header length, a JSON header, the image bytes).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.pb.h"

namespace caustica::server::viewer {

// Text messages larger than this are refused unread: control messages are a few hundred bytes.
inline constexpr size_t kMaxControlMessageBytes = 64 * 1024;

enum class RequestType {
  kHello,
  kList,
  kOpen,
  kMoveLight,
  kSetIntensity,
  kSetEmitter,
  kSetEnvironment,
  kOrbit,
  kZoom
};

// One control message from the browser. Only the fields of its type are set.
struct ViewerRequest {
  RequestType type = RequestType::kHello;
  std::optional<int64_t> id;  // echoed in the reply, so the page can match replies to requests
  std::string token;          // hello: visible ASCII only, so that it fits gRPC metadata
  std::string scene;          // open
  uint32_t passes = 0;        // open: the refinement target; 0: the server's default
  uint32_t strips = 0;        // open: JPEG strips per frame, up to 16; 0: the session's default
  uint32_t light = 0;         // move_light, set_intensity: index into the scene message's lights
  double u = 0, v = 0;        // move_light: where the light should appear, image coordinates
  double intensity = 0;       // set_intensity: the brightest channel, W/sr
  uint32_t emitter = 0;       // set_emitter: index into the scene message's emitters
  std::optional<bool> on;     // set_emitter: switch the emitter on or off
  std::optional<double> radiance;  // set_emitter: the brightest channel of its radiance
  std::optional<double> environment_intensity;  // set_environment
  std::optional<double> rotation;               // set_environment: degrees about +y
  double dx = 0, dy = 0;           // orbit: fractions of the image width and height
  double steps = 0;                // zoom: wheel steps, positive towards the scene
};

// INVALID_ARGUMENT saying what is wrong: not JSON, not an object, a missing or unknown "type",
// an unknown field, or a field of the wrong kind or range, a hello's token with a byte outside
// visible ASCII included. `text` is one text message.
absl::StatusOr<ViewerRequest> parse_request(std::string_view text);
// The integer "id" of a message parse_request refused, where it has one, so that the page can
// match the error to what it sent.
std::optional<int64_t> refused_request_id(std::string_view text);

// The lights of the open scene as a session knows them: GetScene's lists with the lights epoch
// they belong to and, for a scene without a point or spot light, the point light the viewer
// offers instead, which its first change appends to the scene's lights.
struct SceneLights {
  std::vector<v1::Light> lights;
  std::vector<v1::Emitter> emitters;
  std::optional<v1::Environment> environment;
  std::optional<v1::Light> viewer_light;
  uint64_t epoch = 0;
};

// Point and spot lights have a position to drag; directional lights do not.
bool is_draggable(const v1::Light& light);

// GetScene's lights; `viewer_light` is kept only when none of them can be dragged.
SceneLights scene_lights(const v1::SceneInfo& info, const v1::Light& viewer_light);

// The UpdateLights that `request` (move_light, set_intensity, set_emitter or set_environment)
// asks for, expecting `scene.epoch`: the complete light list with only the named light changed,
// or keep_lights with the one emitter or the environment's intensity and rotation.
// INVALID_ARGUMENT naming the field for an unknown light or emitter, a light that cannot be
// dragged or a scene without an environment. Moves keep the light's depth (see
// move_in_image_plane).
absl::StatusOr<v1::UpdateLightsRequest> light_update(const ViewerRequest& request,
                                                     const SceneLights& scene,
                                                     const v1::Camera& camera,
                                                     double pivot_distance);

// `scene` after `update` succeeded and produced lights epoch `epoch`.
void apply_light_update(SceneLights& scene, const v1::UpdateLightsRequest& update, uint64_t epoch);

// The lights as the scene and updated messages list them: {"index","name","type","intensity",
// "draggable","viewer_light"} plus, for point and spot lights, "position", "visible" and "u", "v";
// the offered viewer light comes last, with the index its first change gives it.
nlohmann::json lights_json(const SceneLights& scene, const v1::Camera& camera);
// {"index","material","radiance","brightness","on"} per emissive material.
nlohmann::json emitters_json(const SceneLights& scene);
// {"intensity","rotation"} of the environment, or null when the scene has none.
nlohmann::json environment_json(const SceneLights& scene);

// {"type":"error","code":"UNAUTHENTICATED","message":...}, with "id" when the request had one.
std::string error_message(const absl::Status& status, std::optional<int64_t> id = std::nullopt);

// The binary message of one whole frame: its header fields as JSON, then `data`.
std::string frame_message(const v1::Frame& header, std::string_view data);

// {"geometry":..,"lights":..,"camera":..,"settings":..}
nlohmann::json epochs_json(const v1::Epochs& epochs);
// A frame's or a rebuild's per-stage milliseconds (encode_ms is the part of resolve_ms that built
// the JPEG or PNG).
nlohmann::json timings_json(const v1::StageTimings& timings);

// "png", "jpeg", ... and the MIME type the browser decodes it as.
std::string encoding_name(v1::Encoding encoding);
std::string encoding_mime_type(v1::Encoding encoding);

// The encoding viewer frames use: JPEG where this build's API has it (smaller frames, faster to
// encode), else PNG. Looked up by name so that this compiles against either API.
v1::Encoding preferred_frame_encoding();

}  // namespace caustica::server::viewer
