// animate --servers: one worker thread per replica takes the next keyframe from a shared queue;
// the main thread writes the frames in keyframe order (see animate_fleet.h).
#include "client/animate_fleet.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/frame_image.h"
#include "client/frame_stream.h"
#include "client/health_check.h"
#include "client/progress_bar.h"
#include "client/result_output.h"
#include "client/scene_source.h"
#include "client/scene_upload.h"
#include "proto/wire/scene_wire.h"
#include "renderer/scene/load_scene.h"

namespace caustica::client {
namespace {

using Clock = std::chrono::steady_clock;

// How often a replica that is down is asked whether it is back; also how long one health check
// may wait for a connection.
constexpr auto kProbeInterval = std::chrono::milliseconds(500);
// Reconnection attempts to a replica that is down stay this close together, so that one started
// during the run is found within a probe or two.
constexpr int kReconnectBackoffMs = 500;
// With no replica holding the scene for this long, the command gives up.
constexpr auto kNoReplicaGiveUp = std::chrono::seconds(30);
constexpr auto kCleanupTimeout = std::chrono::seconds(10);

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// Failures that say the replica (or its copy of the scene) is gone, rather than that the
// keyframe itself is wrong: the keyframe goes to another replica.
bool replica_failure(const absl::Status& status) {
  switch (status.code()) {
    case absl::StatusCode::kUnavailable:
    case absl::StatusCode::kDeadlineExceeded:
    case absl::StatusCode::kCancelled:
    case absl::StatusCode::kAborted:
    case absl::StatusCode::kNotFound:  // a restarted replica lost the scene
    case absl::StatusCode::kUnknown:
    case absl::StatusCode::kInternal:
    case absl::StatusCode::kDataLoss:
      return true;
    default:
      return false;
  }
}

struct Replica {
  std::string endpoint;
  std::unique_ptr<Connection> connection;
  // Guarded by Fleet::mutex_ from here on.
  std::string scene_id;  // empty: not (or no longer) holding the scene
  int frames = 0;
  int losses = 0;
  bool ever_joined = false;
  double busy_s = 0;                    // time holding the scene, up to the last join
  Clock::time_point joined;             // when it last got the scene
  grpc::ClientContext* call = nullptr;  // the running call, cancelled when the command stops
};

class Fleet {
 public:
  Fleet(const GlobalOptions& global, const AnimateOptions& options, v1::FrameFormat format,
        std::vector<v1::Keyframe> keyframes, Scene scene, std::string scene_name)
      : global_(global),
        options_(options),
        keyframes_(std::move(keyframes)),
        scene_(std::move(scene)),
        scene_name_(std::move(scene_name)),
        format_(std::move(format)),
        attempts_(keyframes_.size(), 0) {
    for (size_t i = 0; i < keyframes_.size(); ++i) queue_.push_back(static_cast<int>(i));
  }

  absl::Status open_replicas() {
    for (const std::string& endpoint : options_.servers) {
      ConnectOptions connect = global_.connect;
      connect.server = endpoint;
      connect.max_reconnect_backoff_ms = kReconnectBackoffMs;
      absl::StatusOr<std::unique_ptr<Connection>> connection = Connection::open(connect);
      if (!connection.ok()) return connection.status();
      auto replica = std::make_unique<Replica>();
      replica->endpoint = endpoint;
      replica->connection = *std::move(connection);
      replicas_.push_back(std::move(replica));
    }
    return absl::OkStatus();
  }

  absl::Status run(std::ostream& out) {
    const Clock::time_point start = Clock::now();
    last_held_ = start;
    std::vector<std::thread> workers;
    for (auto& replica : replicas_) workers.emplace_back([this, r = replica.get()] { work(*r); });
    absl::Status status = write_in_order(out, start);
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
      // After a failure, keyframes still rendering are not wanted; after success, only uploads to
      // replicas that joined too late can still be running.
      for (auto& replica : replicas_) {
        if (replica->call != nullptr) replica->call->TryCancel();
      }
    }
    changed_.notify_all();
    for (std::thread& worker : workers) worker.join();
    wall_s_ = seconds_since(start);
    delete_scenes();
    return status;
  }

