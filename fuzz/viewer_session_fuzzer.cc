// The browser viewer's WebSocket protocol: the input as text messages, one per line, into a
// ViewerSession (server/viewer/viewer_session.h) that is a gRPC client of a real RenderService in
// this process, as each WebSocket of --http-listen is; and the whole input into parse_request and
// the log's printable() directly. Every text the session sends back must be a JSON object with a
// "type", as the page expects.
//
// The service holds one small scene, uploaded once; "@scene" in a message stands for its id,
// which the server chooses at random. A session's changes to the scene (lights, emitters, camera)
// would carry over into later inputs, so the scene is uploaded again after an input that changed
// it, and every input starts from the same state.
#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <oneapi/tbb/global_control.h>
#include <string>
#include <string_view>

#include "caustica/v1/render_service.grpc.pb.h"
#include "proto/wire/scene_wire.h"
#include "renderer/engine.h"
#include "renderer/scene/load_scene.h"
#include "server/auth.h"
#include "server/log.h"
#include "server/render_service.h"
#include "server/viewer/viewer_protocol.h"
#include "server/viewer/viewer_session.h"

namespace {

using caustica::v1::RenderService;

constexpr std::string_view kScenePlaceholder = "@scene";
// Messages past this many are ignored, so that an input of thousands of short lines (each a call
// through the service) stays well inside libFuzzer's timeout.
constexpr size_t kMaxMessages = 64;
constexpr size_t kMemoryBudgetBytes = size_t{256} << 20;

// Aborts like a crash when the session sends the page something it cannot read.
class CheckingSink : public caustica::server::viewer::ViewerSink {
 public:
  void send_text(const std::string& text) override {
    const nlohmann::json message = nlohmann::json::parse(text, nullptr, false);
    if (!message.is_object() || !message.contains("type") || !message["type"].is_string()) {
      std::fprintf(stderr, "the session sent a text that is not a message: %s\n", text.c_str());
      std::abort();
    }
  }
  void send_binary(const std::string&) override {}
};

// The bundled Cornell box, tiny: its area light is an emitter to switch, and without a point or
// spot light the viewer offers its own light to drag. A directional light is one it cannot drag.
caustica::Scene tiny_scene() {
  // $CAUSTICA_SCENES_DIR, where set, for a binary run away from the source tree it was built in.
  const char* scenes = std::getenv("CAUSTICA_SCENES_DIR");
  absl::StatusOr<caustica::Scene> scene =
      caustica::load_scene(std::filesystem::path(scenes != nullptr ? scenes : CAUSTICA_SCENES_DIR) /
                           "cornell-box/scene.json");
  if (!scene.ok()) {
    std::fprintf(stderr, "viewer_session fuzzer: %s\n", scene.status().ToString().c_str());
    std::abort();
  }
  scene->camera.width = 8;
  scene->camera.height = 8;
  scene->settings.photons_per_pass = 200;
  scene->settings.k_nearest = 8;
  scene->lights.push_back(caustica::Light{.name = "sun",
                                          .type = caustica::LightType::kDirectional,
                                          .direction = caustica::Vec3f(0.2f, -1, 0.3f),
                                          .intensity = caustica::Vec3f(0.5f, 0.5f, 0.5f)});
  return *std::move(scene);
}

// A RenderService on the CPU behind a gRPC server without a port, reached through its
// in-process channel, with the scene every input starts from.
class Fixture {
 public:
  Fixture() : scene_(tiny_scene()) {
    absl::StatusOr<std::shared_ptr<caustica::Backend>> backend =
        caustica::make_backend(caustica::DeviceKind::kCpu, kMemoryBudgetBytes);
    if (!backend.ok()) std::abort();
    service_ = std::make_unique<caustica::server::RenderService>(
        std::vector<std::shared_ptr<caustica::Backend>>{*backend},
        caustica::server::ServiceOptions{});
    grpc::ServerBuilder builder;
    builder.RegisterService(service_.get());
    // gRPC sizes the sync server's completion queues and pollers by the machine's cores; with a
    // process per core (scripts/fuzz's FUZZ_JOBS) that is hundreds of threads switching.
    builder.SetSyncServerOption(grpc::ServerBuilder::SyncServerOption::NUM_CQS, 1);
    builder.SetSyncServerOption(grpc::ServerBuilder::SyncServerOption::MIN_POLLERS, 1);
    builder.SetSyncServerOption(grpc::ServerBuilder::SyncServerOption::MAX_POLLERS, 2);
    // Without a token file every caller is the default tenant, but handlers still ask the
    // interceptor for the verdict.
    std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> creators;
    creators.push_back(std::make_unique<caustica::server::AuthInterceptorFactory>(
        std::make_shared<const caustica::server::Authenticator>()));
    builder.experimental().SetInterceptorCreators(std::move(creators));
    server_ = builder.BuildAndStart();
    channel_ = server_->InProcessChannel({});
    stub_ = RenderService::NewStub(channel_);
    upload();
  }

  const std::shared_ptr<grpc::Channel>& channel() const { return channel_; }

