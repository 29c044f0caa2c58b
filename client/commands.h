// The commands of the `caustica` CLI as library functions: main.cc parses flags into these
// option structs and calls them; tests call them directly. Each returns the status of the whole
// command; results go to `out` (text, or one JSON object with --json), progress to stderr.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/connection.h"
#include "client/scene_source.h"
#include "renderer/accel/structure_kind.h"

namespace caustica::client {

struct GlobalOptions {
  ConnectOptions connect;
  bool json = false;      // one JSON object per command on stdout
  bool progress = false;  // progress bars on stderr (main sets it when stderr is a terminal)
};

// scene upload FILE [--name N] [--structure S]: prints the new scene's id.
struct SceneUploadOptions {
  std::filesystem::path file;
  std::string name;                        // empty: derived from the file name
  std::optional<StructureKind> structure;  // replaces the file's settings.structure
  std::vector<std::string> structure_options;  // NAME=VALUE over the file's settings.build
};
absl::Status run_scene_upload(const GlobalOptions& global, const SceneUploadOptions& options,
                              std::ostream& out);
absl::Status run_scene_list(const GlobalOptions& global, std::ostream& out);
absl::Status run_scene_info(const GlobalOptions& global, const std::string& scene_id,
                            std::ostream& out);
absl::Status run_scene_delete(const GlobalOptions& global, const std::string& scene_id,
                              std::ostream& out);

// A rebuild report as text, or one JSON object with --json.
void print_rebuild(const GlobalOptions& global, const v1::RebuildReport& report, std::ostream& out);

// Sends an update (UpdateLights, UpdateGeometry, ...) to the server holding scene `scene` and
// prints the rebuild report it returns.
template <typename Request>
absl::Status send_update(const GlobalOptions& global, const std::string& scene,
                         grpc::Status (v1::RenderService::Stub::*method)(grpc::ClientContext*,
                                                                         const Request&,
                                                                         v1::RebuildReport*),
                         const Request& request, std::ostream& out) {
  absl::StatusOr<std::unique_ptr<Connection>> connection = Connection::open(global.connect);
  if (!connection.ok()) return connection.status();
  if (absl::Status pinned = (*connection)->pin_to_scene(scene); !pinned.ok()) return pinned;
  absl::StatusOr<v1::RebuildReport> report = (*connection)->call(method, request);
  if (!report.ok()) return report.status();
  print_rebuild(global, *report, out);
  return absl::OkStatus();
}

// The value "X,Y,Z" (or one value V meaning V,V,V when `allow_scalar`) of the flag `flag`.
absl::StatusOr<v1::Vec3> parse_vec3_flag(std::string_view flag, const std::string& text,
                                         bool allow_scalar);

// light set SCENE: the complete new light list, from flags (one light) or a lights file.
struct LightSetOptions {
  std::string scene;
  std::filesystem::path file;            // lights file (light_json.h)
  bool none = false;                     // no lights: only the scene's emissive triangles remain
  std::string point, spot, directional;  // "X,Y,Z": position, or a directional light's direction
  std::string direction;                 // spot axis "X,Y,Z"
  std::string intensity;                 // "R,G,B" or one value (irradiance for directional lights)
  std::optional<float> inner_angle, outer_angle;  // spot half-angles, degrees
  std::string name;
  std::optional<uint64_t> expect_epoch;  // apply only if the lights epoch still equals this
};
// light emit SCENE MATERIAL: changes an emissive material's emission (its triangles are area
// lights), keeping the other lights.
struct LightEmitOptions {
  std::string scene;
  std::string material;
  std::string radiance;  // "R,G,B" or one value; empty: unchanged
  bool on = false, off = false;
  std::optional<uint64_t> expect_epoch;
};
absl::StatusOr<v1::UpdateLightsRequest> emit_request(const LightEmitOptions& options);
absl::Status run_light_emit(const GlobalOptions& global, const LightEmitOptions& options,
                            std::ostream& out);
// light environment SCENE: changes the environment's intensity or rotation, keeping the other
// lights.
struct LightEnvironmentOptions {
  std::string scene;
  std::optional<float> intensity;
  std::optional<float> rotation;  // degrees about the up axis
  std::optional<uint64_t> expect_epoch;
};
absl::StatusOr<v1::UpdateLightsRequest> environment_request(const LightEnvironmentOptions& options);
absl::Status run_light_environment(const GlobalOptions& global,
                                   const LightEnvironmentOptions& options, std::ostream& out);

// mesh move SCENE MESH: where a mesh stands (UpdateGeometry), scaled, then rotated about x, y
// and z, then translated, as a scene file's transform; it places the mesh as uploaded.
struct MeshMoveOptions {
  std::string scene;
  std::string mesh;                      // as `scene info` lists it
  std::string translate, rotate, scale;  // "X,Y,Z" (degrees for rotate; one value for scale)
  std::optional<uint64_t> expect_epoch;  // apply only if the geometry epoch still equals this
};
absl::StatusOr<v1::UpdateGeometryRequest> mesh_move_request(const MeshMoveOptions& options);
absl::Status run_mesh_move(const GlobalOptions& global, const MeshMoveOptions& options,
                           std::ostream& out);

// mesh reshape SCENE MESH --from FILE: the mesh's vertices (and normals) replaced by those of a
// model file's one mesh, streamed in chunks (StreamGeometry); prints the rebuild report.
struct MeshReshapeOptions {
  std::string scene;
  std::string mesh;
  std::filesystem::path file;
  std::optional<uint64_t> expect_epoch;
};
absl::Status run_mesh_reshape(const GlobalOptions& global, const MeshReshapeOptions& options,
                              std::ostream& out);

// view SCENE: the scene (a file is uploaded) in the server's browser viewer; prints the URL and
// opens it on a desktop. With the embedded server, serves until SIGINT or SIGTERM.
struct ViewOptions {
  std::string scene;
  SceneOverrides overrides;
  bool keep = false;  // keep a file uploaded to the embedded server after the command
  bool open = true;   // start the desktop's browser (xdg-open) when there is a display
};
absl::Status run_view(const GlobalOptions& global, const ViewOptions& options, std::ostream& out);
// The page's address: http://HOST:PORT/?scene=ID, with &token=TOKEN when one is given, both
// percent-encoded.
std::string viewer_url(const std::string& host, uint32_t port, const std::string& scene_id,
                       const std::string& token);

// The light list `options` describe (flags, file or none), before any server is involved.
absl::StatusOr<std::vector<v1::Light>> lights_from_options(const LightSetOptions& options);
absl::Status run_light_set(const GlobalOptions& global, const LightSetOptions& options,
                           std::ostream& out);

// What render, stream and animate share: the scene and how its frames come out.
struct FrameJobOptions {
  std::string scene;  // id, or a scene file uploaded for the command
  SceneOverrides overrides;
  bool keep = false;  // keep a scene uploaded from a file on the server
  float exposure_stops = 0;
};

// render SCENE -o OUT: one image after `passes` passes.
struct RenderOptions {
  FrameJobOptions job;
  std::filesystem::path output;
  std::optional<uint32_t> passes;  // default: the scene file's settings.passes, else 1
};
absl::Status run_render(const GlobalOptions& global, const RenderOptions& options,
                        std::ostream& out);

// stream SCENE -o DIR: DIR/frame_0000.<format>, ... as the image refines.
struct StreamOptions {
  FrameJobOptions job;
  std::filesystem::path directory;
  std::string format = "png";  // file extension of the frames
  uint32_t passes = 8;
  uint32_t every = 1;  // passes between frames
  std::string tev;     // HOST:PORT of a tev viewer that shows each frame; empty: none
};
absl::Status run_stream(const GlobalOptions& global, const StreamOptions& options,
                        std::ostream& out);

// animate SCENE --script LIGHTS.json -o DIR [--video OUT.mp4]: one image per keyframe.
struct AnimateOptions {
  FrameJobOptions job;
  std::filesystem::path directory;
  std::string format = "png";
  std::filesystem::path script;  // empty: none
  // The glTF animation of the scene's models to play (a name, or a number as "0"); empty: none.
  std::string gltf_animation;
  std::filesystem::path video;  // empty: no video
  int fps = 12;  // the video's frame rate, and the rate a glTF animation is sampled at
  // --servers: replicas ("host:port") that share the keyframes, instead of the one --server. The
  // scene (a file) goes to each; a replica down at the start, or lost on the way, is probed until
  // it answers and then takes keyframes again.
  std::vector<std::string> servers;
};
absl::Status run_animate(const GlobalOptions& global, const AnimateOptions& options,
                         std::ostream& out);

// stats: server, device, memory, latencies and scenes.
absl::Status run_stats(const GlobalOptions& global, const std::string& scene_id, std::ostream& out);

// smoke: upload a small Cornell box, change its lights twice, render after each change and check
// every frame. Prints one summary line; returns the exit code (0 passed, 1 failed).
struct SmokeOptions {
  std::filesystem::path scene;  // empty: the bundled scenes/cornell-box/scene.json
  uint32_t size = 64;           // image width and height
  uint32_t photons = 4000;      // per pass
};
int run_smoke(const GlobalOptions& global, const SmokeOptions& options, std::ostream& out);

}  // namespace caustica::client
