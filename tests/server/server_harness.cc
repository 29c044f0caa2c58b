#include "tests/server/server_harness.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

#include "absl/strings/str_cat.h"
#include "client/health_check.h"
#include "client/subprocess.h"
#include "proto/wire/scene_wire.h"
#include "renderer/scene/load_scene.h"

namespace caustica::testing {
namespace {

using std::chrono::steady_clock;

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

std::filesystem::path make_temp_dir(const std::string& prefix) {
  const std::string pattern =
      (std::filesystem::temp_directory_path() / (prefix + "-XXXXXX")).string();
  std::vector<char> name(pattern.begin(), pattern.end());
  name.push_back('\0');
  if (mkdtemp(name.data()) == nullptr) ADD_FAILURE() << "mkdtemp failed: " << std::strerror(errno);
  return std::filesystem::path(name.data());
}

std::unique_ptr<ServerProcess> ServerProcess::start(
    const std::vector<std::string>& extra_args,
    std::shared_ptr<grpc::ChannelCredentials> credentials) {
  std::unique_ptr<ServerProcess> server(new ServerProcess());
  server->dir_ = make_temp_dir("caustica-server-test");
  const std::filesystem::path port_file = server->dir_ / "port";
  std::vector<std::string> args = {CAUSTICA_SERVER_BIN, "--port-file", port_file.string()};
  if (std::find(extra_args.begin(), extra_args.end(), "--listen") == extra_args.end()) {
    args.insert(args.end(), {"--listen", "127.0.0.1:0"});
  }
  args.insert(args.end(), extra_args.begin(), extra_args.end());
  // CAUSTICA_TEST_DEVICE=cuda runs the whole suite against a server on the GPU.
  if (const char* device = std::getenv("CAUSTICA_TEST_DEVICE");
      device != nullptr && *device != '\0') {
    args.push_back("--device");
    args.push_back(device);
  }
  absl::StatusOr<pid_t> pid = client::spawn_process(args, server->dir_ / "server.log");
  if (!pid.ok()) {
    ADD_FAILURE() << "could not start caustica-server: " << pid.status();
    return nullptr;
  }
  server->pid_ = *pid;
  const auto give_up = steady_clock::now() + std::chrono::seconds(30);
  while (server->port_ == 0) {
    if (std::filesystem::exists(port_file)) {
      server->port_ = std::atoi(read_file(port_file).c_str());
      break;
    }
    if (!server->running() || steady_clock::now() > give_up) {
      ADD_FAILURE() << "caustica-server did not start; its log:\n" << server->log();
      return nullptr;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  grpc::ChannelArguments channel_args;
  channel_args.SetMaxReceiveMessageSize(256 << 20);
  if (credentials == nullptr) credentials = grpc::InsecureChannelCredentials();
  server->channel_ = grpc::CreateCustomChannel(server->address(), credentials, channel_args);
  return server;
}

std::string read_text_file(const std::filesystem::path& path) { return read_file(path); }

std::optional<TestCertificates> make_test_certificates(const std::filesystem::path& dir) {
  // One configuration for the CA and the extensions of the two leaf certificates; gRPC checks
  // the server certificate's subjectAltName against the address the client dials.
  {
    std::ofstream config(dir / "openssl.cnf");
    config << "[req]\ndistinguished_name = dn\nprompt = no\n"
              "[dn]\nCN = caustica test CA\n"
              "[ca]\nbasicConstraints = critical,CA:TRUE\n"
              "keyUsage = critical,keyCertSign,cRLSign\nsubjectKeyIdentifier = hash\n"
              "[server]\nbasicConstraints = CA:FALSE\nextendedKeyUsage = serverAuth\n"
              "subjectAltName = IP:127.0.0.1,DNS:localhost\n"
              "[client]\nbasicConstraints = CA:FALSE\nextendedKeyUsage = clientAuth\n";
  }
  const std::string new_key = "-newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes";
  const auto leaf = [&](const std::string& name, const std::string& subject, int serial) {
    return absl::StrCat("openssl req -new ", new_key, " -keyout ", name, ".key -out ", name,
                        ".csr -subj ", subject, " && openssl x509 -req -in ", name,
                        ".csr -CA ca.pem -CAkey ca.key -set_serial ", serial,
                        " -days 2 -extfile openssl.cnf -extensions ", name, " -out ", name, ".pem");
  };
  const std::string command = absl::StrCat(
      "{ cd '", dir.string(), "' && openssl req -x509 -config openssl.cnf -extensions ca ", new_key,
      " -keyout ca.key -out ca.pem -days 2 && ", leaf("server", "/CN=localhost", 2), " && ",
      leaf("client", "/CN=caustica-test-client", 3), "; } 2>&1");
  std::string output;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) {
    ADD_FAILURE() << "cannot run openssl";
    return std::nullopt;
  }
  char buffer[4096];
  for (size_t n; (n = fread(buffer, 1, sizeof(buffer), pipe)) > 0;) output.append(buffer, n);
  const int status = pclose(pipe);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    ADD_FAILURE() << "openssl failed making test certificates:\n" << output;
    return std::nullopt;
  }
  return TestCertificates{dir / "ca.pem", dir / "server.pem", dir / "server.key",
                          dir / "client.pem", dir / "client.key"};
}

ServerProcess::~ServerProcess() {
  // Every test ends with a clean shutdown: exit code 0 (a sanitizer finding would change it).
  if (pid_ > 0 && running()) {
    EXPECT_EQ(terminate(), 0) << log();
  }
  // Kept for inspection when the test failed.
  if (!::testing::Test::HasFailure()) {
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  } else {
    std::fprintf(stderr, "server files kept in %s\n", dir_.c_str());
  }
}

std::unique_ptr<v1::RenderService::Stub> ServerProcess::stub() const {
  return v1::RenderService::NewStub(channel_);
}

uint64_t ServerProcess::resident_bytes() const {
  std::ifstream status("/proc/" + std::to_string(pid_) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.starts_with("VmRSS:")) return std::stoull(line.substr(6)) * 1024;  // "  123 kB"
  }
  return 0;
}

int ServerProcess::logged_port(const std::string& what) const {
  std::smatch match;
  const std::string text = log();
  if (!std::regex_search(text, match, std::regex(what + " on port ([0-9]+)"))) return 0;
  return std::stoi(match[1]);
}

bool ServerProcess::running() {
  if (pid_ <= 0) return false;
  if (std::optional<int> status = client::poll_exit(pid_)) {
    exit_code_ = *status;
    pid_ = -1;
    return false;
  }
  return true;
}

int ServerProcess::terminate(double timeout_s) {
  if (running()) kill(pid_, SIGTERM);
  const auto give_up = steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (running()) {
    if (steady_clock::now() > give_up) {
      client::terminate_process(pid_, std::chrono::milliseconds(0));
      pid_ = -1;
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return exit_code_;
}

void ServerProcess::kill_now() {
  if (!running()) return;
  kill(pid_, SIGKILL);
  while (running()) std::this_thread::sleep_for(std::chrono::milliseconds(5));
}

std::string ServerProcess::log() const { return read_file(dir_ / "server.log"); }

Scene cornell_box(int width, int height, uint32_t photons, uint32_t k, uint32_t seed) {
  return small_scene_from(std::filesystem::path(CAUSTICA_SCENES_DIR) / "cornell-box" / "scene.json",
                          width, height, photons, k, seed);
}

Scene small_scene_from(const std::filesystem::path& file, int width, int height, uint32_t photons,
                       uint32_t k, uint32_t seed) {
  absl::StatusOr<Scene> scene = load_scene(file);
  EXPECT_TRUE(scene.ok()) << scene.status();
  if (!scene.ok()) return Scene{};
  scene->camera.width = width;
  scene->camera.height = height;
  scene->settings.photons_per_pass = photons;
  scene->settings.k_nearest = k;
  scene->settings.seed = seed;
  return *std::move(scene);
}

std::vector<v1::SceneChunk> scene_chunks(const Scene& scene, const std::string& name,
                                         size_t max_chunk_bytes) {
  std::vector<v1::SceneChunk> chunks(1);
  *chunks[0].mutable_header() = wire::encode_scene_header(scene, name);
  wire::for_each_chunk(scene, max_chunk_bytes, [&](v1::SceneChunk& chunk) {
    chunks.push_back(chunk);
    return true;
  });
  return chunks;
}

void set_deadline(grpc::ClientContext& context, double seconds) {
  context.set_deadline(std::chrono::system_clock::now() +
                       std::chrono::milliseconds(static_cast<int64_t>(seconds * 1000)));
}

grpc::Status upload(v1::RenderService::Stub& stub, const std::vector<v1::SceneChunk>& chunks,
                    v1::SceneInfo* info) {
  grpc::ClientContext context;
  set_deadline(context);
  std::unique_ptr<grpc::ClientWriter<v1::SceneChunk>> writer = stub.UploadScene(&context, info);
  for (const v1::SceneChunk& chunk : chunks) {
    if (!writer->Write(chunk)) break;  // the server already answered; Finish() says why
  }
  writer->WritesDone();
  return writer->Finish();
}

std::string upload_scene(v1::RenderService::Stub& stub, const Scene& scene,
                         const std::string& name) {
  v1::SceneInfo info;
  const grpc::Status status = upload(stub, scene_chunks(scene, name), &info);
  EXPECT_TRUE(status.ok()) << status.error_code() << ": " << status.error_message();
  return info.scene_id();
}

v1::FrameFormat frame_format(v1::PixelFormat pixel_format, v1::Encoding encoding) {
  v1::FrameFormat format;
  format.set_pixel_format(pixel_format);
  format.set_encoding(encoding);
  return format;
}

grpc::Status render_frame(v1::RenderService::Stub& stub, const std::string& scene_id,
                          uint32_t target_passes, const v1::FrameFormat& format, v1::Frame* frame) {
  grpc::ClientContext context;
  set_deadline(context);
  v1::RenderFrameRequest request;
  request.set_scene_id(scene_id);
  request.set_target_passes(target_passes);
  *request.mutable_format() = format;
  return stub.RenderFrame(&context, request, frame);
}

std::vector<float> frame_floats(const std::string& data) {
  std::vector<float> pixels(data.size() / sizeof(float));
  std::memcpy(pixels.data(), data.data(), pixels.size() * sizeof(float));
  return pixels;
}

double mean_rgb(const std::vector<float>& rgba) {
  double sum = 0;
  for (size_t i = 0; i < rgba.size(); ++i) {
    if (i % 4 != 3) sum += rgba[i];
  }
  return rgba.empty() ? 0 : sum / (rgba.size() / 4 * 3);
}

v1::Light point_light(float intensity) {
  v1::Light light;
  light.set_name("bulb");
  light.set_type(v1::Light::POINT);
  light.mutable_position()->set_x(278);
  light.mutable_position()->set_y(400);
  light.mutable_position()->set_z(279);
  light.mutable_intensity()->set_x(intensity);
  light.mutable_intensity()->set_y(intensity);
  light.mutable_intensity()->set_z(intensity);
  return light;
}

std::vector<StreamedFrame> read_frames(grpc::ClientReader<v1::Frame>& reader) {
  std::vector<StreamedFrame> frames;
  v1::Frame piece;
  bool open = false;  // a frame has pieces still to come
  while (reader.Read(&piece)) {
    if (!open) {
      StreamedFrame& frame = frames.emplace_back();
      frame.header = piece;
      frame.header.clear_data();
      open = true;
    }
    StreamedFrame& frame = frames.back();
    EXPECT_EQ(piece.frame_number(), frame.header.frame_number());
    EXPECT_EQ(piece.data_offset(), frame.data.size());
    EXPECT_EQ(piece.data_size(), frame.header.data_size());
    frame.data += piece.data();
    ++frame.pieces;
    if (piece.last_chunk()) {
      EXPECT_EQ(frame.data.size(), frame.header.data_size());
      open = false;
    }
  }
  EXPECT_FALSE(open) << "the stream ended inside a frame";
  return frames;
}

namespace {

template <typename Request, typename Start>
grpc::Status read_whole_stream(const Request& request, const Start& start,
                               std::vector<StreamedFrame>* frames) {
  grpc::ClientContext context;
  set_deadline(context, 90);
  std::unique_ptr<grpc::ClientReader<v1::Frame>> reader = start(&context, request);
  *frames = read_frames(*reader);
  return reader->Finish();
}

}  // namespace

grpc::Status stream_frames(v1::RenderService::Stub& stub, const v1::StreamFramesRequest& request,
                           std::vector<StreamedFrame>* frames) {
  return read_whole_stream(
      request, [&](grpc::ClientContext* c, const auto& r) { return stub.StreamFrames(c, r); },
      frames);
}

grpc::Status play_animation(v1::RenderService::Stub& stub, const v1::PlayAnimationRequest& request,
                            std::vector<StreamedFrame>* frames) {
  return read_whole_stream(
      request, [&](grpc::ClientContext* c, const auto& r) { return stub.PlayAnimation(c, r); },
      frames);
}

void delete_scene(v1::RenderService::Stub& stub, const std::string& scene_id) {
  grpc::ClientContext context;
  set_deadline(context);
  v1::DeleteSceneRequest request;
  request.set_scene_id(scene_id);
  v1::DeleteSceneResponse response;
  EXPECT_TRUE(stub.DeleteScene(&context, request, &response).ok());
}

grpc::Status get_scene_status(v1::RenderService::Stub& stub, const std::string& scene_id) {
  grpc::ClientContext context;
  set_deadline(context);
  v1::GetSceneRequest request;
  request.set_scene_id(scene_id);
  v1::SceneInfo info;
  return stub.GetScene(&context, request, &info);
}

std::vector<v1::SceneInfo> list_scenes(v1::RenderService::Stub& stub) {
  grpc::ClientContext context;
  set_deadline(context);
  v1::ListScenesResponse response;
  const grpc::Status status = stub.ListScenes(&context, {}, &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return {response.scenes().begin(), response.scenes().end()};
}

grpc::Status call_update_lights(v1::RenderService::Stub& stub,
                                const v1::UpdateLightsRequest& request, v1::RebuildReport* report) {
  grpc::ClientContext context;
  set_deadline(context);
  return stub.UpdateLights(&context, request, report);
}

v1::RebuildReport update_lights(v1::RenderService::Stub& stub, const std::string& scene_id,
                                float intensity) {
  grpc::ClientContext context;
  set_deadline(context);
  v1::UpdateLightsRequest request;
  request.set_scene_id(scene_id);
  *request.add_lights() = point_light(intensity);
  v1::RebuildReport report;
  const grpc::Status status = stub.UpdateLights(&context, request, &report);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return report;
}

v1::SceneInfo get_scene(v1::RenderService::Stub& stub, const std::string& scene_id) {
  grpc::ClientContext context;
  set_deadline(context);
  v1::GetSceneRequest request;
  request.set_scene_id(scene_id);
  v1::SceneInfo info;
  const grpc::Status status = stub.GetScene(&context, request, &info);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return info;
}

bool health_serving(const std::shared_ptr<grpc::Channel>& channel) {
  absl::StatusOr<client::ServingStatus> status = client::check_health(
      channel, std::chrono::system_clock::now() + std::chrono::seconds(10), false);
  return status.ok() && *status == client::ServingStatus::kServing;
}

std::vector<float> render_linear(v1::RenderService::Stub& stub, const std::string& id,
                                 uint32_t passes) {
  v1::Frame frame;
  const grpc::Status status =
      render_frame(stub, id, passes, frame_format(v1::RGBA32F_LINEAR), &frame);
  EXPECT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(frame.passes(), passes);
  return frame_floats(frame);
}

std::unique_ptr<ServerProcess> start_restored_server(const std::filesystem::path& data_dir,
                                                     const std::vector<std::string>& extra) {
  std::vector<std::string> args = {"--data-dir", data_dir.string()};
  args.insert(args.end(), extra.begin(), extra.end());
  std::unique_ptr<ServerProcess> server = ServerProcess::start(args);
  if (server == nullptr) return nullptr;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!health_serving(server->channel())) {
    if (std::chrono::steady_clock::now() > give_up) {
      ADD_FAILURE() << "the server never turned SERVING; its log:\n" << server->log();
      return nullptr;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return server;
}

void expect_server_healthy(ServerProcess& server) {
  ASSERT_TRUE(server.running()) << server.log();
  EXPECT_TRUE(health_serving(server.channel()));
  auto stub = server.stub();
  const std::string id = upload_scene(*stub, cornell_box(16, 16, 2000, 16, 1), "health");
  v1::Frame frame;
  const grpc::Status status = render_frame(*stub, id, 1, frame_format(v1::RGBA8_SRGB), &frame);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(frame.data().size(), 16u * 16u * 4u);
  EXPECT_EQ(frame.passes(), 1u);
}

PfmImage read_pfm(const std::filesystem::path& path) {
  PfmImage image;
  std::ifstream in(path, std::ios::binary);
  std::string magic;
  double scale = 0;
  in >> magic >> image.width >> image.height >> scale;
  in.get();  // the single whitespace byte before the data
  EXPECT_EQ(magic, "PF");
  EXPECT_LT(scale, 0) << "expected little-endian PFM";
  const size_t row_floats = size_t(image.width) * 3;
  image.rgb.resize(row_floats * image.height);
  // PFM rows run bottom to top.
  for (int y = image.height - 1; y >= 0; --y) {
    in.read(reinterpret_cast<char*>(image.rgb.data() + y * row_floats), row_floats * sizeof(float));
  }
  EXPECT_TRUE(in.good()) << path;
  return image;
}

}  // namespace caustica::testing