  // Per replica: endpoint, frames, frames/s while it held the scene, and losses.
  nlohmann::json replicas_json() const {
    nlohmann::json list = nlohmann::json::array();
    for (const auto& r : replicas_) {
      list.push_back({{"server", r->endpoint},
                      {"frames", r->frames},
                      {"frames_per_s", r->busy_s > 0 ? r->frames / r->busy_s : 0.0},
                      {"joined", r->ever_joined},
                      {"losses", r->losses}});
    }
    return list;
  }
  const nlohmann::json& frames_json() const { return frames_json_; }
  double wall_s() const { return wall_s_; }
  void print_summary(std::ostream& out) const {
    for (const auto& r : replicas_) {
      out << absl::StrFormat("replica      %s: %d frames, %.2f frames/s%s\n", r->endpoint,
                             r->frames, r->busy_s > 0 ? r->frames / r->busy_s : 0.0,
                             !r->ever_joined  ? ", never answered"
                             : r->losses == 1 ? ", failed once"
                             : r->losses > 1  ? absl::StrFormat(", failed %d times", r->losses)
                                              : "");
    }
    out << absl::StrFormat("animation    %d frames in %.2f s: %.2f frames/s on %d replicas\n",
                           keyframes_.size(), wall_s_, keyframes_.size() / wall_s_,
                           replicas_.size());
  }

 private:
  // One replica's loop: join (health check, then upload), then render keyframes until none is
  // left; a failed replica gives its keyframe back and goes back to joining.
  void work(Replica& r) {
    while (true) {
      std::unique_lock lock(mutex_);
      if (stopping_) return;
      if (r.scene_id.empty()) {
        lock.unlock();
        join(r);
        continue;
      }
      changed_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      const int index = queue_.front();
      queue_.pop_front();
      const std::string scene_id = r.scene_id;
      // --timeout bounds each keyframe's call.
      std::unique_ptr<grpc::ClientContext> context = r.connection->new_context();
      r.call = context.get();
      lock.unlock();

      std::optional<v1::Frame> frame;
      const absl::Status status = render_keyframe(r, *context, scene_id, index, frame);

      lock.lock();
      r.call = nullptr;
      if (status.ok()) {
        ++r.frames;
        done_.emplace(index, std::pair(*std::move(frame), r.endpoint));
      } else if (stopping_) {
        return;
      } else {
        queue_.push_front(index);  // the earliest keyframes are the ones written first
        if (replica_failure(status) &&
            ++attempts_[index] <= static_cast<int>(replicas_.size()) + 2) {
          r.busy_s += seconds_since(r.joined);
          r.scene_id.clear();
          ++r.losses;
          note(absl::StrFormat("replica %s failed (%s: %s); keyframe %d goes to another replica",
                               r.endpoint, absl::StatusCodeToString(status.code()),
                               status.message(), index));
        } else if (failure_.ok()) {
          failure_ = absl::Status(status.code(), absl::StrCat("keyframe ", index, " on ",
                                                              r.endpoint, ": ", status.message()));
        }
      }
      lock.unlock();
      changed_.notify_all();
    }
  }

  absl::Status render_keyframe(Replica& r, grpc::ClientContext& context,
                               const std::string& scene_id, int index,
                               std::optional<v1::Frame>& frame) {
    v1::PlayAnimationRequest request;
    request.set_scene_id(scene_id);
    *request.add_keyframes() = keyframes_[static_cast<size_t>(index)];
    *request.mutable_format() = format_;
    std::unique_ptr<grpc::ClientReader<v1::Frame>> reader =
        r.connection->stub().PlayAnimation(&context, request);
    absl::Status status = receive_frames(context, *reader, [&](v1::Frame& whole) {
      frame = std::move(whole);
      return absl::OkStatus();
    });
    if (status.ok() && !frame) status = absl::DataLossError("the replica sent no frame");
    if (status.ok()) frame->set_keyframe(static_cast<uint32_t>(index));
    return status;
  }

  // Waits until the replica reports SERVING and uploads the scene to it; returns without a
  // scene after a probe interval otherwise.
  void join(Replica& r) {
    const Clock::time_point probe_start = Clock::now();
    absl::StatusOr<ServingStatus> health = check_health(
        r.connection->channel(), std::chrono::system_clock::now() + kProbeInterval, true);
    if (!health.ok() || *health != ServingStatus::kServing) {
      std::unique_lock lock(mutex_);
      changed_.wait_until(lock, probe_start + kProbeInterval, [&] { return stopping_; });
      return;
    }
    std::unique_ptr<grpc::ClientContext> context = r.connection->new_context();
    {
      std::lock_guard lock(mutex_);
      if (stopping_) return;
      r.call = context.get();
    }
    absl::StatusOr<v1::SceneInfo> info =
        upload_scene(r.connection->stub(), *context, scene_, scene_name_);
    std::lock_guard lock(mutex_);
    r.call = nullptr;
    if (!info.ok()) {
      if (!stopping_ && !replica_failure(info.status()) && failure_.ok()) {
        failure_ = absl::Status(info.status().code(), absl::StrCat("upload to ", r.endpoint, ": ",
                                                                   info.status().message()));
        changed_.notify_all();
      }
      return;
    }
    r.scene_id = info->scene_id();
    r.joined = Clock::now();
    if (r.ever_joined) note(absl::StrFormat("replica %s is back and takes keyframes", r.endpoint));
    r.ever_joined = true;
    changed_.notify_all();
  }

