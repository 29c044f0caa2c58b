#include "bench/soak.h"

#include <grpcpp/client_context.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <fstream>
#include <functional>
#include <iostream>
#include <latch>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/strip.h"
#include "bench/hostile_client.h"
#include "client/connection.h"
#include "client/embedded_server.h"
#include "client/frame_stream.h"
#include "client/health_check.h"
#include "client/scene_upload.h"
#include "proto/wire/scene_wire.h"
#include "renderer/scene/load_scene.h"

#ifndef CAUSTICA_SCENES_DIR
#define CAUSTICA_SCENES_DIR "scenes"
#endif

namespace caustica {
namespace {

using Clock = std::chrono::steady_clock;
using Json = nlohmann::ordered_json;
using Stub = v1::RenderService::Stub;

double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// Milliseconds to a microsecond, so the report stays readable.
double rounded(double ms) { return std::round(ms * 1000.0) / 1000.0; }

// The passes the plain stream of a cycle renders to: a few frames after RenderFrame's one pass.
constexpr uint32_t kStreamPasses = 3;
// A target no stream reaches: those streams end only when the client cancels them.
constexpr uint32_t kEndlessPasses = 1u << 30;
// Error messages kept per call kind; the counts carry the rest.
constexpr size_t kFirstErrors = 5;
// How often the server's memory is sampled between the start and the end.
constexpr auto kSampleInterval = std::chrono::seconds(2);
constexpr double kFlatTolerance = 0.05;
// How long the server may take to end its streams once their clients went away.
constexpr auto kDrainTimeout = std::chrono::seconds(10);
// When the server's heap counts as settled (wait_for_heap_to_settle).
constexpr auto kSettleTimeout = std::chrono::seconds(10);
constexpr auto kSettleInterval = std::chrono::milliseconds(500);
constexpr double kSettledTolerance = 0.01;
// A cycle that failed waits this long before the next, so that a dead server is not hammered.
constexpr auto kErrorPause = std::chrono::milliseconds(200);
constexpr auto kProgressInterval = std::chrono::seconds(30);
// After the storm every port of a hostile soak's server must answer a plain request this fast;
// each gets this long before it counts as not answering at all.
constexpr auto kPortAnswerLimit = std::chrono::seconds(1);
constexpr double kPortCheckDeadline_s = 5;

enum CallKind { kUpload, kUpdateLights, kRender, kStream, kCancelledStream, kDelete, kCallKinds };
constexpr std::array<const char*, kCallKinds> kCallNames = {"upload_scene",     "update_lights",
                                                            "render_frame",     "stream_frames",
                                                            "stream_cancelled", "delete_scene"};

// What one client saw of one kind of call.
struct CallLog {
  uint64_t count = 0;
  uint64_t errors = 0;
  std::vector<double> ms;  // of the calls that succeeded
  std::vector<std::string> first_errors;

  void add(const absl::Status& status, double call_ms) {
    ++count;
    if (status.ok()) {
      ms.push_back(call_ms);
      return;
    }
    ++errors;
    if (first_errors.size() < kFirstErrors) first_errors.push_back(status.ToString());
  }
  void merge(const CallLog& other) {
    count += other.count;
    errors += other.errors;
    ms.insert(ms.end(), other.ms.begin(), other.ms.end());
    for (const std::string& e : other.first_errors) {
      if (first_errors.size() < kFirstErrors) first_errors.push_back(e);
    }
  }
};

struct ClientLog {
  std::array<CallLog, kCallKinds> calls;
  uint64_t cycles = 0;

