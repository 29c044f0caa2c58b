#include "bench/viewer_drag.h"

#include <arpa/inet.h>
#include <civetweb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdlib.h>
#include <sys/socket.h>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "bench/measure.h"
#include "bench/serving.h"
#include "client/connection.h"
#include "client/embedded_server.h"
#include "client/scene_upload.h"

namespace caustica {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

// Longest wait for any one message; a pass of a large scene on the CPU takes seconds.
constexpr std::chrono::seconds kWaitLimit{120};
// Image-plane step of one move: one pointer move of a slow drag.
constexpr double kDragStep = 0.02;
// The pass target the scene is opened with: each move's first frame completes the picture, so
// that the next move finds the stream idle rather than behind a pass of the previous position.
constexpr int kPasses = 1;

double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// Turns Nagle's algorithm off on this process's socket to 127.0.0.1:`port`. civetweb's client
// writes a WebSocket message as two segments (header, then payload), and with Nagle on the payload
// waits for the server's delayed acknowledgement of the header; browsers send without that delay.
bool set_no_delay_to(int port) {
  bool found = false;
  for (int fd = 0; fd < 4096; ++fd) {
    sockaddr_in peer{};
    socklen_t length = sizeof peer;
    if (getpeername(fd, reinterpret_cast<sockaddr*>(&peer), &length) != 0) continue;
    if (peer.sin_family != AF_INET || ntohs(peer.sin_port) != port ||
        peer.sin_addr.s_addr != htonl(INADDR_LOOPBACK)) {
      continue;
    }
    const int on = 1;
    found = setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on) == 0 || found;
  }
  return found;
}

// A message from the server, stamped on arrival.
struct Incoming {
  Clock::time_point at;
  bool binary = false;
  json message;            // a text message, or a frame's header
  size_t image_bytes = 0;  // a frame's image file, after the header
};

// The page's end of the viewer's WebSocket, without the drawing: JSON requests out; JSON
// messages and binary frames in, queued with the time they arrived on civetweb's client thread.
class ViewerSocket {
 public:
  static absl::StatusOr<std::unique_ptr<ViewerSocket>> connect(int port) {
    static std::once_flag initialised;
    std::call_once(initialised, [] { mg_init_library(MG_FEATURES_WEBSOCKET); });
    std::unique_ptr<ViewerSocket> socket(new ViewerSocket());
    char error[256] = "";
    // No Origin header: the server admits clients that are not browsers, as it admits gRPC ones.
    socket->connection_ =
        mg_connect_websocket_client("127.0.0.1", port, 0, error, sizeof error, "/ws", nullptr,
                                    &ViewerSocket::on_data, &ViewerSocket::on_close, socket.get());
    if (socket->connection_ == nullptr) {
      return absl::UnavailableError(
          absl::StrCat("viewer WebSocket ws://127.0.0.1:", port, "/ws refused: ", error));
    }
    if (!set_no_delay_to(port)) {
      return absl::InternalError(absl::StrCat("viewer WebSocket: no socket to 127.0.0.1:", port,
                                              " to turn Nagle's algorithm off on"));
    }
    return socket;
  }

  ~ViewerSocket() {
    if (connection_ == nullptr) return;
    // A close frame first, so that the server ends the socket and civetweb's client thread
    // returns at once instead of at its next receive timeout.
    const char normal_closure[2] = {0x03, static_cast<char>(0xe8)};
    mg_websocket_client_write(connection_, MG_WEBSOCKET_OPCODE_CONNECTION_CLOSE, normal_closure,
                              sizeof normal_closure);
    {
      std::unique_lock lock(mutex_);
      arrived_.wait_for(lock, std::chrono::seconds(5), [&] { return closed_; });
    }
    mg_close_connection(connection_);
  }