  // Ends every call still running (a viewer session's stream ends on the client's side first) and
  // joins the server's threads, so that the leak check at exit sees no call half done.
  void shut_down() {
    stub_.reset();
    channel_.reset();
    server_->Shutdown(std::chrono::system_clock::now());
    server_->Wait();
    server_.reset();
    service_.reset();
  }
  const std::string& scene_id() const { return scene_id_; }

  // Uploads the scene again when the last input changed it (or deleted it).
  void restore_scene() {
    caustica::v1::GetSceneRequest request;
    request.set_scene_id(scene_id_);
    caustica::v1::SceneInfo info;
    grpc::ClientContext context;
    if (stub_->GetScene(&context, request, &info).ok() &&
        info.epochs().SerializeAsString() == epochs_) {
      return;
    }
    caustica::v1::DeleteSceneRequest remove;
    remove.set_scene_id(scene_id_);
    caustica::v1::DeleteSceneResponse removed;
    grpc::ClientContext remove_context;
    (void)stub_->DeleteScene(&remove_context, remove, &removed);
    upload();
  }

 private:
  void upload() {
    caustica::v1::SceneInfo info;
    grpc::ClientContext context;
    std::unique_ptr<grpc::ClientWriter<caustica::v1::SceneChunk>> writer =
        stub_->UploadScene(&context, &info);
    caustica::v1::SceneChunk header;
    *header.mutable_header() = caustica::wire::encode_scene_header(scene_, "fuzz box");
    writer->Write(header);
    caustica::wire::for_each_chunk(
        scene_, caustica::wire::kMaxChunkBytes,
        [&](caustica::v1::SceneChunk& chunk) { return writer->Write(chunk); });
    writer->WritesDone();
    const grpc::Status status = writer->Finish();
    if (!status.ok()) {
      std::fprintf(stderr, "viewer_session fuzzer: upload: %s\n", status.error_message().c_str());
      std::abort();
    }
    scene_id_ = info.scene_id();
    epochs_ = info.epochs().SerializeAsString();
  }

  const caustica::Scene scene_;
  std::unique_ptr<caustica::server::RenderService> service_;
  std::unique_ptr<grpc::Server> server_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<RenderService::Stub> stub_;
  std::string scene_id_;
  std::string epochs_;  // the serialized epochs of the scene as uploaded
};

// Shut down at exit (LLVMFuzzerInitialize) but never destroyed: gRPC's own threads may still run
// while static destructors would.
Fixture* fixture = nullptr;

std::string with_scene_id(std::string_view line, const std::string& scene_id) {
  std::string message;
  size_t at = line.find(kScenePlaceholder);
  while (at != std::string_view::npos) {
    message.append(line.substr(0, at)).append(scene_id);
    line.remove_prefix(at + kScenePlaceholder.size());
    at = line.find(kScenePlaceholder);
  }
  return message.append(line);
}

}  // namespace

// glibc's buffer for a failed dlopen's message, which some library's thread leaves behind now and
// then: a false positive that later LeakSanitizers skip themselves (llvm-project#142876), but not
// clang 14's.
extern "C" const char* __lsan_default_suppressions() { return "leak:_dlerror_run\n"; }

// Each input is a few gRPC calls on several threads, so ASan's defaults (30-frame allocation
// stacks, fresh allocations filled, a 256 MB quarantine cycled through page faults that flush
// every thread's TLB) took most of the time (docs/reliability.md, "Runs"). Errors are still
// caught: stacks are shorter and a freed block is reused sooner. ASAN_OPTIONS overrides.
extern "C" const char* __asan_default_options() {
  return "malloc_context_size=4:max_malloc_fill_size=0:quarantine_size_mb=16";
}

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // A line per call would bury libFuzzer's report and take much of the time.
  caustica::server::set_log_level(caustica::server::LogLevel::kError);
  // scripts/fuzz runs a process per core (FUZZ_JOBS); renders of every process on every core
  // would spend the time switching threads. The CPU backend's results do not depend on it.
  static oneapi::tbb::global_control one_thread(oneapi::tbb::global_control::max_allowed_parallelism,
                                                1);
  fixture = new Fixture();
  // libFuzzer ends with exit(); LeakSanitizer's check runs after this, as its handler was
  // installed first. Without it, calls that were still running on other threads at exit were
  // reported as leaks when 16 processes ended at once.
  std::atexit([] { fixture->shut_down(); });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  (void)caustica::server::viewer::parse_request(input);
  (void)caustica::server::printable(input);

  fixture->restore_scene();
  CheckingSink sink;
  // One pass a picture, and a short idle poll: each input ends in a few milliseconds.
  caustica::server::viewer::ViewerSession session(
      fixture->channel(), sink,
      caustica::server::viewer::ViewerOptions{.default_passes = 1, .idle_poll_s = 0.05});
  std::string_view rest = input;
  for (size_t messages = 0; messages < kMaxMessages && !rest.empty(); ++messages) {
    const size_t end = rest.find('\n');
    session.handle_text(with_scene_id(rest.substr(0, end), fixture->scene_id()));
    rest = end == std::string_view::npos ? std::string_view() : rest.substr(end + 1);
  }
  // Ends the frame stream and joins its thread, so that nothing of this input outlives it.
  session.close();
  return 0;
}
