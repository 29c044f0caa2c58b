// What the server's end-to-end tests share: the real caustica-server started as a child process
// on a free port (and stopped with SIGTERM), scenes in their wire form, uploads, frames and the
// PFM files caustica-render writes.
#pragma once

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "caustica/v1/render_service.grpc.pb.h"
#include "renderer/scene/scene.h"
#include "tests/client/client_run.h"

namespace caustica::testing {

// One caustica-server process in its own temporary directory.
class ServerProcess {
 public:
  // Starts the server with `--listen 127.0.0.1:0 --port-file ...` and `extra_args`, and waits
  // until it listens. Fails the test (returns null) when it does not. A --listen in `extra_args`
  // replaces the loopback one (the address() and channel() stay on 127.0.0.1). channel()
  // connects with `credentials`; null: plaintext.
  static std::unique_ptr<ServerProcess> start(
      const std::vector<std::string>& extra_args = {},
      std::shared_ptr<grpc::ChannelCredentials> credentials = nullptr);
  ~ServerProcess();

  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  // Resident memory (VmRSS) of the running server; 0 once it is gone.
  uint64_t resident_bytes() const;
  // The port of a log line "... <what> on port N", e.g. "metrics"; 0 when the log has none.
  int logged_port(const std::string& what) const;
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  std::shared_ptr<grpc::Channel> channel() const { return channel_; }
  std::unique_ptr<v1::RenderService::Stub> stub() const;
  const std::filesystem::path& dir() const { return dir_; }

  // Sends SIGTERM and waits (at most `timeout_s`); the exit code (128 + signal when a signal
  // ended it), or -1 when it did not exit in time (it is then killed).
  int terminate(double timeout_s = 20);
  // SIGKILL, as a crash or the OOM killer would end it, and waits for it to be gone.
  void kill_now();
  bool running();
  // What the server wrote to stderr so far.
  std::string log() const;

 private:
  ServerProcess() = default;
  pid_t pid_ = -1;
  int exit_code_ = 0;  // once it exited: its exit status, 128 + signal when a signal ended it
  int port_ = 0;
  std::filesystem::path dir_;
  std::shared_ptr<grpc::Channel> channel_;
};

// A fresh server per test (gtest_discover_tests runs every case in its own process anyway).
class ServerTest : public ::testing::Test {
 protected:
  // Flags beyond --listen and --port-file.
  virtual std::vector<std::string> server_args() const { return {}; }
  void SetUp() override {
    server_ = ServerProcess::start(server_args());
    ASSERT_NE(server_, nullptr);
    stub_ = server_->stub();
  }