  // Sends `message` with the next "id", which it returns.
  absl::StatusOr<int64_t> send(json message) {
    const int64_t id = next_id_++;
    message["id"] = id;
    const std::string text = message.dump();
    if (mg_websocket_client_write(connection_, MG_WEBSOCKET_OPCODE_TEXT, text.data(),
                                  text.size()) <= 0) {
      return absl::UnavailableError(
          absl::StrCat("viewer WebSocket: cannot send ", message.value("type", "?")));
    }
    return id;
  }

  // The next message; DEADLINE_EXCEEDED naming `waiting_for` when none comes in time.
  absl::StatusOr<Incoming> next(Clock::time_point deadline, const std::string& waiting_for) {
    std::unique_lock lock(mutex_);
    arrived_.wait_until(lock, deadline,
                        [&] { return !queue_.empty() || closed_ || !problem_.empty(); });
    if (!problem_.empty()) return absl::DataLossError(problem_);
    if (!queue_.empty()) {
      Incoming incoming = std::move(queue_.front());
      queue_.pop_front();
      return incoming;
    }
    if (closed_) {
      return absl::UnavailableError(
          absl::StrCat("the server closed the viewer WebSocket while waiting for ", waiting_for));
    }
    return absl::DeadlineExceededError(
        absl::StrCat("timed out after ", kWaitLimit.count(), " s waiting for ", waiting_for));
  }

 private:
  ViewerSocket() = default;

  static int on_data(mg_connection*, int bits, char* data, size_t size, void* user) {
    auto* self = static_cast<ViewerSocket*>(user);
    Incoming incoming;
    incoming.at = Clock::now();
    std::string problem;
    switch (bits & 0x0f) {
      case MG_WEBSOCKET_OPCODE_TEXT:
        incoming.message = json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
        if (incoming.message.is_discarded()) problem = "a text message that is not JSON";
        break;
      case MG_WEBSOCKET_OPCODE_BINARY: {
        incoming.binary = true;
        // A little-endian u32 header length, the JSON header, the image file.
        uint32_t length = 0;
        for (size_t i = 0; i < 4 && i < size; ++i) {
          length |= uint32_t(static_cast<unsigned char>(data[i])) << (8 * i);
        }
        if (size < 4 || size - 4 < length) {
          problem = absl::StrCat("a binary message of ", size, " bytes with a header of ", length);
          break;
        }
        incoming.message =
            json::parse(data + 4, data + 4 + length, nullptr, /*allow_exceptions=*/false);
        incoming.image_bytes = size - 4 - length;
        if (!incoming.message.is_object()) problem = "a frame whose header is not a JSON object";
        break;
      }
      case MG_WEBSOCKET_OPCODE_CONNECTION_CLOSE:
        return 0;
      default:  // pings and pongs
        return 1;
    }
    {
      std::lock_guard lock(self->mutex_);
      if (!problem.empty()) {
        if (self->problem_.empty()) self->problem_ = "viewer WebSocket: the server sent " + problem;
      } else {
        self->queue_.push_back(std::move(incoming));
      }
    }
    self->arrived_.notify_all();
    return 1;
  }

  static void on_close(const mg_connection*, void* user) {
    auto* self = static_cast<ViewerSocket*>(user);
    {
      std::lock_guard lock(self->mutex_);
      self->closed_ = true;
    }
    self->arrived_.notify_all();
  }

  mg_connection* connection_ = nullptr;
  int64_t next_id_ = 1;
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::deque<Incoming> queue_;
  bool closed_ = false;
  std::string problem_;
};

// The viewer's {"type":"error"} as a status of the code it names.
absl::Status viewer_error(const json& message, const std::string& during) {
  const std::string code = message.value("code", "UNKNOWN");
  absl::StatusCode status_code = absl::StatusCode::kUnknown;
  for (int c = 0; c <= static_cast<int>(absl::StatusCode::kUnauthenticated); ++c) {
    if (absl::StatusCodeToString(static_cast<absl::StatusCode>(c)) == code) {
      status_code = static_cast<absl::StatusCode>(c);
    }
  }
  return absl::Status(status_code, absl::StrCat("viewer, ", during, ": ", code, ": ",
                                                message.value("message", "")));
}

