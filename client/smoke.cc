// caustica smoke: an end-to-end check of a server in seconds. Uploads a small Cornell box, renders
// it, adds a point light and renders, moves the light (guarded by the expected lights epoch) and
// streams two passes in the smallest pieces the server sends. Every frame must have the requested
// size, some lit pixels and the lights epoch of the latest update; moving the light must change
// the image.
#include <chrono>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/commands.h"
#include "client/frame_stream.h"
#include "client/result_output.h"

#ifndef CAUSTICA_SCENES_DIR
#define CAUSTICA_SCENES_DIR "scenes"
#endif

namespace caustica::client {
namespace {

using Stub = v1::RenderService::Stub;

// Smaller than the server's smallest piece (docs/server.md), which it raises this to: every frame
// larger than that piece arrives in pieces and exercises reassembly.
constexpr uint32_t kSmokeChunkBytes = 4096;

struct SmokeRun {
  const SmokeOptions& options;
  Connection& connection;
  std::string scene_id;
  int frames_checked = 0;

  absl::Status check_frame(const v1::Frame& frame, uint64_t lights_epoch, std::string_view step) {
    const std::string where =
        absl::StrCat(absl::string_view(step.data(), step.size()), ": frame ", frame.frame_number());
    const uint32_t size = options.size;
    if (frame.width() != size || frame.height() != size) {
      return absl::InternalError(absl::StrFormat("%s is %dx%d, expected %dx%d", where,
                                                 frame.width(), frame.height(), size, size));
    }
    if (frame.data().size() != size_t{size} * size * 4) {
      return absl::InternalError(
          absl::StrCat(where, " holds ", frame.data().size(), " bytes, expected RGBA8"));
    }
    if (frame.epochs().lights() != lights_epoch) {
      return absl::InternalError(absl::StrCat(
          where, " shows lights epoch ", frame.epochs().lights(), ", expected ", lights_epoch));
    }
    size_t lit = 0;
    for (size_t i = 0; i < frame.data().size(); ++i) lit += i % 4 != 3 && frame.data()[i] != 0;
    if (lit == 0) return absl::InternalError(absl::StrCat(where, " is black"));
    ++frames_checked;
    return absl::OkStatus();
  }

  absl::StatusOr<v1::Frame> render(uint64_t lights_epoch, std::string_view step) {
    v1::RenderFrameRequest request;
    request.set_scene_id(scene_id);
    request.set_target_passes(1);
    request.mutable_format()->set_pixel_format(v1::RGBA8_SRGB);
    absl::StatusOr<v1::Frame> frame = connection.call(&Stub::RenderFrame, request);
    if (!frame.ok()) return frame.status();
    if (absl::Status s = check_frame(*frame, lights_epoch, step); !s.ok()) return s;
    return frame;
  }

  absl::StatusOr<v1::RebuildReport> set_light(const v1::Vec3& position,
                                              std::optional<uint64_t> expected_epoch) {
    v1::UpdateLightsRequest request;
    request.set_scene_id(scene_id);
    v1::Light* light = request.add_lights();
    light->set_name("smoke");
    light->set_type(v1::Light::POINT);
    *light->mutable_position() = position;
    // About the irradiance the box's ceiling light gives the floor, from a third of the way up.
    light->mutable_intensity()->set_x(50000);
    light->mutable_intensity()->set_y(50000);
    light->mutable_intensity()->set_z(50000);
    if (expected_epoch) request.set_expected_lights_epoch(*expected_epoch);
    return connection.call(&Stub::UpdateLights, request);
  }

