// One browser viewer over one WebSocket. The session is a gRPC client of this same server through
// its in-process channel and sends the browser's token as `authorization: Bearer <token>`, so
// tokens, tenants and their limits apply exactly as to any other client. Control messages run on
// the connection's thread; frames are pushed from a stream thread that keeps one StreamFrames
// call open while the picture refines and opens the next one after a change.
#pragma once

#include <grpcpp/grpcpp.h>

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "caustica/v1/render_service.grpc.pb.h"
#include "server/viewer/viewer_protocol.h"

namespace caustica::server::viewer {

// Where a session's messages go: a WebSocket, or a recording in tests. Called from the
// connection's thread and the stream thread; implementations serialise the two.
class ViewerSink {
 public:
  virtual ~ViewerSink() = default;
  virtual void send_text(const std::string& text) = 0;
  virtual void send_binary(const std::string& bytes) = 0;
};

struct ViewerOptions {
  // Passes a picture refines to when the page does not ask for a number.
  uint32_t default_passes = 32;
  v1::Encoding encoding = preferred_frame_encoding();
  // JPEG frames as this many strips when the page does not ask (open's "strips"): the server
  // encodes them and the browser decodes them in parallel rather than one whole image at a time.
  uint32_t jpeg_strips = 4;
  double call_timeout_s = 60;
  // While the picture is finished, how often the session checks for changes by other clients.
  double idle_poll_s = 1;
  // Frame bytes per StreamFrames message: well under the in-process channel's default receive
  // limit (4 MiB); the session reassembles the pieces.
  uint32_t stream_chunk_bytes = 1 << 20;
};

class ViewerSession {
 public:
  ViewerSession(std::shared_ptr<grpc::Channel> channel, ViewerSink& sink,
                ViewerOptions options = {});
  ~ViewerSession();
  ViewerSession(const ViewerSession&) = delete;
  ViewerSession& operator=(const ViewerSession&) = delete;

  // One text message from the browser; every failure is answered with an error message.
  void handle_text(std::string_view text);
  // Binary messages go only from the server to the browser.
  void handle_binary();
  // Ends the frame stream and waits for its thread; nothing is sent afterwards.
  void close();

 private:
  absl::Status handle(const ViewerRequest& request);
  absl::Status hello(const ViewerRequest& request);
  absl::Status list(const ViewerRequest& request);
  absl::Status open(const ViewerRequest& request);
  // move_light, set_intensity and set_emitter: one UpdateLights each.
  absl::Status change_lights(const ViewerRequest& request);
  absl::Status change_camera(const ViewerRequest& request);
  // Reloads the lights after another client changed them under this page, and tells the page.
  void reload_lights();
  // A context carrying the token and a deadline (none when `timeout_s` is 0).
  std::unique_ptr<grpc::ClientContext> make_context(double timeout_s) const;
  // The light the viewer offers when the scene has no point or spot light to drag: a point light
  // in the upper middle of the picture.
  v1::Light placed_light() const;
  void send(const nlohmann::json& message);
  // The `updated` reply to a change: what changed, its epochs and timings, and the lights now.
  void send_updated(const char* what, const v1::RebuildReport& report,
                    const ViewerRequest& request);

  void start_stream(const std::string& scene_id, uint32_t passes, uint32_t strips);
  void stop_stream();
  void wake_stream();
  void stream_loop(std::string scene_id, uint32_t passes, uint32_t strips);
  // One StreamFrames call (JPEG frames in `strips` strips); its status. `epochs` and `passes` get
  // those of the last frame.
  grpc::Status stream_once(const std::string& scene_id, uint32_t passes, uint32_t strips,
                           v1::Epochs* epochs, uint32_t* last_passes);
  // Waits until woken, closed or `timeout_s` passed (0: no timeout); whether it was woken.
  bool wait_for_wake(double timeout_s);

  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::RenderService::Stub> stub_;
  ViewerSink& sink_;
  const ViewerOptions options_;

  // Touched by the connection's thread only.
  bool greeted_ = false;
  std::string scene_id_;
  v1::SceneInfo info_;
  v1::Camera camera_;
  double pivot_distance_ = 1;  // how far ahead of the camera orbit and zoom turn about
  SceneLights lights_;

  // Shared with the stream thread.
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::string token_;
  bool woken_ = false;
  bool stream_stop_ = false;  // the stream thread should return
  bool closed_ = false;
  std::shared_ptr<grpc::ClientContext> stream_context_;
  std::thread stream_thread_;
};

}  // namespace caustica::server::viewer