// The next text message of `type` (with `id`, where given), skipping frames and other messages;
// an error message is returned as its status.
absl::StatusOr<json> wait_for_text(ViewerSocket& socket, const std::string& type,
                                   std::optional<int64_t> id, const std::string& during) {
  const Clock::time_point deadline = Clock::now() + kWaitLimit;
  const std::string waiting_for = absl::StrCat("the '", type, "' message after ", during);
  while (true) {
    absl::StatusOr<Incoming> incoming = socket.next(deadline, waiting_for);
    if (!incoming.ok()) return incoming.status();
    if (incoming->binary) continue;
    const json& message = incoming->message;
    const std::string got = message.value("type", "");
    if (got == "error") return viewer_error(message, during);
    if (got == type && (!id || message.value("id", int64_t{-1}) == *id)) return message;
  }
}

// Frames until the stream reports the pass target reached ('idle'); returns how many came.
absl::StatusOr<int> wait_until_idle(ViewerSocket& socket, const std::string& during) {
  const Clock::time_point deadline = Clock::now() + kWaitLimit;
  int frames = 0;
  while (true) {
    absl::StatusOr<Incoming> incoming = socket.next(
        deadline,
        absl::StrCat("the 'idle' message after ", during, " (", frames, " frames since)"));
    if (!incoming.ok()) return incoming.status();
    if (incoming->binary) {
      ++frames;
      continue;
    }
    const std::string type = incoming->message.value("type", "");
    if (type == "error") return viewer_error(incoming->message, during);
    if (type == "idle") return frames;
  }
}

// The light a drag moves: the first the page shows a handle for (draggable, in front of the
// camera, with an image position).
absl::StatusOr<json> draggable_light(const json& scene_message) {
  for (const json& light : scene_message.value("lights", json::array())) {
    if (light.value("draggable", false) && light.value("visible", false) && light.contains("u") &&
        light.contains("v")) {
      return light;
    }
  }
  return absl::FailedPreconditionError(
      absl::StrCat("viewer: the scene message lists no light the page could drag (a point or spot "
                   "light in front of the camera): ",
                   scene_message.value("lights", json::array()).dump()));
}

// What the page sends when a light's handle is dragged to (u, v).
json move_message(const json& light, double u, double v) {
  return {{"type", "move_light"}, {"light", light.at("index")}, {"u", u}, {"v", v}};
}

double timing(const json& message, const char* name) {
  const json timings = message.value("timings", json::object());
  return timings.contains(name) && timings.at(name).is_number() ? timings.at(name).get<double>()
                                                                : 0.0;
}

uint64_t lights_epoch(const json& message) {
  return message.value("epochs", json::object()).value("lights", uint64_t{0});
}

// One drag step, as the page measures it: from sending the move to the first frame whose lights
// epoch is at least the one the `updated` reply names (frames may come before the reply).
struct DragSample {
  double total_ms;
  json updated;  // the reply: epochs and the rebuild's timings
  Incoming frame;
};

absl::StatusOr<DragSample> drag_step(ViewerSocket& socket, const json& move) {
  const Clock::time_point sent = Clock::now();
  absl::StatusOr<int64_t> id = socket.send(move);
  if (!id.ok()) return id.status();
  const Clock::time_point deadline = sent + kWaitLimit;
  std::optional<json> updated;
  std::vector<Incoming> frames;
  while (true) {
    if (updated) {
      const uint64_t target = lights_epoch(*updated);
      for (Incoming& frame : frames) {
        if (lights_epoch(frame.message) >= target) {
          return DragSample{ms_between(sent, frame.at), *std::move(updated), std::move(frame)};
        }
      }
    }
    const std::string waiting_for =
        updated ? absl::StrCat("the first frame of lights epoch ", lights_epoch(*updated), " (",
                               frames.size(), " frames since the move",
                               frames.empty() ? std::string()
                                              : absl::StrCat(", the last of lights epoch ",
                                                             lights_epoch(frames.back().message)),
                               ")")
                : absl::StrCat("the 'updated' reply to move_light id ", *id);
    absl::StatusOr<Incoming> incoming = socket.next(deadline, waiting_for);
    if (!incoming.ok()) return incoming.status();
    if (incoming->binary) {
      frames.push_back(*std::move(incoming));
      continue;
    }
    const json& message = incoming->message;
    const std::string type = message.value("type", "");
    if (type == "error") return viewer_error(message, "move_light");
    if (type == "lights") {
      return absl::AbortedError(
          "viewer: another client changed the scene's lights during the benchmark");
    }
    if (type == "updated" && message.value("id", int64_t{-1}) == *id) updated = message;
  }
}