  absl::Status stream(uint64_t lights_epoch) {
    v1::StreamFramesRequest request;
    request.set_scene_id(scene_id);
    request.set_target_passes(2);
    request.set_passes_per_frame(1);
    request.mutable_format()->set_pixel_format(v1::RGBA8_SRGB);
    request.set_max_chunk_bytes(kSmokeChunkBytes);
    std::unique_ptr<grpc::ClientContext> context = connection.new_context();
    auto reader = connection.stub().StreamFrames(context.get(), request);
    int frames = 0;
    absl::Status status = receive_frames(*context, *reader, [&](v1::Frame& frame) {
      ++frames;
      return check_frame(frame, lights_epoch, "stream");
    });
    if (!status.ok()) return status;
    if (frames == 0) return absl::InternalError("stream: no frame arrived");
    return absl::OkStatus();
  }
};

v1::Vec3 vec3(float x, float y, float z) {
  v1::Vec3 v;
  v.set_x(x);
  v.set_y(y);
  v.set_z(z);
  return v;
}

absl::StatusOr<std::string> run_smoke_steps(const GlobalOptions& global,
                                            const SmokeOptions& options) {
  const std::filesystem::path scene_file =
      options.scene.empty() ? std::filesystem::path(CAUSTICA_SCENES_DIR) / "cornell-box/scene.json"
                            : options.scene;
  absl::StatusOr<std::unique_ptr<Connection>> connection = Connection::open(global.connect);
  if (!connection.ok()) return connection.status();
  SceneOverrides overrides;
  overrides.width = overrides.height = options.size;
  overrides.photons = options.photons;
  absl::StatusOr<std::unique_ptr<SceneSource>> source = SceneSource::open(
      **connection, scene_file.string(), overrides, /*keep=*/false, global.progress);
  if (!source.ok()) return source.status();
  const v1::SceneInfo& info = *(*source)->uploaded();
  SmokeRun run{options, **connection, (*source)->id()};

  const uint64_t epoch0 = info.epochs().lights();
  if (absl::StatusOr<v1::Frame> f = run.render(epoch0, "upload"); !f.ok()) return f.status();

  absl::StatusOr<v1::RebuildReport> added = run.set_light(vec3(278, 180, 280), std::nullopt);
  if (!added.ok()) return added.status();
  const uint64_t epoch1 = added->epochs().lights();
  if (epoch1 <= epoch0) {
    return absl::InternalError(absl::StrCat("adding a light left the lights epoch at ", epoch1));
  }
  absl::StatusOr<v1::Frame> before = run.render(epoch1, "light added");
  if (!before.ok()) return before.status();

  absl::StatusOr<v1::RebuildReport> moved = run.set_light(vec3(150, 400, 150), epoch1);
  if (!moved.ok()) return moved.status();
  const uint64_t epoch2 = moved->epochs().lights();
  absl::StatusOr<v1::Frame> after = run.render(epoch2, "light moved");
  if (!after.ok()) return after.status();
  if (after->data() == before->data()) {
    return absl::InternalError("moving the light did not change the image");
  }
  if (absl::Status s = run.stream(epoch2); !s.ok()) return s;

  absl::StatusOr<v1::Stats> stats = run.connection.call(&Stub::GetStats, v1::GetStatsRequest());
  if (!stats.ok()) return stats.status();
  return absl::StrFormat(
      "%s %dx%d (%d triangles) on %s (%s): upload %.0f ms, lights epochs %d -> %d -> %d "
      "(photon trace %.0f ms), %d frames checked",
      info.name(), options.size, options.size, info.triangles(),
      (*connection)->embedded() ? "an embedded server" : (*connection)->address(),
      stats->device().kind(), info.upload_ms(), epoch0, epoch1, epoch2,
      moved->timings().photon_trace_ms(), run.frames_checked);
}

}  // namespace

int run_smoke(const GlobalOptions& global, const SmokeOptions& options, std::ostream& out) {
  const auto t0 = std::chrono::steady_clock::now();
  const absl::StatusOr<std::string> summary = run_smoke_steps(global, options);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (global.json) {
    nlohmann::json json = {{"ok", summary.ok()}, {"seconds", seconds}};
    json[summary.ok() ? "summary" : "error"] =
        summary.ok() ? *summary : error_line("smoke", summary.status());
    print_json(out, json);
  } else if (summary.ok()) {
    out << absl::StrFormat("smoke: ok: %s, %.1f s\n", *summary, seconds);
  } else {
    out << absl::StrFormat("smoke: FAILED after %.1f s: %s\n", seconds,
                           error_line("smoke", summary.status()));
  }
  return summary.ok() ? 0 : 1;
}

}  // namespace caustica::client