  // A line on stderr for the person watching; callers hold mutex_.
  void note(const std::string& line) {
    if (global_.progress) std::cerr << "\r\033[K";
    std::cerr << "caustica: animate: " << line << "\n";
  }

  // Writes frame 0, 1, ... as each becomes available, drawing each replica's rate.
  absl::Status write_in_order(std::ostream& out, Clock::time_point start) {
    ProgressBar bar("animate", global_.progress);
    std::error_code error;
    std::filesystem::create_directories(options_.directory, error);
    if (error) {
      return absl::InvalidArgumentError(absl::StrCat(
          options_.directory.string(), ": cannot create directory: ", error.message()));
    }
    const size_t total = keyframes_.size();
    for (size_t next = 0; next < total; ++next) {
      std::unique_lock lock(mutex_);
      while (!done_.contains(static_cast<int>(next))) {
        if (!failure_.ok()) return failure_;
        bool held = false;
        for (const auto& r : replicas_) held = held || !r->scene_id.empty();
        if (held) last_held_ = Clock::now();
        if (Clock::now() - last_held_ > kNoReplicaGiveUp) {
          return absl::UnavailableError(absl::StrCat(
              "no replica of ", absl::StrJoin(options_.servers, ","), " has answered for ",
              std::chrono::duration_cast<std::chrono::seconds>(kNoReplicaGiveUp).count(), " s; ",
              next, " of ", total, " frames written"));
        }
        changed_.wait_for(lock, std::chrono::milliseconds(200));
        bar.update(static_cast<double>(next), static_cast<double>(total), rates_text());
      }
      auto node = done_.extract(static_cast<int>(next));
      const std::string rates = rates_text();
      lock.unlock();
      const v1::Frame& frame = node.mapped().first;
      const std::filesystem::path path =
          options_.directory / absl::StrFormat("frame_%04d.%s", next, options_.format);
      if (absl::Status written = write_frame(frame, path); !written.ok()) return written;
      if (global_.json) {
        nlohmann::json json = frame_header_json(frame);
        json["output"] = path.string();
        json["server"] = node.mapped().second;
        frames_json_.push_back(std::move(json));
      } else {
        out << absl::StrFormat("wrote        %s  keyframe %d on %s: %s | %s ms\n", path.string(),
                               next, node.mapped().second, frame_text(frame),
                               timings_text(frame.timings()));
      }
      bar.update(static_cast<double>(next + 1), static_cast<double>(total),
                 absl::StrFormat("%.1f/s | %s", (next + 1) / seconds_since(start), rates));
    }
    std::lock_guard lock(mutex_);
    for (auto& r : replicas_) {
      if (!r->scene_id.empty()) r->busy_s += seconds_since(r->joined);
      r->joined = Clock::now();
    }
    return absl::OkStatus();
  }

  // "A 2.1/s, B down, C 1.9/s"; callers hold mutex_.
  std::string rates_text() const {
    std::vector<std::string> parts;
    for (const auto& r : replicas_) {
      if (r->scene_id.empty()) {
        parts.push_back(absl::StrCat(r->endpoint, " down"));
        continue;
      }
      const double busy = r->busy_s + seconds_since(r->joined);
      parts.push_back(absl::StrFormat("%s %.1f/s", r->endpoint, busy > 0 ? r->frames / busy : 0.0));
    }
    return absl::StrJoin(parts, ", ");
  }

  // Best effort, as for a single server: unless --keep, each replica that holds the scene drops
  // it.
  void delete_scenes() {
    if (options_.job.keep) return;
    for (auto& r : replicas_) {
      if (r->scene_id.empty()) continue;
      grpc::ClientContext context;
      context.set_deadline(std::chrono::system_clock::now() + kCleanupTimeout);
      r->connection->authorize(context);
      v1::DeleteSceneRequest request;
      request.set_scene_id(r->scene_id);
      v1::DeleteSceneResponse response;
      r->connection->stub().DeleteScene(&context, request, &response);
    }
  }

  const GlobalOptions& global_;
  const AnimateOptions& options_;
  const std::vector<v1::Keyframe> keyframes_;
  const Scene scene_;
  const std::string scene_name_;
  const v1::FrameFormat format_;
  std::vector<std::unique_ptr<Replica>> replicas_;

  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<int> queue_;      // keyframes no replica is rendering or has rendered
  std::vector<int> attempts_;  // per keyframe: replicas lost while rendering it
  std::map<int, std::pair<v1::Frame, std::string>> done_;  // frames not yet written, and by whom
  absl::Status failure_;  // a keyframe or upload that no other replica would do better
  bool stopping_ = false;
  Clock::time_point last_held_;  // when a replica last held the scene