// A private directory for the port file, removed with it.
class TemporaryDirectory {
 public:
  static absl::StatusOr<TemporaryDirectory> create() {
    std::string pattern =
        (std::filesystem::temp_directory_path() / "caustica-viewer-drag-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) {
      return absl::InternalError(absl::StrCat("cannot create a directory like ", pattern));
    }
    return TemporaryDirectory(pattern);
  }
  TemporaryDirectory(TemporaryDirectory&& other) noexcept : path_(std::exchange(other.path_, {})) {}
  ~TemporaryDirectory() {
    std::error_code ignored;
    if (!path_.empty()) std::filesystem::remove_all(path_, ignored);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  explicit TemporaryDirectory(std::filesystem::path path) : path_(std::move(path)) {}
  std::filesystem::path path_;
};

absl::Status delete_scene(client::Connection& connection, const std::string& id) {
  v1::DeleteSceneRequest request;
  request.set_scene_id(id);
  return connection.call(&v1::RenderService::Stub::DeleteScene, request).status();
}

}  // namespace

absl::Status run_viewer_drag_benchmark(const BenchOptions& o, Reporter& bench_report) {
  if (o.photon_scene.empty()) {
    // Named explicitly, it needs a scene; in a run of everything it is skipped like the other
    // scene benchmarks.
    if (o.only.empty()) return absl::OkStatus();
    return absl::InvalidArgumentError("viewer_drag needs --scene");
  }
  absl::StatusOr<TemporaryDirectory> dir = TemporaryDirectory::create();
  if (!dir.ok()) return dir.status();
  const std::filesystem::path port_file = dir->path() / "http-port";
  absl::StatusOr<std::unique_ptr<client::EmbeddedServer>> server = client::EmbeddedServer::start(
      {.data_dir = std::filesystem::path(),
       .extra_args = {"--device", o.device, "--log-level", "warning", "--http-listen",
                      "127.0.0.1:0", "--http-port-file", port_file.string()}});
  if (!server.ok()) return server.status();
  // The server writes the viewer's port before its gRPC port, for which start() waited.
  int http_port = 0;
  if (std::ifstream in(port_file); !(in >> http_port) || http_port <= 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("the server did not start the viewer: no port in ", port_file.string(),
                     " (--http-port-file)"));
  }

  client::ConnectOptions connect;
  connect.server = (*server)->address();
  absl::StatusOr<std::unique_ptr<client::Connection>> connection =
      client::Connection::open(connect);
  if (!connection.ok()) return connection.status();
  absl::StatusOr<Reporter> device_report = server_device_reporter(**connection, bench_report);
  if (!device_report.ok()) return device_report.status();
  Reporter& report = *device_report;

  absl::StatusOr<Scene> scene = load_photon_scene(o);
  if (!scene.ok()) return scene.status();
  grpc::ClientContext upload_context;
  absl::StatusOr<v1::SceneInfo> uploaded =
      client::upload_scene((*connection)->stub(), upload_context, *scene, "viewer_drag benchmark");
  if (!uploaded.ok()) return uploaded.status();
  const std::string scene_id = uploaded->scene_id();

  std::vector<double> total, rebuild, render, resolve, encode, queue, other, bytes;
  std::string encoding;
  {
    absl::StatusOr<std::unique_ptr<ViewerSocket>> socket = ViewerSocket::connect(http_port);
    if (!socket.ok()) return socket.status();
    ViewerSocket& ws = **socket;
    if (absl::StatusOr<int64_t> sent = ws.send({{"type", "hello"}, {"token", ""}}); !sent.ok()) {
      return sent.status();
    }
    if (absl::StatusOr<json> scenes = wait_for_text(ws, "scenes", std::nullopt, "hello");
        !scenes.ok()) {
      return scenes.status();
    }
    // As the page opens a scene with ?passes=1.
    absl::StatusOr<int64_t> opened =
        ws.send({{"type", "open"}, {"scene", scene_id}, {"passes", kPasses}});
    if (!opened.ok()) return opened.status();
    absl::StatusOr<json> scene_message = wait_for_text(ws, "scene", *opened, "open");
    if (!scene_message.ok()) return scene_message.status();
    encoding = scene_message->value("encoding", "");
    absl::StatusOr<json> light = draggable_light(*scene_message);
    if (!light.ok()) return light.status();
    absl::StatusOr<int> first_frames = wait_until_idle(ws, "open");
    if (!first_frames.ok()) return first_frames.status();
    if (*first_frames == 0) {
      return absl::DataLossError("viewer: the stream went idle after open without a frame");
    }

    const double u0 = light->at("u").get<double>(), v0 = light->at("v").get<double>();
    for (int i = 0; i < o.warmup + o.runs; ++i) {
      // Back and forth about where the light appeared, so that every move is a change.
      const double u = u0 + (i % 2 == 0 ? kDragStep : -kDragStep);
      absl::StatusOr<DragSample> sample = drag_step(ws, move_message(*light, u, v0));
      if (!sample.ok()) return sample.status();
      if (absl::StatusOr<int> settled = wait_until_idle(ws, "move_light"); !settled.ok()) {
        return settled.status();
      }
      if (i < o.warmup) continue;
      const json& reply = sample->updated;
      const json& frame = sample->frame.message;
      // As update_to_frame counts it: the change's rebuild and the pass's own photons.
      const double rebuild_ms =
          timing(reply, "structure_build_ms") + timing(reply, "photon_trace_ms") +
          timing(reply, "photon_map_build_ms") + timing(frame, "structure_build_ms") +
          timing(frame, "photon_trace_ms") + timing(frame, "photon_map_build_ms");
      const double encode_ms = timing(frame, "encode_ms");  // where the header carries it
      const double resolve_ms = timing(frame, "resolve_ms") - encode_ms;
      const double queue_ms = timing(reply, "queue_ms") + timing(frame, "queue_ms");
      total.push_back(sample->total_ms);
      rebuild.push_back(rebuild_ms);
      render.push_back(timing(frame, "render_ms"));
      resolve.push_back(resolve_ms);
      encode.push_back(encode_ms);
      queue.push_back(queue_ms);
      other.push_back(sample->total_ms - rebuild_ms - render.back() - resolve_ms - encode_ms -
                      queue_ms);
      bytes.push_back(static_cast<double>(sample->frame.image_bytes));
    }
  }

  const std::string name =
      o.photon_scene.parent_path().filename().string() +
      absl::StrFormat(" %dx%d %d photons k=%d %s", o.width, o.height, o.photons, o.k, encoding);
  const Measurement m = summarize(total);
  report.line("viewer_drag", name, m.median, "ms", &m, o.runs);
  report.line("viewer_drag_rebuild", name, summarize(rebuild).median, "ms");
  report.line("viewer_drag_render", name, summarize(render).median, "ms");
  report.line("viewer_drag_resolve", name, summarize(resolve).median, "ms");
  if (summarize(encode).max > 0) {
    report.line("viewer_drag_encode", name, summarize(encode).median, "ms");
  }
  report.line("viewer_drag_queue", name, summarize(queue).median, "ms");
  report.line("viewer_drag_other", name, summarize(other).median, "ms");
  report.line("viewer_drag_bytes", name, summarize(bytes).median, "bytes");
  return delete_scene(**connection, scene_id);
}

}  // namespace caustica
