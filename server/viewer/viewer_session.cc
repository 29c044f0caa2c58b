#include "server/viewer/viewer_session.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "server/viewer/viewer_geometry.h"

namespace caustica::server::viewer {
namespace {

using nlohmann::json;

// Where the viewer places the light it offers for a scene without a point or spot light, in image
// coordinates.
constexpr double kPlacedLightU = 0.5;
constexpr double kPlacedLightV = 0.3;
// ... and at this fraction of the distance to the point orbit and zoom turn about.
constexpr double kPlacedLightDepth = 0.5;

absl::Status to_absl(const grpc::Status& status, std::string_view method) {
  if (status.ok()) return absl::OkStatus();
  return absl::Status(static_cast<absl::StatusCode>(status.error_code()),
                      absl::StrCat(std::string(method), ": ", status.error_message()));
}

bool same_epochs(const v1::Epochs& a, const v1::Epochs& b) {
  return a.geometry() == b.geometry() && a.lights() == b.lights() && a.camera() == b.camera() &&
         a.settings() == b.settings();
}

}  // namespace

ViewerSession::ViewerSession(std::shared_ptr<grpc::Channel> channel, ViewerSink& sink,
                             ViewerOptions options)
    : channel_(std::move(channel)),
      stub_(v1::RenderService::NewStub(channel_)),
      sink_(sink),
      options_(options) {}

ViewerSession::~ViewerSession() { close(); }

void ViewerSession::close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  stop_stream();
}

void ViewerSession::send(const json& message) {
  {
    std::lock_guard lock(mutex_);
    if (closed_) return;
  }
  sink_.send_text(message.dump(-1, ' ', false, json::error_handler_t::replace));
}

void ViewerSession::handle_binary() {
  sink_.send_text(error_message(absl::InvalidArgumentError(
      "binary messages are not accepted: control messages are JSON text")));
}

void ViewerSession::handle_text(std::string_view text) {
  absl::StatusOr<ViewerRequest> request = parse_request(text);
  if (!request.ok()) {
    sink_.send_text(error_message(request.status(), refused_request_id(text)));
    return;
  }
  if (absl::Status done = handle(*request); !done.ok()) {
    sink_.send_text(error_message(done, request->id));
  }
}

absl::Status ViewerSession::handle(const ViewerRequest& request) {
  if (request.type == RequestType::kHello) return hello(request);
  if (!greeted_) {
    return absl::FailedPreconditionError(
        "send {\"type\":\"hello\",\"token\":...} first (the token may be empty without --tokens)");
  }
  switch (request.type) {
    case RequestType::kHello:
      break;
    case RequestType::kList:
      return list(request);
    case RequestType::kOpen:
      return open(request);
    case RequestType::kMoveLight:
    case RequestType::kSetIntensity:
    case RequestType::kSetEmitter:
    case RequestType::kSetEnvironment:
      return change_lights(request);
    case RequestType::kOrbit:
    case RequestType::kZoom:
      return change_camera(request);
  }
  return absl::OkStatus();
}

std::unique_ptr<grpc::ClientContext> ViewerSession::make_context(double timeout_s) const {
  auto context = std::make_unique<grpc::ClientContext>();
  std::string token;
  {
    std::lock_guard lock(mutex_);
    token = token_;
  }
  // Without a token nothing is sent, so a server with --tokens refuses the call with its own
  // words, exactly as it refuses a gRPC client that sent none.
  if (!token.empty()) context->AddMetadata("authorization", "Bearer " + token);
  if (timeout_s > 0) {
    context->set_deadline(std::chrono::system_clock::now() +
                          std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000)));
  }
  return context;
}

absl::Status ViewerSession::hello(const ViewerRequest& request) {
  {
    std::lock_guard lock(mutex_);
    token_ = request.token;
  }
  greeted_ = true;
  return list(request);
}

absl::Status ViewerSession::list(const ViewerRequest& request) {
  v1::ListScenesResponse response;
  std::unique_ptr<grpc::ClientContext> context = make_context(options_.call_timeout_s);
  if (absl::Status status = to_absl(stub_->ListScenes(context.get(), {}, &response), "ListScenes");
      !status.ok()) {
    return status;
  }
  json scenes = json::array();
  for (const v1::SceneInfo& scene : response.scenes()) {
    scenes.push_back({{"id", scene.scene_id()},
                      {"name", scene.name()},
                      {"triangles", scene.triangles()},
                      {"width", scene.camera().width()},
                      {"height", scene.camera().height()},
                      {"lights", scene.lights()},
                      {"area_lights", scene.area_lights()}});
  }
  json message = {{"type", "scenes"}, {"scenes", scenes}};
  if (request.id) message["id"] = *request.id;
  send(message);
  return absl::OkStatus();
}