  uint64_t errors() const {
    uint64_t n = 0;
    for (const CallLog& c : calls) n += c.errors;
    return n;
  }
  void merge(const ClientLog& other) {
    for (int i = 0; i < kCallKinds; ++i) calls[i].merge(other.calls[i]);
    cycles += other.cycles;
  }
};

// Nearest rank of sorted `ms`.
double percentile(const std::vector<double>& sorted, double p) {
  const size_t rank = size_t(std::ceil(p * double(sorted.size())));
  return sorted[std::clamp<size_t>(rank, 1, sorted.size()) - 1];
}

Json call_json(const CallLog& log) {
  std::vector<double> sorted = log.ms;
  std::sort(sorted.begin(), sorted.end());
  Json j;
  j["count"] = log.count;
  j["errors"] = log.errors;
  if (sorted.empty()) {
    j["p50_ms"] = j["p99_ms"] = j["max_ms"] = nullptr;
  } else {
    j["p50_ms"] = rounded(percentile(sorted, 0.50));
    j["p99_ms"] = rounded(percentile(sorted, 0.99));
    j["max_ms"] = rounded(sorted.back());
  }
  j["first_errors"] = log.first_errors;
  return j;
}

// --- the server process ---

// A field of /proc/<pid>/status, e.g. "VmRSS" or "State"; nullopt when the process is gone.
std::optional<std::string> proc_status_field(pid_t pid, absl::string_view field) {
  if (pid <= 0) return std::nullopt;
  std::ifstream in(absl::StrCat("/proc/", pid, "/status"));
  std::string line;
  while (std::getline(in, line)) {
    absl::string_view rest = line;
    if (absl::ConsumePrefix(&rest, field) && absl::ConsumePrefix(&rest, ":")) {
      return std::string(absl::StripAsciiWhitespace(rest));
    }
  }
  return std::nullopt;
}

std::optional<uint64_t> resident_bytes(pid_t pid) {
  std::optional<std::string> rss = proc_status_field(pid, "VmRSS");  // "12345 kB"
  uint64_t kib = 0;
  if (!rss || !absl::SimpleAtoi(absl::StripSuffix(*rss, " kB"), &kib)) return std::nullopt;
  return kib * 1024;
}

// A zombie has exited but is not reaped yet: the EmbeddedServer reaps it when it stops it.
bool process_alive(pid_t pid) {
  std::optional<std::string> state = proc_status_field(pid, "State");
  return state && !state->empty() && (*state)[0] != 'Z' && (*state)[0] != 'X';
}

struct Snapshot {
  std::optional<uint64_t> rss;
  std::optional<uint64_t> heap_bytes;  // none where the server does not report its heap
  std::optional<uint64_t> device_bytes;
  std::optional<v1::Stats> stats;
};

Snapshot snapshot(client::Connection& connection, pid_t pid) {
  Snapshot s;
  s.rss = resident_bytes(pid);
  absl::StatusOr<v1::Stats> stats = connection.call(&Stub::GetStats, v1::GetStatsRequest());
  if (stats.ok()) {
    if (stats->heap_bytes() > 0) s.heap_bytes = stats->heap_bytes();
    s.device_bytes = stats->memory_used_bytes();
    s.stats = *std::move(stats);
  }
  return s;
}

// Waits until the server runs at most `streams` streams; returns whether it did in time.
bool wait_for_streams(client::Connection& connection, uint32_t streams,
                      std::chrono::milliseconds timeout) {
  const Clock::time_point give_up = Clock::now() + timeout;
  while (true) {
    absl::StatusOr<v1::Stats> stats = connection.call(&Stub::GetStats, v1::GetStatsRequest());
    if (stats.ok() && stats->active_streams() <= streams) return true;
    if (Clock::now() >= give_up) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

// Waits until the server's live heap settled: what clients that just stopped left behind
// (connections being closed, a large message being dropped) takes a moment to go. Settled means
// two readings kSettleInterval apart within kSettledTolerance; gives up after kSettleTimeout.
void wait_for_heap_to_settle(client::Connection& connection) {
  const Clock::time_point give_up = Clock::now() + kSettleTimeout;
  std::optional<uint64_t> last;
  while (Clock::now() < give_up) {
    absl::StatusOr<v1::Stats> stats = connection.call(&Stub::GetStats, v1::GetStatsRequest());
    if (!stats.ok() || stats->heap_bytes() == 0) return;  // no heap to wait for
    const double heap = double(stats->heap_bytes());
    if (last && std::abs(heap - double(*last)) <= kSettledTolerance * double(*last)) return;
    last = stats->heap_bytes();
    std::this_thread::sleep_for(kSettleInterval);
  }
}

Json optional_json(std::optional<uint64_t> v) { return v ? Json(*v) : Json(nullptr); }

std::optional<double> relative_change(std::optional<uint64_t> from, std::optional<uint64_t> to) {
  if (!from || !to) return std::nullopt;
  // Bytes in use where there were none count as growth of their whole size.
  return (double(*to) - double(*from)) / double(std::max<uint64_t>(*from, 1));
}

// One reading of the server's memory.
struct Sample {
  std::optional<uint64_t> rss, heap_bytes, device_bytes;
};

// The start against the end, both read with no client working, and the range of the readings
// between them. Flat means the end is within kFlatTolerance of the start either way.
Json memory_json(const std::vector<Sample>& samples, std::optional<uint64_t> Sample::*field,
                 std::optional<bool>* flat) {
  *flat = std::nullopt;
  if (samples.empty()) return nullptr;
  std::optional<uint64_t> min, max;
  int count = 0;
  for (const Sample& sample : samples) {
    const std::optional<uint64_t> v = sample.*field;
    if (!v) continue;
    ++count;
    min = std::min(min.value_or(*v), *v);
    max = std::max(max.value_or(*v), *v);
  }
  const std::optional<uint64_t> start = samples.front().*field;
  const std::optional<uint64_t> end = samples.back().*field;
  Json j;
  j["start"] = optional_json(start);
  j["end"] = optional_json(end);
  j["min"] = optional_json(min);
  j["max"] = optional_json(max);
  j["samples"] = count;
  const std::optional<double> change = relative_change(start, end);
  j["change"] = change ? Json(std::round(*change * 1e6) / 1e6) : Json(nullptr);
  if (change) *flat = std::abs(*change) <= kFlatTolerance;
  j["flat"] = *flat ? Json(**flat) : Json(nullptr);
  return j;
}

// The server's own memory is judged by its live heap where it reports one, since resident memory
// also holds what the allocator keeps of freed memory (AddressSanitizer's quarantine alone grows
// it by hundreds of megabytes without a leak); unknown resident memory is not judged.
bool host_memory_flat(std::optional<bool> rss_flat, std::optional<bool> heap_flat) {
  return heap_flat ? *heap_flat : rss_flat.value_or(true);
}

// A scene file's stem, or its directory's name for the usual "scene.json".
std::string scene_name(const std::filesystem::path& file) {
  if (file.filename() == "scene.json" && file.has_parent_path()) {
    return file.parent_path().filename().string();
  }
  return file.stem().string();
}

// --- one client ---

absl::Status check_frame(const v1::Frame& frame, const Scene& scene) {
  const uint32_t w = uint32_t(scene.camera.width), h = uint32_t(scene.camera.height);
  if (frame.width() != w || frame.height() != h || frame.data().size() != size_t{w} * h * 4) {
    return absl::DataLossError(
        absl::StrFormat("a frame of %dx%d with %d bytes, expected %dx%d RGBA8", frame.width(),
                        frame.height(), frame.data().size(), w, h));
  }
  return absl::OkStatus();
}

using LightLists = std::array<std::vector<v1::Light>, 2>;

// Replaces the lights of scene `id` with `lights`.
absl::Status set_lights(client::Connection& connection, const std::string& id,
                        const std::vector<v1::Light>& lights) {
  v1::UpdateLightsRequest request;
  request.set_scene_id(id);
  for (const v1::Light& light : lights) *request.add_lights() = light;
  return connection.call(&Stub::UpdateLights, request).status();
}

// The two light lists a cycle alternates between: the scene's own lights and a point light in
// the upper middle of the scene's bounds, moved sideways, so that every update is a real change.
LightLists light_lists(const Scene& scene) {
  Vec3f low(std::numeric_limits<float>::max()), high(std::numeric_limits<float>::lowest());
  for (const Mesh& mesh : scene.meshes) {
    for (const Vec3f& p : mesh.positions) {
      for (int axis = 0; axis < 3; ++axis) {
        low[axis] = std::min(low[axis], p[axis]);
        high[axis] = std::max(high[axis], p[axis]);
      }
    }
  }
  if (low.x > high.x) low = high = scene.camera.look_at;
  const Vec3f extent = high - low;
  // About the irradiance the Cornell box's ceiling light gives its floor, for any scene size.
  const float diagonal2 = extent.x * extent.x + extent.y * extent.y + extent.z * extent.z;
  const float intensity = std::max(0.05f * diagonal2, 1.0f);
  LightLists lists;
  for (int i = 0; i < 2; ++i) {
    for (const Light& light : scene.lights) lists[i].push_back(wire::encode_light(light));
    Light moving;
    moving.name = "soak";
    moving.type = LightType::kPoint;
    moving.position = low + extent * Vec3f(i == 0 ? 0.4f : 0.6f, 0.75f, 0.5f);
    moving.intensity = Vec3f(intensity);
    lists[i].push_back(wire::encode_light(moving));
  }
  return lists;
}

// The frames of a fresh upload under each light list, by their passes, rendered once at the start.
// Within a backend a render is deterministic (docs/architecture.md), so every frame a cycle gets
// must equal the reference of its light list and passes byte for byte.
using ReferenceFrames = std::array<std::map<uint32_t, std::string>, 2>;

// A stream of this many passes covers every frame of a cycle, the cancelled stream's included.
constexpr uint32_t kReferencePasses = 2 * kStreamPasses + 2;

absl::StatusOr<ReferenceFrames> render_references(client::Connection& connection,
                                                  const Scene& scene, const LightLists& lights) {
  ReferenceFrames references;
  for (size_t i = 0; i < lights.size(); ++i) {
    std::unique_ptr<grpc::ClientContext> upload_context = connection.new_context();
    absl::StatusOr<v1::SceneInfo> info =
        client::upload_scene(connection.stub(), *upload_context, scene, "soak reference");
    if (!info.ok()) return info.status();
    absl::Status status = set_lights(connection, info->scene_id(), lights[i]);
    if (status.ok()) {
      v1::StreamFramesRequest request;
      request.set_scene_id(info->scene_id());
      request.set_target_passes(kReferencePasses);
      request.set_passes_per_frame(1);
      request.mutable_format()->set_pixel_format(v1::RGBA8_SRGB);
      std::unique_ptr<grpc::ClientContext> context = connection.new_context();
      auto reader = connection.stub().StreamFrames(context.get(), request);
      status = client::receive_frames(*context, *reader, [&](v1::Frame& frame) {
        if (absl::Status s = check_frame(frame, scene); !s.ok()) return s;
        references[i][frame.passes()] = std::move(*frame.mutable_data());
        return absl::OkStatus();
      });
    }
    v1::DeleteSceneRequest remove;
    remove.set_scene_id(info->scene_id());
    absl::Status deleted = connection.call(&Stub::DeleteScene, remove).status();
    if (!status.ok()) return status;
    if (!deleted.ok()) return deleted;
  }
  return references;
}

class SoakClient {
 public:
  SoakClient(int index, const Scene& scene, const LightLists& lights,
             const ReferenceFrames& references, client::Connection& connection)
      : name_(absl::StrCat("soak client ", index)),
        scene_(scene),
        lights_(lights),
        references_(references),
        connection_(connection) {}

  // Upload, light change, render, stream, cancelled stream, delete. A failed step skips to the
  // delete, so the client never leaves a scene behind.
  void cycle(ClientLog& log) {
    bool ok = true;
    std::string id;
    const size_t lights = log.cycles % lights_.size();
    auto step = [&](CallKind kind, const std::function<absl::Status()>& call) {
      if (!ok) return;
      const Clock::time_point start = Clock::now();
      const absl::Status status = call();
      log.calls[kind].add(status, ms_between(start, Clock::now()));
      ok = status.ok();
    };
    step(kUpload, [&] { return upload(id); });
    step(kUpdateLights, [&] { return update_lights(id, lights); });
    step(kRender, [&] { return render(id, lights); });
    step(kStream, [&] { return stream(id, lights); });
    step(kCancelledStream, [&] { return cancelled_stream(id, lights); });
    if (!id.empty()) {
      ok = true;
      step(kDelete, [&] { return delete_scene(id); });
    }
    ++log.cycles;
    if (log.errors() > errors_seen_) {
      errors_seen_ = log.errors();
      std::this_thread::sleep_for(kErrorPause);
    }
  }

 private:
  absl::Status upload(std::string& id) {
    std::unique_ptr<grpc::ClientContext> context = connection_.new_context();
    absl::StatusOr<v1::SceneInfo> info =
        client::upload_scene(connection_.stub(), *context, scene_, name_);
    if (!info.ok()) return info.status();
    id = info->scene_id();
    return absl::OkStatus();
  }

  absl::Status update_lights(const std::string& id, size_t lights) {
    return set_lights(connection_, id, lights_[lights]);
  }

  // The frame's size, and its pixels against the reference of its light list and passes.
  absl::Status check(const v1::Frame& frame, size_t lights) const {
    if (absl::Status s = check_frame(frame, scene_); !s.ok()) return s;
    const std::map<uint32_t, std::string>& frames = references_[lights];
    const auto reference = frames.find(frame.passes());
    if (reference == frames.end()) {
      return absl::DataLossError(
          absl::StrFormat("a frame of %d passes, which the reference (to %d passes) lacks",
                          frame.passes(), frames.empty() ? 0 : frames.rbegin()->first));
    }
    if (frame.data() != reference->second) {
      const std::string& expected = reference->second;
      size_t differ = 0;
      for (size_t i = 0; i < expected.size(); ++i) differ += frame.data()[i] != expected[i];
      return absl::DataLossError(absl::StrFormat(
          "the frame of %d passes under light list %d differs from the reference in %d of %d "
          "bytes",
          frame.passes(), lights, differ, expected.size()));
    }
    return absl::OkStatus();
  }

  absl::Status render(const std::string& id, size_t lights) {
    v1::RenderFrameRequest request;
    request.set_scene_id(id);
    request.set_target_passes(1);
    request.mutable_format()->set_pixel_format(v1::RGBA8_SRGB);
    absl::StatusOr<v1::Frame> frame = connection_.call(&Stub::RenderFrame, request);
    if (!frame.ok()) return frame.status();
    return check(*frame, lights);
  }

  v1::StreamFramesRequest stream_request(const std::string& id, uint32_t target) const {
    v1::StreamFramesRequest request;
    request.set_scene_id(id);
    request.set_target_passes(target);
    request.set_passes_per_frame(1);
    request.mutable_format()->set_pixel_format(v1::RGBA8_SRGB);
    return request;
  }

  absl::Status stream(const std::string& id, size_t lights) {
    std::unique_ptr<grpc::ClientContext> context = connection_.new_context();
    auto reader = connection_.stub().StreamFrames(context.get(), stream_request(id, kStreamPasses));
    uint32_t passes = 0;
    absl::Status status = client::receive_frames(*context, *reader, [&](v1::Frame& frame) {
      passes = frame.passes();
      return check(frame, lights);
    });
    if (!status.ok()) return status;
    if (passes < kStreamPasses) {
      return absl::DataLossError(
          absl::StrCat("the stream ended at ", passes, " passes of ", kStreamPasses));
    }
    return absl::OkStatus();
  }

  // The client's cancellation after the first frame is the expected end, not an error.
  absl::Status cancelled_stream(const std::string& id, size_t lights) {
    std::unique_ptr<grpc::ClientContext> context = connection_.new_context();
    auto reader =
        connection_.stub().StreamFrames(context.get(), stream_request(id, kEndlessPasses));
    bool cancelled = false;
    absl::Status status = client::receive_frames(*context, *reader, [&](v1::Frame& frame) {
      if (absl::Status s = check(frame, lights); !s.ok()) return s;
      cancelled = true;
      return absl::CancelledError("cancelled by the client after the first frame");
    });
    if (cancelled && absl::IsCancelled(status)) return absl::OkStatus();
    if (status.ok()) return absl::InternalError("an endless stream ended by itself");
    return status;
  }

  absl::Status delete_scene(const std::string& id) {
    v1::DeleteSceneRequest request;
    request.set_scene_id(id);
    return connection_.call(&Stub::DeleteScene, request).status();
  }

  const std::string name_;
  const Scene& scene_;
  const LightLists& lights_;
  const ReferenceFrames& references_;
  client::Connection& connection_;
  uint64_t errors_seen_ = 0;
};

// --- the storm ---

struct StormResult {
  int streams = 0;
  int streaming_before_cancel = 0;  // had their first frame when the cancel came
  uint32_t server_streams_before_cancel = 0;
  int cancelled = 0;
  int finished = 0;  // ended by themselves: unexpected
  int errors = 0;
  std::vector<std::string> first_errors;
  double open_ms = 0;                // from opening to the cancel
  double closed_ms = 0;              // from the cancel until every call returned on the client
  std::optional<double> drained_ms;  // from the cancel until the server ran no storm stream
};

// Opens `streams` endless streams on one scene at once, waits until each showed a frame (or for
// `wait`), cancels them all at once and waits for the server to end them.
absl::StatusOr<StormResult> run_storm(client::Connection& connection, const Scene& scene,
                                      int streams, uint32_t streams_before,
                                      std::chrono::milliseconds wait) {
  StormResult r;
  r.streams = streams;
  std::string id;
  {
    std::unique_ptr<grpc::ClientContext> context = connection.new_context();
    absl::StatusOr<v1::SceneInfo> info =
        client::upload_scene(connection.stub(), *context, scene, "soak storm");
    if (!info.ok()) return info.status();
    id = info->scene_id();
  }
  v1::StreamFramesRequest request;
  request.set_scene_id(id);
  request.set_target_passes(kEndlessPasses);
  request.set_passes_per_frame(1);
  request.mutable_format()->set_pixel_format(v1::RGBA8_SRGB);

  std::vector<std::unique_ptr<grpc::ClientContext>> contexts;
  for (int i = 0; i < streams; ++i) contexts.push_back(connection.new_context());
  std::vector<absl::Status> results(streams);
  std::mutex mutex;
  std::condition_variable first_frame;
  int streaming = 0;
  std::latch open(1);
  std::vector<std::thread> threads;
  threads.reserve(streams);
  for (int i = 0; i < streams; ++i) {
    threads.emplace_back([&, i] {
      open.wait();
      auto reader = connection.stub().StreamFrames(contexts[i].get(), request);
      bool first = true;
      results[i] = client::receive_frames(*contexts[i], *reader, [&](v1::Frame& frame) {
        if (first) {
          first = false;
          std::lock_guard<std::mutex> lock(mutex);
          ++streaming;
          first_frame.notify_all();
        }
        return check_frame(frame, scene);
      });
    });
  }
  const Clock::time_point opened = Clock::now();
  open.count_down();
  {
    std::unique_lock<std::mutex> lock(mutex);
    first_frame.wait_for(lock, wait, [&] { return streaming == streams; });
    r.streaming_before_cancel = streaming;
  }
  absl::StatusOr<v1::Stats> stats = connection.call(&Stub::GetStats, v1::GetStatsRequest());
  if (stats.ok() && stats->active_streams() > streams_before) {
    r.server_streams_before_cancel = stats->active_streams() - streams_before;
  }
  const Clock::time_point cancel = Clock::now();
  r.open_ms = rounded(ms_between(opened, cancel));
  for (const auto& context : contexts) context->TryCancel();
  for (std::thread& t : threads) t.join();
  r.closed_ms = rounded(ms_between(cancel, Clock::now()));
  if (wait_for_streams(connection, streams_before,
                       std::chrono::duration_cast<std::chrono::milliseconds>(kDrainTimeout))) {
    r.drained_ms = rounded(ms_between(cancel, Clock::now()));
  }
  for (const absl::Status& status : results) {
    if (absl::IsCancelled(status)) {
      ++r.cancelled;
    } else if (status.ok()) {
      ++r.finished;
    } else {
      ++r.errors;
      if (r.first_errors.size() < kFirstErrors) r.first_errors.push_back(status.ToString());
    }
  }
  r.errors += r.finished;
  v1::DeleteSceneRequest remove;
  remove.set_scene_id(id);
  if (absl::Status s = connection.call(&Stub::DeleteScene, remove).status(); !s.ok()) {
    ++r.errors;
    if (r.first_errors.size() < kFirstErrors) r.first_errors.push_back(s.ToString());
  }
  return r;
}

// What the hostile clients met, and how each port answered after the storm. Met means every class
// ran, no probe met the unexpected, every port answered within kPortAnswerLimit, and the target
// scene could be deleted at the end.
Json hostile_json(const std::vector<HostileLogs>& logs, const std::vector<PortCheck>& checks,
                  const absl::Status& target_deleted, bool* met) {
  HostileLogs all;
  for (const HostileLogs& client : logs) {
    for (int k = 0; k < kHostileClasses; ++k) all[k].merge(client[k]);
  }
  *met = target_deleted.ok();
  Json j;
  for (int k = 0; k < kHostileClasses; ++k) {
    const HostileLog& log = all[k];
    j["classes"][kHostileClassNames[k]] = {{"actions", log.actions},
                                           {"probes", log.probes},
                                           {"refused", log.refused},
                                           {"accepted", log.accepted},
                                           {"busy", log.busy},
                                           {"unexpected", log.unexpected},
                                           {"first_unexpected", log.first_unexpected}};
    *met = *met && log.actions > 0 && log.unexpected == 0;
  }
  const double limit_ms = std::chrono::duration<double, std::milli>(kPortAnswerLimit).count();
  for (const PortCheck& check : checks) {
    j["after_storm"][check.port] = {{"status", check.status.ok() ? "OK" : check.status.ToString()},
                                    {"ms", rounded(check.ms)}};
    *met = *met && check.status.ok() && check.ms < limit_ms;
  }
  j["answer_limit_ms"] = limit_ms;
  j["target_deleted"] = target_deleted.ok() ? "OK" : target_deleted.ToString();
  j["expectations_met"] = *met;
  return j;
}

const char* serving_status_name(client::ServingStatus s) {
  switch (s) {
    case client::ServingStatus::kServing:
      return "SERVING";
    case client::ServingStatus::kNotServing:
      return "NOT_SERVING";
    case client::ServingStatus::kServiceUnknown:
      return "SERVICE_UNKNOWN";
    case client::ServingStatus::kUnknown:
      break;
  }
  return "UNKNOWN";
}

// A fresh scene uploaded, rendered and deleted.
absl::Status render_fresh_scene(client::Connection& connection, const Scene& scene) {
  std::unique_ptr<grpc::ClientContext> context = connection.new_context();
  absl::StatusOr<v1::SceneInfo> info =
      client::upload_scene(connection.stub(), *context, scene, "soak health check");
  if (!info.ok()) return info.status();
  v1::RenderFrameRequest render;
  render.set_scene_id(info->scene_id());
  render.set_target_passes(1);
  render.mutable_format()->set_pixel_format(v1::RGBA8_SRGB);
  absl::StatusOr<v1::Frame> frame = connection.call(&Stub::RenderFrame, render);
  absl::Status status = frame.ok() ? check_frame(*frame, scene) : frame.status();
  v1::DeleteSceneRequest remove;
  remove.set_scene_id(info->scene_id());
  absl::Status deleted = connection.call(&Stub::DeleteScene, remove).status();
  return status.ok() ? deleted : status;
}

// Samples the server's memory from `first` on until stopped, and tells stderr how far the soak got
// now and then.
class Sampler {
 public:
  Sampler(client::Connection& connection, pid_t pid, const Snapshot& first, Clock::time_point end,
          const std::atomic<uint64_t>& cycles, const std::atomic<uint64_t>& errors)
      : connection_(connection),
        pid_(pid),
        start_(Clock::now()),
        end_(end),
        cycles_(cycles),
        errors_(errors) {
    add_locked(first);
    thread_ = std::thread([this] { run(); });
  }
  ~Sampler() { stop(); }

  void stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopped_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  void add(const Snapshot& s) {
    std::lock_guard<std::mutex> lock(mutex_);
    add_locked(s);
  }
  std::vector<Sample> samples() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return samples_;
  }

 private:
  void add_locked(const Snapshot& s) { samples_.push_back({s.rss, s.heap_bytes, s.device_bytes}); }

  void run() {
    Clock::time_point next_progress = start_ + kProgressInterval;
    std::unique_lock<std::mutex> lock(mutex_);
    while (!wake_.wait_for(lock, kSampleInterval, [this] { return stopped_; })) {
      lock.unlock();
      const Snapshot s = snapshot(connection_, pid_);
      const Clock::time_point now = Clock::now();
      if (now >= next_progress) {
        next_progress += kProgressInterval;
        std::cerr << absl::StrFormat(
            "caustica-bench: soak %.0f s, %.0f s to go: %d cycles, %d errors\n",
            std::chrono::duration<double>(now - start_).count(),
            std::max(0.0, std::chrono::duration<double>(end_ - now).count()), cycles_.load(),
            errors_.load());
      }
      lock.lock();
      if (!stopped_) add_locked(s);
    }
  }

  client::Connection& connection_;
  const pid_t pid_;
  const Clock::time_point start_, end_;
  const std::atomic<uint64_t>& cycles_;
  const std::atomic<uint64_t>& errors_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopped_ = false;
  std::vector<Sample> samples_;
  std::thread thread_;
};

}  // namespace

absl::StatusOr<bool> run_soak(const SoakOptions& o, std::ostream& out) {
  if (o.hostile && !o.server.empty()) {
    return absl::InvalidArgumentError(
        "a hostile soak starts its own server (no --server), whose every port it attacks");
  }
  const std::filesystem::path scene_file =
      o.scene.empty() ? std::filesystem::path(CAUSTICA_SCENES_DIR) / "cornell-box/scene.json"
                      : o.scene;
  absl::StatusOr<Scene> scene = load_scene(scene_file);
  if (!scene.ok()) return scene.status();
  scene->camera.width = o.width;
  scene->camera.height = o.height;
  scene->settings.photons_per_pass = o.photons;
  const LightLists lights = light_lists(*scene);
  const std::string scene_label =
      absl::StrFormat("%s %dx%d %d photons", scene_name(scene_file), o.width, o.height, o.photons);

  std::unique_ptr<client::EmbeddedServer> server;
  std::string address = o.server;
  pid_t pid = o.server_pid;
  // Every client holds one scene at a time; the storm and the health check add one each. Hostile
  // clients add their target and, for a moment, each an upload of theirs the server accepted.
  const int scenes_needed = o.clients + 2 + (o.hostile ? o.clients + 1 : 0);
  HostilePorts ports;
  if (address.empty()) {
    std::vector<std::string> args = {"--device",     o.device,
                                     "--max-scenes", absl::StrCat(scenes_needed + 6),
                                     "--log-level",  "warning"};
    std::vector<std::string> environment;
    if (o.hostile) {
      args.insert(args.end(), {"--max-message-mb", absl::StrCat(kHostileMaxMessageMb)});
      // glibc counts the blocks each thread keeps for reuse (its tcache) as allocated, and the
      // viewer's many handler threads fill theirs only slowly, which reads as a growing heap.
      // Without those caches the heap GetStats reports is what is live.
      environment.push_back("GLIBC_TUNABLES=glibc.malloc.tcache_count=0");
    }
    absl::StatusOr<std::unique_ptr<client::EmbeddedServer>> started =
        client::EmbeddedServer::start({.data_dir = o.data_dir,
                                       .extra_args = args,
                                       .environment = environment,
                                       .every_port = o.hostile});
    if (!started.ok()) return started.status();
    server = *std::move(started);
    address = server->address();
    pid = server->pid();
    ports = {.grpc = server->port(),
             .health = server->health_port(),
             .metrics = server->metrics_port(),
             .http = server->http_port()};
  }
  client::ConnectOptions connect;
  connect.server = address;
  connect.timeout_s = o.deadline_s;
  absl::StatusOr<std::unique_ptr<client::Connection>> main_connection =
      client::Connection::open(connect);
  if (!main_connection.ok()) return main_connection.status();
  client::Connection& connection = **main_connection;
  absl::StatusOr<v1::Stats> before = connection.call(&Stub::GetStats, v1::GetStatsRequest());
  if (!before.ok()) return before.status();
  const uint32_t streams_before = before->active_streams();
  if (before->max_scenes() < before->scenes() + uint32_t(scenes_needed)) {
    return absl::FailedPreconditionError(absl::StrFormat(
        "the server holds %d of its %d scenes (--max-scenes); %d clients need %d more",
        before->scenes(), before->max_scenes(), o.clients, scenes_needed));
  }
  absl::StatusOr<ReferenceFrames> references = render_references(connection, *scene, lights);
  if (!references.ok()) return references.status();

  // The clients share the connection: gRPC channels to one address share their transport anyway,
  // and the stub is safe to call from many threads.
  std::vector<std::unique_ptr<SoakClient>> clients;
  for (int i = 0; i < o.clients; ++i) {
    clients.push_back(std::make_unique<SoakClient>(i, *scene, lights, *references, connection));
  }
  // The hostile clients share one target scene, which lives from here to the end.
  std::string target;
  std::vector<std::unique_ptr<HostileClient>> hostile;
  std::vector<HostileLogs> hostile_logs(o.clients);
  if (o.hostile) {
    std::unique_ptr<grpc::ClientContext> context = connection.new_context();
    absl::StatusOr<v1::SceneInfo> info =
        client::upload_scene(connection.stub(), *context, *scene, "soak hostile target");
    if (!info.ok()) return info.status();
    target = info->scene_id();
    for (int i = 0; i < o.clients; ++i) {
      hostile.push_back(std::make_unique<HostileClient>(i, ports, target, *scene, o.deadline_s));
    }
  }

  // The clients first cycle unmeasured (at least once each) until the server's pools, caches and
  // bounded statistics have filled up, so that the start's memory is the server's steady state;
  // the timed cycles start together after it.
  std::vector<ClientLog> warmup(o.clients), timed(o.clients);
  std::atomic<uint64_t> cycles_done{0}, errors_seen{0};
  std::latch warmed(o.clients), go(1);
  const Clock::time_point warmup_end =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(
                         std::chrono::duration<double>(o.warmup_minutes * 60.0));
  Clock::time_point end;
  std::vector<std::thread> threads;
  for (int i = 0; i < o.clients; ++i) {
    threads.emplace_back([&, i] {
      // Hostile actions run in the warm-up too, so that what the server keeps for them is in the
      // start's memory.
      const auto cycle = [&](ClientLog& log) {
        const uint64_t errors = log.errors();
        clients[i]->cycle(log);
        errors_seen += log.errors() - errors;
        if (o.hostile) hostile[i]->act(hostile_logs[i]);
      };
      for (int n = 0; n < o.warmup_cycles || Clock::now() < warmup_end; ++n) cycle(warmup[i]);
      warmed.count_down();
      go.wait();
      while (Clock::now() < end) {
        cycle(timed[i]);
        ++cycles_done;
      }
    });
  }
  const auto drain = std::chrono::duration_cast<std::chrono::milliseconds>(kDrainTimeout);
  warmed.wait();
  std::cerr << absl::StrFormat("caustica-bench: soak: warm-up done, timing %g minutes\n",
                               o.minutes);
  wait_for_streams(connection, streams_before, drain);
  wait_for_heap_to_settle(connection);
  const Snapshot start = snapshot(connection, pid);
  const Clock::time_point started = Clock::now();
  end = started + std::chrono::duration_cast<Clock::duration>(
                      std::chrono::duration<double>(o.minutes * 60.0));
  Sampler sampler(connection, pid, start, end, cycles_done, errors_seen);
  go.count_down();
  for (std::thread& t : threads) t.join();
  const double elapsed_s = std::chrono::duration<double>(Clock::now() - started).count();
  wait_for_streams(connection, streams_before, drain);
  sampler.stop();
  wait_for_heap_to_settle(connection);
  const Snapshot finish = snapshot(connection, pid);
  sampler.add(finish);

  StormResult storm;
  absl::Status storm_status;
  if (o.storm > 0) {
    const auto wait = std::chrono::milliseconds(int64_t(std::min(30.0, o.deadline_s / 2) * 1000));
    absl::StatusOr<StormResult> ran = run_storm(connection, *scene, o.storm, streams_before, wait);
    if (ran.ok()) {
      storm = *std::move(ran);
    } else {
      storm_status = ran.status();
    }
  }
  const bool alive = server == nullptr || process_alive(pid);
  absl::StatusOr<client::ServingStatus> health = client::check_health(
      connection.channel(), std::chrono::system_clock::now() + std::chrono::seconds(5), false);
  const absl::Status fresh = render_fresh_scene(connection, *scene);
  std::vector<PortCheck> port_checks;
  absl::Status target_deleted;
  if (o.hostile) {
    port_checks = check_every_port(ports, kPortCheckDeadline_s);
    v1::DeleteSceneRequest remove;
    remove.set_scene_id(target);
    target_deleted = connection.call(&Stub::DeleteScene, remove).status();
  }
  const Snapshot after = snapshot(connection, pid);

  ClientLog all_warmup, all_timed;
  for (const ClientLog& log : warmup) all_warmup.merge(log);
  for (const ClientLog& log : timed) all_timed.merge(log);

  Json report;
  report["name"] = "soak";
  report["scene"] = scene_label;
  const v1::DeviceInfo& device = before->device();
  report["device"] =
      absl::StrFormat("server %s: %s x%d", device.kind(), device.name(), device.compute_units());
  report["server"] = address;
  report["server_started"] = server != nullptr;
  report["clients"] = o.clients;
  report["warmup_minutes"] = o.warmup_minutes;
  report["warmup_cycles"] = o.warmup_cycles;
  report["minutes"] = o.minutes;
  report["elapsed_s"] = rounded(elapsed_s);
  report["cycles"] = all_timed.cycles;
  report["cycles_per_s"] = rounded(elapsed_s > 0 ? all_timed.cycles / elapsed_s : 0.0);
  Json calls;
  uint64_t total_calls = 0;
  for (int k = 0; k < kCallKinds; ++k) {
    calls[kCallNames[k]] = call_json(all_timed.calls[k]);
    total_calls += all_timed.calls[k].count;
  }
  report["calls"] = calls;
  report["total_calls"] = total_calls;
  report["warmup"] = {{"cycles", all_warmup.cycles}, {"errors", all_warmup.errors()}};
  for (int k = 0; k < kCallKinds; ++k) {
    for (const std::string& e : all_warmup.calls[k].first_errors) {
      report["warmup"]["first_errors"].push_back(absl::StrCat(kCallNames[k], ": ", e));
    }
  }
  const uint64_t total_errors = all_timed.errors() + all_warmup.errors();
  report["total_errors"] = total_errors;

  std::optional<bool> rss_flat, heap_flat, device_flat;
  Json memory;
  const std::vector<Sample> samples = sampler.samples();
  memory["rss_bytes"] = memory_json(samples, &Sample::rss, &rss_flat);
  memory["heap_bytes"] = memory_json(samples, &Sample::heap_bytes, &heap_flat);
  memory["device_bytes"] = memory_json(samples, &Sample::device_bytes, &device_flat);
  memory["rss_bytes_after_storm"] = optional_json(after.rss);
  memory["heap_bytes_after_storm"] = optional_json(after.heap_bytes);
  memory["device_bytes_after_storm"] = optional_json(after.device_bytes);
  memory["tolerance"] = kFlatTolerance;
  const bool memory_flat = host_memory_flat(rss_flat, heap_flat) && device_flat.value_or(false);
  memory["memory_flat"] = memory_flat;
  report["memory"] = memory;

  Json s;
  s["streams"] = o.storm;
  bool storm_ok = storm_status.ok();
  if (!storm_status.ok()) {
    s["error"] = storm_status.ToString();
  } else if (o.storm > 0) {
    s["streaming_before_cancel"] = storm.streaming_before_cancel;
    s["server_streams_before_cancel"] = storm.server_streams_before_cancel;
    s["cancelled"] = storm.cancelled;
    s["finished"] = storm.finished;
    s["errors"] = storm.errors;
    s["first_errors"] = storm.first_errors;
    s["open_ms"] = storm.open_ms;
    s["closed_ms"] = storm.closed_ms;
    s["drained_ms"] = storm.drained_ms ? Json(*storm.drained_ms) : Json(nullptr);
    storm_ok = storm.errors == 0 && storm.drained_ms.has_value();
  }
  s["server_alive"] = alive;
  s["health"] = health.ok() ? serving_status_name(*health) : health.status().ToString();
  s["render_after"] = fresh.ok() ? "OK" : fresh.ToString();
  const bool healthy =
      alive && health.ok() && *health == client::ServingStatus::kServing && fresh.ok() && storm_ok;
  s["healthy"] = healthy;
  report["storm"] = s;

  if (after.stats) {
    report["server_stats"] = {{"scenes_start", before->scenes()},
                              {"scenes_end", after.stats->scenes()},
                              {"active_streams_end", after.stats->active_streams()},
                              {"requests_served", after.stats->requests_served()},
                              {"frames_served", after.stats->frames_served()},
                              {"memory_peak_bytes", after.stats->memory_peak_bytes()}};
  }
  bool hostile_met = true;
  report["hostile"] =
      o.hostile ? hostile_json(hostile_logs, port_checks, target_deleted, &hostile_met) : nullptr;
  const bool pass = total_errors == 0 && memory_flat && healthy && hostile_met;
  report["pass"] = pass;
  // Error messages may quote what a hostile client sent, which need not be UTF-8.
  out << report.dump(-1, ' ', false, Json::error_handler_t::replace) << "\n";
  out.flush();
  return pass;
}

}  // namespace caustica