  std::unique_ptr<ServerProcess> server_;
  std::unique_ptr<v1::RenderService::Stub> stub_;
};

// Gives a call `seconds` to finish, so a hung server fails the test instead of stalling it.
void set_deadline(grpc::ClientContext& context, double seconds = 60);

// The bundled Cornell box at a test-sized resolution and photon count.
// A scene file at a test-sized resolution, photon count, k and seed.
Scene small_scene_from(const std::filesystem::path& file, int width, int height, uint32_t photons,
                       uint32_t k, uint32_t seed);
Scene cornell_box(int width, int height, uint32_t photons, uint32_t k, uint32_t seed);

// The UploadScene stream of `scene`: the header, then its mesh chunks.
std::vector<v1::SceneChunk> scene_chunks(const Scene& scene, const std::string& name,
                                         size_t max_chunk_bytes = size_t{1} << 20);
// Streams `chunks` and finishes the call.
grpc::Status upload(v1::RenderService::Stub& stub, const std::vector<v1::SceneChunk>& chunks,
                    v1::SceneInfo* info);
// Uploads `scene`, failing the test unless it succeeds; returns the scene id.
std::string upload_scene(v1::RenderService::Stub& stub, const Scene& scene,
                         const std::string& name = "test");

v1::FrameFormat frame_format(v1::PixelFormat pixel_format, v1::Encoding encoding = v1::RAW);
grpc::Status render_frame(v1::RenderService::Stub& stub, const std::string& scene_id,
                          uint32_t target_passes, const v1::FrameFormat& format, v1::Frame* frame);
// RGBA32F RAW pixels of a frame (or of reassembled frame bytes).
std::vector<float> frame_floats(const std::string& data);
inline std::vector<float> frame_floats(const v1::Frame& frame) {
  return frame_floats(frame.data());
}
// Mean of the RGB channels of RGBA floats.
double mean_rgb(const std::vector<float>& rgba);
// A point light in the Cornell box's upper middle.
v1::Light point_light(float intensity);

// A whole frame reassembled from its pieces.
struct StreamedFrame {
  v1::Frame header;  // the first piece, without data
  std::string data;
  int pieces = 0;
};
// Reads a StreamFrames/PlayAnimation reply into whole frames, checking that the pieces of each
// frame are consecutive and complete.
std::vector<StreamedFrame> read_frames(grpc::ClientReader<v1::Frame>& reader);

// Whole calls of the two frame streams, with a deadline; `frames` gets what arrived.
grpc::Status stream_frames(v1::RenderService::Stub& stub, const v1::StreamFramesRequest& request,
                           std::vector<StreamedFrame>* frames);
grpc::Status play_animation(v1::RenderService::Stub& stub, const v1::PlayAnimationRequest& request,
                            std::vector<StreamedFrame>* frames);
// GetScene of a scene that must exist.
v1::SceneInfo get_scene(v1::RenderService::Stub& stub, const std::string& scene_id);
// DeleteScene of a scene that must exist.
void delete_scene(v1::RenderService::Stub& stub, const std::string& scene_id);
// GetScene's status alone.
grpc::Status get_scene_status(v1::RenderService::Stub& stub, const std::string& scene_id);
// ListScenes, which must succeed.
std::vector<v1::SceneInfo> list_scenes(v1::RenderService::Stub& stub);
// UpdateLights with `request`, its status (the report in `report`).
grpc::Status call_update_lights(v1::RenderService::Stub& stub,
                                const v1::UpdateLightsRequest& request, v1::RebuildReport* report);
// UpdateLights to one point_light(intensity), which must succeed; its report.
v1::RebuildReport update_lights(v1::RenderService::Stub& stub, const std::string& scene_id,
                                float intensity);

// run_command and CommandRun: tests/client/client_run.h.

// grpc.health.v1.Health/Check of the whole server.
bool health_serving(const std::shared_ptr<grpc::Channel>& channel);
// RGBA32F linear pixels of a RenderFrame of `passes` passes of scene `id`, which must succeed.
std::vector<float> render_linear(v1::RenderService::Stub& stub, const std::string& id,
                                 uint32_t passes);
// A server on `data_dir` (--data-dir) with `extra` flags, waited for until it has restored its
// scenes and turned SERVING; null, with the test failed, when it does not within a minute.
std::unique_ptr<ServerProcess> start_restored_server(const std::filesystem::path& data_dir,
                                                     const std::vector<std::string>& extra = {});
// Health check, then a small render of a fresh upload: what "the server survived" means.
void expect_server_healthy(ServerProcess& server);

// A PFM file as written by caustica-render: RGB floats, rows top first after reading.
struct PfmImage {
  int width = 0, height = 0;
  std::vector<float> rgb;
};
PfmImage read_pfm(const std::filesystem::path& path);

// Path of a fresh temporary directory, removed by the OS's tmp cleaning (tests keep it for
// inspection on failure).
std::filesystem::path make_temp_dir(const std::string& prefix);

// PEM files for TLS tests: a CA, a server certificate for 127.0.0.1 and localhost, and a client
// certificate, both signed by the CA, each with its key.
struct TestCertificates {
  std::filesystem::path ca;
  std::filesystem::path server_cert, server_key;
  std::filesystem::path client_cert, client_key;
};
// Makes them in `dir` with the openssl command-line tool, valid for two days from now. Fails the
// test (returns nullopt) when openssl fails.
std::optional<TestCertificates> make_test_certificates(const std::filesystem::path& dir);
// A file's contents ("" when it cannot be read).
std::string read_text_file(const std::filesystem::path& path);

}  // namespace caustica::testing