v1::Light ViewerSession::placed_light() const {
  v1::Light light;
  light.set_name("viewer light");
  light.set_type(v1::Light::POINT);
  // Halfway to the pivot: above what the camera looks at rather than on it.
  const double depth = kPlacedLightDepth * pivot_distance_;
  *light.mutable_position() = to_proto(point_at(camera_, kPlacedLightU, kPlacedLightV, depth));
  // Lights what the camera looks at with an irradiance of about one.
  const auto intensity = static_cast<float>(1.5 * depth * depth);
  light.mutable_intensity()->set_x(intensity);
  light.mutable_intensity()->set_y(intensity);
  light.mutable_intensity()->set_z(intensity);
  return light;
}

absl::Status ViewerSession::open(const ViewerRequest& request) {
  stop_stream();
  v1::GetSceneRequest get;
  get.set_scene_id(request.scene);
  v1::SceneInfo info;
  std::unique_ptr<grpc::ClientContext> context = make_context(options_.call_timeout_s);
  if (absl::Status status = to_absl(stub_->GetScene(context.get(), get, &info), "GetScene");
      !status.ok()) {
    return status;
  }
  scene_id_ = info.scene_id();
  info_ = info;
  camera_ = info.camera();
  pivot_distance_ = scene_scale_hint(camera_);
  lights_ = scene_lights(info, placed_light());
  const uint32_t passes = request.passes > 0 ? request.passes : options_.default_passes;
  const uint32_t strips = request.strips > 0 ? request.strips : options_.jpeg_strips;
  json message = {{"type", "scene"},
                  {"scene",
                   {{"id", info.scene_id()},
                    {"name", info.name()},
                    {"width", camera_.width()},
                    {"height", camera_.height()},
                    {"triangles", info.triangles()},
                    {"scene_lights", info.lights()},
                    {"area_lights", info.area_lights()},
                    {"epochs", epochs_json(info.epochs())}}},
                  {"passes", passes},
                  {"encoding", encoding_name(options_.encoding)},
                  {"lights", lights_json(lights_, camera_)},
                  {"emitters", emitters_json(lights_)},
                  {"environment", environment_json(lights_)}};
  if (request.id) message["id"] = *request.id;
  send(message);
  start_stream(scene_id_, passes, strips);
  return absl::OkStatus();
}

absl::Status ViewerSession::change_lights(const ViewerRequest& request) {
  if (scene_id_.empty()) return absl::FailedPreconditionError("open a scene first");
  absl::StatusOr<v1::UpdateLightsRequest> update =
      light_update(request, lights_, camera_, pivot_distance_);
  if (!update.ok()) return update.status();
  update->set_scene_id(scene_id_);
  v1::RebuildReport report;
  std::unique_ptr<grpc::ClientContext> context = make_context(options_.call_timeout_s);
  const grpc::Status status = stub_->UpdateLights(context.get(), *update, &report);
  if (status.error_code() == grpc::StatusCode::FAILED_PRECONDITION) reload_lights();
  if (absl::Status failed = to_absl(status, "UpdateLights"); !failed.ok()) return failed;
  apply_light_update(lights_, *update, report.epochs().lights());
  wake_stream();
  send_updated("lights", report, request);
  return absl::OkStatus();
}

void ViewerSession::send_updated(const char* what, const v1::RebuildReport& report,
                                 const ViewerRequest& request) {
  json message = {{"type", "updated"},
                  {"what", what},
                  {"epochs", epochs_json(report.epochs())},
                  {"timings", timings_json(report.timings())},
                  {"lights", lights_json(lights_, camera_)},
                  {"emitters", emitters_json(lights_)},
                  {"environment", environment_json(lights_)}};
  if (request.id) message["id"] = *request.id;
  send(message);
}

void ViewerSession::reload_lights() {
  v1::GetSceneRequest get;
  get.set_scene_id(scene_id_);
  v1::SceneInfo info;
  std::unique_ptr<grpc::ClientContext> context = make_context(options_.call_timeout_s);
  if (!stub_->GetScene(context.get(), get, &info).ok()) return;
  lights_ = scene_lights(info, placed_light());
  send({{"type", "lights"},
        {"epochs", epochs_json(info.epochs())},
        {"lights", lights_json(lights_, camera_)},
        {"emitters", emitters_json(lights_)},
        {"environment", environment_json(lights_)}});
}

absl::Status ViewerSession::change_camera(const ViewerRequest& request) {
  if (scene_id_.empty()) return absl::FailedPreconditionError("open a scene first");
  const v1::Camera camera = request.type == RequestType::kOrbit
                                ? orbit(camera_, request.dx, request.dy, pivot_distance_)
                                : zoom(camera_, request.steps, pivot_distance_);
  v1::UpdateCameraRequest update;
  update.set_scene_id(scene_id_);
  *update.mutable_camera() = camera;
  v1::RebuildReport report;
  std::unique_ptr<grpc::ClientContext> context = make_context(options_.call_timeout_s);
  if (absl::Status status =
          to_absl(stub_->UpdateCamera(context.get(), update, &report), "UpdateCamera");
      !status.ok()) {
    return status;
  }
  camera_ = camera;
  const Vec3d offset{camera.look_at().x() - camera.position().x(),
                     camera.look_at().y() - camera.position().y(),
                     camera.look_at().z() - camera.position().z()};
  pivot_distance_ = std::sqrt(offset.x * offset.x + offset.y * offset.y + offset.z * offset.z);
  wake_stream();
  send_updated("camera", report, request);
  return absl::OkStatus();
}