  nlohmann::json frames_json_ = nlohmann::json::array();
  double wall_s_ = 0;
};

// Each replica sees only the keyframes it renders, but what a keyframe sets (the camera, the
// lights, emitters, the environment, where meshes stand) stays until another keyframe changes
// it: so each keyframe is made to carry the whole state it is seen in.
void carry_state(const Scene& scene, std::vector<v1::Keyframe>& keyframes) {
  v1::Camera camera = wire::encode_camera(scene.camera);
  camera.clear_width();
  camera.clear_height();
  google::protobuf::RepeatedPtrField<v1::Light> lights;
  for (const Light& light : scene.lights) *lights.Add() = wire::encode_light(light);
  google::protobuf::RepeatedPtrField<v1::Emitter> emitters;
  google::protobuf::RepeatedPtrField<v1::MeshUpdate> meshes;
  std::optional<float> intensity, rotation;
  // The entry of `list` whose `key` is `name`, added when there is none.
  const auto entry = [](auto& list, const std::string& name, auto key) {
    for (auto& e : list)
      if ((e.*key)() == name) return &e;
    return list.Add();
  };
  for (v1::Keyframe& keyframe : keyframes) {
    if (keyframe.has_camera()) {
      camera = keyframe.camera();
    } else {
      *keyframe.mutable_camera() = camera;
    }
    if (keyframe.keep_lights()) {
      *keyframe.mutable_lights() = lights;
      keyframe.set_keep_lights(false);
    } else {
      lights = keyframe.lights();
    }
    for (const v1::Emitter& change : keyframe.emitters()) {
      v1::Emitter& kept = *entry(emitters, change.material(), &v1::Emitter::material);
      kept.set_material(change.material());
      if (change.has_radiance()) *kept.mutable_radiance() = change.radiance();
      if (change.has_off()) kept.set_off(change.off());
    }
    *keyframe.mutable_emitters() = emitters;
    if (keyframe.has_environment_intensity()) intensity = keyframe.environment_intensity();
    if (keyframe.has_environment_rotation_deg()) rotation = keyframe.environment_rotation_deg();
    if (intensity) keyframe.set_environment_intensity(*intensity);
    if (rotation) keyframe.set_environment_rotation_deg(*rotation);
    for (const v1::MeshUpdate& change : keyframe.meshes()) {
      v1::MeshUpdate& kept = *entry(meshes, change.mesh(), &v1::MeshUpdate::mesh);
      kept.set_mesh(change.mesh());
      if (change.transform_size() > 0) *kept.mutable_transform() = change.transform();
      // New positions drop the normals that came before them (MeshUpdate).
      if (change.positions_size() > 0) {
        *kept.mutable_positions() = change.positions();
        kept.clear_normals();
      }
      if (change.normals_size() > 0) *kept.mutable_normals() = change.normals();
    }
    *keyframe.mutable_meshes() = meshes;
  }
}

}  // namespace

absl::Status run_animate_fleet(const GlobalOptions& global, const AnimateOptions& options,
                               std::vector<v1::Keyframe> keyframes,
                               const std::function<absl::Status()>& after_frames,
                               std::ostream& out) {
  if (!global.connect.server.empty()) {
    return absl::InvalidArgumentError("--servers replaces --server: give one or the other");
  }
  if (!is_scene_file(options.job.scene)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--servers needs a scene file, which goes to every replica; '",
                     options.job.scene, "' is a scene id, which only one server knows"));
  }
  absl::StatusOr<v1::FrameFormat> format = frame_format_for(
      std::filesystem::path("frame." + options.format), options.job.exposure_stops);
  if (!format.ok()) return format.status();
  absl::StatusOr<Scene> scene = load_scene_file(options.job.scene);
  if (!scene.ok()) return scene.status();
  options.job.overrides.apply(*scene);
  carry_state(*scene, keyframes);
  Fleet fleet(global, options, *std::move(format), std::move(keyframes), *std::move(scene),
              default_scene_name(options.job.scene));
  if (absl::Status opened = fleet.open_replicas(); !opened.ok()) return opened;
  if (absl::Status status = fleet.run(out); !status.ok()) return status;
  if (absl::Status finished = after_frames(); !finished.ok()) return finished;
  if (global.json) {
    nlohmann::json json;
    json["frames"] = fleet.frames_json();
    json["replicas"] = fleet.replicas_json();
    json["round_trip_ms"] = fleet.wall_s() * 1000;
    json["frames_per_s"] = static_cast<double>(fleet.frames_json().size()) / fleet.wall_s();
    if (!options.video.empty()) json["video"] = options.video.string();
    print_json(out, json);
  } else {
    fleet.print_summary(out);
    if (!options.video.empty()) out << absl::StrFormat("wrote        %s\n", options.video.string());
  }
  return absl::OkStatus();
}

}  // namespace caustica::client
