#include "bench/serving.h"

#include <algorithm>
#include <chrono>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "bench/measure.h"
#include "bench/viewer_drag.h"
#include "client/connection.h"
#include "client/frame_stream.h"
#include "client/rpc_status.h"
#include "client/scene_upload.h"
#include "proto/wire/scene_wire.h"
#include "renderer/scene/load_scene.h"

namespace caustica {
namespace {

using Clock = std::chrono::steady_clock;

double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

absl::StatusOr<std::string> upload(client::Connection& connection, const Scene& scene,
                                   const std::string& name, v1::SceneInfo* info = nullptr) {
  grpc::ClientContext context;
  absl::StatusOr<v1::SceneInfo> uploaded =
      client::upload_scene(connection.stub(), context, scene, name);
  if (!uploaded.ok()) return uploaded.status();
  if (info != nullptr) *info = *uploaded;
  return uploaded->scene_id();
}

absl::Status delete_scene(client::Connection& connection, const std::string& id) {
  v1::DeleteSceneRequest request;
  request.set_scene_id(id);
  return connection.call(&v1::RenderService::Stub::DeleteScene, request).status();
}

// Streams `frames` copies of the current film; returns milliseconds from the call to the last
// whole frame, and checks every frame arrived whole and of the right size.
absl::StatusOr<double> stream_repeated(client::Connection& connection, const std::string& id,
                                       v1::PixelFormat format, uint32_t frames,
                                       size_t expected_bytes) {
  v1::StreamFramesRequest request;
  request.set_scene_id(id);
  request.set_target_passes(1);
  request.set_repeat_frames(frames);
  request.mutable_format()->set_pixel_format(format);
  request.set_max_chunk_bytes(4u << 20);
  grpc::ClientContext context;
  const Clock::time_point start = Clock::now();
  std::unique_ptr<grpc::ClientReader<v1::Frame>> reader =
      connection.stub().StreamFrames(&context, request);
  uint32_t received = 0;
  absl::Status status = client::receive_frames(context, *reader, [&](v1::Frame& frame) {
    if (frame.data().size() != expected_bytes) {
      return absl::DataLossError(
          absl::StrCat("frame of ", frame.data().size(), " bytes, expected ", expected_bytes));
    }
    ++received;
    return absl::OkStatus();
  });
  const double ms = ms_between(start, Clock::now());
  if (!status.ok()) return status;
  if (received != frames) {
    return absl::DataLossError(absl::StrCat(received, " frames of ", frames, " arrived"));
  }
  return ms;
}

absl::Status stream_benchmarks(const BenchOptions& o, client::Connection& connection,
                               Reporter& report) {
  // The bundled Cornell box at the benchmark's size with almost no photons: the one pass rendered
  // before streaming is cheap, and the stream itself only re-sends the film.
  absl::StatusOr<Scene> scene =
      load_scene(std::string(CAUSTICA_SCENES_DIR) + "/cornell-box/scene.json");
  if (!scene.ok()) return scene.status();
  scene->camera.width = o.width;
  scene->camera.height = o.height;
  scene->settings.photons_per_pass = 1000;
  absl::StatusOr<std::string> id = upload(connection, *scene, "stream benchmark");
  if (!id.ok()) return id.status();
  const std::string size = absl::StrFormat("cornell-box %dx%d", o.width, o.height);
  const uint32_t frames = 100;
  struct Format {
    const char* name;
    v1::PixelFormat format;
    size_t bytes_per_pixel;
  };
  for (const Format& f : {Format{"stream_rgba8", v1::RGBA8_SRGB, 4},
                          Format{"stream_rgba32f", v1::RGBA32F_LINEAR, 16}}) {
    if (!wanted(o, f.name)) continue;
    const size_t frame_bytes = size_t(o.width) * o.height * f.bytes_per_pixel;
    absl::Status failure;
    Measurement m = measure(o, [&] {
      absl::StatusOr<double> ms = stream_repeated(connection, *id, f.format, frames, frame_bytes);
      if (!ms.ok()) failure = ms.status();
    });
    if (!failure.ok()) return failure;
    const double frames_per_s = frames / (m.median * 1e-3);
    report.line(f.name, size + absl::StrFormat(" %d frames", frames), frames_per_s, "frames/s", &m,
                o.runs);
    report.line(absl::StrCat(f.name, "_bandwidth"), size, frames_per_s * frame_bytes / 1e6, "MB/s");
  }
  return delete_scene(connection, *id);
}

absl::Status upload_benchmark(const BenchOptions& o, client::Connection& connection,
                              const Scene& mesh_scene, const std::string& name, Reporter& report) {
  const double megabytes = wire::upload_bytes(mesh_scene) / 1e6;
  std::vector<double> transfer_ms, total_ms;
  for (int i = 0; i < o.warmup + o.runs; ++i) {
    v1::SceneInfo info;
    const Clock::time_point start = Clock::now();
    absl::StatusOr<std::string> id = upload(connection, mesh_scene, "upload benchmark", &info);
    const double ms = ms_between(start, Clock::now());
    if (!id.ok()) return id.status();
    if (absl::Status s = delete_scene(connection, *id); !s.ok()) return s;
    if (i < o.warmup) continue;
    total_ms.push_back(ms);
    // The server builds the triangle structure before it answers; that is not transport.
    transfer_ms.push_back(ms - info.last_rebuild().timings().structure_build_ms());
  }
  Measurement transfer = summarize(transfer_ms), total = summarize(total_ms);
  report.line("upload", name + absl::StrFormat(" %.1f MB", megabytes),
              megabytes / (transfer.median * 1e-3), "MB/s", &transfer, o.runs);
  report.line("upload_with_build", name, megabytes / (total.median * 1e-3), "MB/s", &total, o.runs);
  return absl::OkStatus();
}

// The scene's lights at step i of a light animation (moved_lights), in their wire form.
void add_moved_lights(const Scene& scene, int i,
                      google::protobuf::RepeatedPtrField<v1::Light>& lights) {
  for (const Light& light : moved_lights(scene, i)) *lights.Add() = wire::encode_light(light);
}

// An update to the lights of step i: moved_lights, and the environment turned_environment.
v1::UpdateLightsRequest moved_lights_update(const Scene& scene, const std::string& id, int i) {
  v1::UpdateLightsRequest update;
  update.set_scene_id(id);
  add_moved_lights(scene, i, *update.mutable_lights());
  const EnvironmentChange environment = turned_environment(scene, i);
  if (environment.rotation_deg) update.set_environment_rotation_deg(*environment.rotation_deg);
  return update;
}

// The benchmark's photon scene at its size, photons and k, uploaded.
absl::StatusOr<std::pair<Scene, std::string>> upload_photon_scene(const BenchOptions& o,
                                                                  client::Connection& connection,
                                                                  const std::string& name) {
  absl::StatusOr<Scene> scene = load_photon_scene(o);
  if (!scene.ok()) return scene.status();
  absl::StatusOr<std::string> id = upload(connection, *scene, name);
  if (!id.ok()) return id.status();
  return std::make_pair(*std::move(scene), *std::move(id));
}

// A light script played by the server (PlayAnimation, one stream): every keyframe moves the
// lights and renders one pass. Reports the interval between consecutive frames as the client
// receives them, and the server's own stage timings per keyframe: the rebuild (photons and maps),
// the render and the resolve (tone mapping, the copy back and encoding); the rest of an interval
// is transport.
absl::Status animation_benchmark(const BenchOptions& o, client::Connection& connection,
                                 Reporter& report) {
  absl::StatusOr<std::pair<Scene, std::string>> uploaded =
      upload_photon_scene(o, connection, "animation benchmark");
  if (!uploaded.ok()) return uploaded.status();
  const auto& [scene, id] = *uploaded;
  constexpr int kKeyframes = 24;
  v1::PlayAnimationRequest request;
  request.set_scene_id(id);
  request.mutable_format()->set_pixel_format(v1::RGBA8_SRGB);
  request.set_max_chunk_bytes(4u << 20);
  for (int i = 0; i < kKeyframes; ++i) {
    v1::Keyframe* keyframe = request.add_keyframes();
    keyframe->set_passes(1);
    add_moved_lights(scene, i, *keyframe->mutable_lights());
  }
  std::vector<double> intervals, rebuild, render, resolve;
  for (int run = 0; run < o.warmup + o.runs; ++run) {
    grpc::ClientContext context;
    std::unique_ptr<grpc::ClientReader<v1::Frame>> reader =
        connection.stub().PlayAnimation(&context, request);
    std::vector<Clock::time_point> arrivals;
    std::vector<v1::StageTimings> timings;
    absl::Status status = client::receive_frames(context, *reader, [&](v1::Frame& frame) {
      arrivals.push_back(Clock::now());
      timings.push_back(frame.timings());
      return absl::OkStatus();
    });
    if (!status.ok()) return status;
    if (arrivals.size() != kKeyframes) {
      return absl::DataLossError(
          absl::StrCat(arrivals.size(), " frames of ", kKeyframes, " arrived"));
    }
    if (run < o.warmup) continue;
    // From the second frame on: the first also waits for the call to start.
    for (int i = 1; i < kKeyframes; ++i) {
      intervals.push_back(ms_between(arrivals[i - 1], arrivals[i]));
      const v1::StageTimings& t = timings[i];
      rebuild.push_back(t.structure_build_ms() + t.photon_trace_ms() + t.photon_map_build_ms());
      render.push_back(t.render_ms());
      resolve.push_back(t.resolve_ms());
    }
  }
  const std::string name = photon_scene_label(o) + absl::StrFormat(" %d keyframes", kKeyframes);
  Measurement m = summarize(intervals);
  report.line("animation_frame_interval", name, m.median, "ms", &m, int(intervals.size()));
  report.line("animation_frame_rebuild", name, summarize(rebuild).median, "ms");
  report.line("animation_frame_render", name, summarize(render).median, "ms");
  report.line("animation_frame_resolve", name, summarize(resolve).median, "ms");
  return delete_scene(connection, id);
}

// UpdateLights (photons re-traced, maps rebuilt), then RenderFrame of one pass, as a client
// animating a light sees it, with the frame RAW (`update_to_frame`) or as a JPEG or PNG file
// (`update_to_frame_jpeg`, `update_to_frame_png`: what a viewer shows). Rebuild, render and
// encode come from the server's own stage timings; the rest of the client's wall time is
// transport (RPCs, tone mapping excluded, bytes on the wire), reported also per call: what the
// light change's call (`_update_call`) and the frame's call (`_frame_call`) cost beyond the
// server's stages.
absl::Status update_to_frame_benchmark(const BenchOptions& o, client::Connection& connection,
                                       const std::string& benchmark, v1::Encoding encoding,
                                       Reporter& report) {
  absl::StatusOr<std::pair<Scene, std::string>> uploaded =
      upload_photon_scene(o, connection, "latency benchmark");
  if (!uploaded.ok()) return uploaded.status();
  const auto& [scene, id] = *uploaded;
  std::vector<double> total, rebuild, render, encode, transport, update_call, frame_call, bytes;
  for (int i = 0; i < o.warmup + o.runs; ++i) {
    const v1::UpdateLightsRequest update = moved_lights_update(scene, id, i);
    v1::RenderFrameRequest render_request;
    render_request.set_scene_id(id);
    render_request.set_target_passes(1);
    render_request.mutable_format()->set_pixel_format(v1::RGBA8_SRGB);
    render_request.mutable_format()->set_encoding(encoding);

    const Clock::time_point start = Clock::now();
    absl::StatusOr<v1::RebuildReport> rebuilt =
        connection.call(&v1::RenderService::Stub::UpdateLights, update);
    if (!rebuilt.ok()) return rebuilt.status();
    const Clock::time_point updated = Clock::now();
    absl::StatusOr<v1::Frame> frame =
        connection.call(&v1::RenderService::Stub::RenderFrame, render_request);
    if (!frame.ok()) return frame.status();
    const Clock::time_point end = Clock::now();
    const double ms = ms_between(start, end);
    if (frame->epochs().lights() != rebuilt->epochs().lights()) {
      return absl::InternalError("the frame does not show the new lights epoch");
    }
    if (i < o.warmup) continue;
    const v1::StageTimings& r = rebuilt->timings();
    const v1::StageTimings& f = frame->timings();
    const double rebuild_ms = r.photon_trace_ms() + r.photon_map_build_ms() +
                              r.structure_build_ms() + f.photon_trace_ms() +
                              f.photon_map_build_ms();
    const double render_ms = f.render_ms() + f.resolve_ms() - f.encode_ms();
    total.push_back(ms);
    rebuild.push_back(rebuild_ms);
    render.push_back(render_ms);
    encode.push_back(f.encode_ms());
    transport.push_back(ms - rebuild_ms - render_ms - f.encode_ms());
    update_call.push_back(ms_between(start, updated) - rebuild_ms);
    frame_call.push_back(ms_between(updated, end) - render_ms - f.encode_ms());
    bytes.push_back(static_cast<double>(frame->data().size()));
  }
  const std::string name = photon_scene_label(o);
  Measurement m = summarize(total);
  report.line(benchmark, name, m.median, "ms", &m, o.runs);
  report.line(benchmark + "_rebuild", name, summarize(rebuild).median, "ms");
  report.line(benchmark + "_render", name, summarize(render).median, "ms");
  if (encoding != v1::RAW) {
    report.line(benchmark + "_encode", name, summarize(encode).median, "ms");
  }
  report.line(benchmark + "_transport", name, summarize(transport).median, "ms");
  report.line(benchmark + "_update_call", name, summarize(update_call).median, "ms");
  report.line(benchmark + "_frame_call", name, summarize(frame_call).median, "ms");
  report.line(benchmark + "_bytes", name, summarize(bytes).median, "bytes");
  return delete_scene(connection, id);
}

}  // namespace

absl::StatusOr<Reporter> server_device_reporter(client::Connection& connection,
                                                const Reporter& report) {
  absl::StatusOr<v1::Stats> stats =
      connection.call(&v1::RenderService::Stub::GetStats, v1::GetStatsRequest());
  if (!stats.ok()) return stats.status();
  return report.for_device(absl::StrFormat("server %s: %s x%d", stats->device().kind(),
                                           stats->device().name(),
                                           stats->device().compute_units()));
}

std::vector<std::string> serving_benchmark_names() {
  return {"stream_rgba8",         "stream_rgba32f",      "upload",    "update_to_frame",
          "update_to_frame_jpeg", "update_to_frame_png", "animation", kViewerDragBenchmark};
}

absl::Status run_serving_benchmarks(const BenchOptions& o, Reporter& server_report) {
  // viewer_drag starts a server of its own, with the viewer; the rest share this one.
  if (wanted(o, kViewerDragBenchmark)) {
    if (absl::Status s = run_viewer_drag_benchmark(o, server_report); !s.ok()) return s;
  }
  const std::vector<std::string> names = serving_benchmark_names();
  if (std::none_of(names.begin(), names.end(), [&](const std::string& n) {
        return n != kViewerDragBenchmark && wanted(o, n);
      })) {
    return absl::OkStatus();
  }
  client::ConnectOptions connect;
  // Always a server of our own: a figure must not depend on whatever else listens on 50051.
  absl::StatusOr<std::unique_ptr<client::EmbeddedServer>> server = client::EmbeddedServer::start(
      {.extra_args = {"--device", o.device, "--log-level", "warning"}});
  if (!server.ok()) return server.status();
  connect.server = (*server)->address();
  connect.max_message_mb = 256;
  absl::StatusOr<std::unique_ptr<client::Connection>> connection =
      client::Connection::open(connect);
  if (!connection.ok()) return connection.status();

  absl::StatusOr<Reporter> device_report = server_device_reporter(**connection, server_report);
  if (!device_report.ok()) return device_report.status();
  Reporter& report = *device_report;

  if (wanted(o, "stream_rgba8") || wanted(o, "stream_rgba32f")) {
    if (absl::Status s = stream_benchmarks(o, **connection, report); !s.ok()) return s;
  }
  if (wanted(o, "upload") && !o.mesh.empty()) {
    absl::StatusOr<Scene> scene = load_bench_mesh_scene(o);
    if (!scene.ok()) return scene.status();
    if (absl::Status s =
            upload_benchmark(o, **connection, *scene, o.mesh.filename().string(), report);
        !s.ok())
      return s;
  }
  for (const auto& [benchmark, encoding] :
       {std::pair{"update_to_frame", v1::RAW}, std::pair{"update_to_frame_jpeg", v1::JPEG},
        std::pair{"update_to_frame_png", v1::PNG}}) {
    if (!wanted(o, benchmark) || o.photon_scene.empty()) continue;
    if (absl::Status s = update_to_frame_benchmark(o, **connection, benchmark, encoding, report);
        !s.ok())
      return s;
  }
  if (wanted(o, "animation") && !o.photon_scene.empty()) {
    if (absl::Status s = animation_benchmark(o, **connection, report); !s.ok()) return s;
  }
  return absl::OkStatus();
}

}  // namespace caustica