// --- the frame stream ---

void ViewerSession::start_stream(const std::string& scene_id, uint32_t passes, uint32_t strips) {
  {
    std::lock_guard lock(mutex_);
    if (closed_) return;
    stream_stop_ = false;
    woken_ = false;
  }
  stream_thread_ =
      std::thread([this, scene_id, passes, strips] { stream_loop(scene_id, passes, strips); });
}

void ViewerSession::stop_stream() {
  {
    std::lock_guard lock(mutex_);
    stream_stop_ = true;
    if (stream_context_) stream_context_->TryCancel();
  }
  wake_.notify_all();
  if (stream_thread_.joinable()) stream_thread_.join();
}

void ViewerSession::wake_stream() {
  {
    std::lock_guard lock(mutex_);
    woken_ = true;
  }
  wake_.notify_all();
}

bool ViewerSession::wait_for_wake(double timeout_s) {
  std::unique_lock lock(mutex_);
  auto ready = [&] { return woken_ || stream_stop_; };
  if (timeout_s > 0) {
    wake_.wait_for(lock, std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000)), ready);
  } else {
    wake_.wait(lock, ready);
  }
  const bool woken = woken_ && !stream_stop_;
  woken_ = false;
  return woken;
}

grpc::Status ViewerSession::stream_once(const std::string& scene_id, uint32_t passes,
                                        uint32_t strips, v1::Epochs* epochs,
                                        uint32_t* last_passes) {
  std::shared_ptr<grpc::ClientContext> context = make_context(0);
  {
    std::lock_guard lock(mutex_);
    if (stream_stop_) return grpc::Status::CANCELLED;
    stream_context_ = context;
    // Changes made from here on show in this call's frames.
    woken_ = false;
  }
  v1::StreamFramesRequest request;
  request.set_scene_id(scene_id);
  request.set_target_passes(passes);
  request.set_passes_per_frame(1);
  request.set_max_chunk_bytes(options_.stream_chunk_bytes);
  request.mutable_format()->set_pixel_format(v1::RGBA8_SRGB);
  request.mutable_format()->set_encoding(options_.encoding);
  if (options_.encoding == v1::JPEG) request.mutable_format()->set_jpeg_strips(strips);
  std::unique_ptr<grpc::ClientReader<v1::Frame>> reader =
      stub_->StreamFrames(context.get(), request);
  v1::Frame piece;
  v1::Frame header;
  std::string data;
  while (reader->Read(&piece)) {
    if (piece.data_offset() == 0) {
      header = piece;
      header.clear_data();
      data.clear();
      data.reserve(piece.data_size());
    }
    data += piece.data();
    if (!piece.last_chunk()) continue;
    *epochs = header.epochs();
    *last_passes = header.passes();
    {
      std::lock_guard lock(mutex_);
      if (closed_) break;
    }
    sink_.send_binary(frame_message(header, data));
  }
  const grpc::Status status = reader->Finish();
  std::lock_guard lock(mutex_);
  stream_context_.reset();
  return status;
}

void ViewerSession::stream_loop(std::string scene_id, uint32_t passes, uint32_t strips) {
  while (true) {
    v1::Epochs epochs;
    uint32_t last_passes = 0;
    const grpc::Status status = stream_once(scene_id, passes, strips, &epochs, &last_passes);
    {
      std::lock_guard lock(mutex_);
      if (stream_stop_) return;
    }
    if (!status.ok()) {
      send(json::parse(error_message(to_absl(status, "StreamFrames"))));
      if (status.error_code() == grpc::StatusCode::NOT_FOUND ||
          status.error_code() == grpc::StatusCode::UNAVAILABLE ||
          status.error_code() == grpc::StatusCode::UNAUTHENTICATED) {
        return;
      }
      // Another try once this page changes something, which may have freed what was missing.
      if (!wait_for_wake(0)) return;
      continue;
    }
    send({{"type", "idle"}, {"passes", last_passes}, {"epochs", epochs_json(epochs)}});
    // Finished: a change by this page (which wakes the thread) or by another client (seen by
    // polling) starts the next stream, unless the last frame already showed it.
    while (true) {
      wait_for_wake(options_.idle_poll_s);
      {
        std::lock_guard lock(mutex_);
        if (stream_stop_) return;
      }
      v1::GetSceneRequest get;
      get.set_scene_id(scene_id);
      v1::SceneInfo info;
      std::unique_ptr<grpc::ClientContext> context = make_context(options_.call_timeout_s);
      const grpc::Status polled = stub_->GetScene(context.get(), get, &info);
      if (!polled.ok()) {
        send(json::parse(error_message(to_absl(polled, "GetScene"))));
        return;
      }
      if (!same_epochs(info.epochs(), epochs) || info.passes() < last_passes) break;
    }
  }
}

}  // namespace caustica::server::viewer
