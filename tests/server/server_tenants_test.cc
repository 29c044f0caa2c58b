// Tenants against the real caustica-server started with --tokens: each tenant sees only its own
// scenes, and the per-tenant limits (scenes, memory share, streams) and the idle TTL hold.
#include <grpcpp/support/client_interceptor.h>
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <thread>

#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

namespace fs = std::filesystem;

constexpr char kStudioToken[] = "studio-token-0123456789abcdef";
constexpr char kLabToken[] = "lab-token-0123456789abcdef0123";

// Adds `authorization: Bearer <token>` to every call of a channel, as a client configured with a
// token does.
class BearerInterceptor : public grpc::experimental::Interceptor {
 public:
  explicit BearerInterceptor(std::string token) : token_(std::move(token)) {}
  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(
            grpc::experimental::InterceptionHookPoints::PRE_SEND_INITIAL_METADATA)) {
      methods->GetSendInitialMetadata()->insert({"authorization", "Bearer " + token_});
    }
    methods->Proceed();
  }

 private:
  std::string token_;
};

class BearerFactory : public grpc::experimental::ClientInterceptorFactoryInterface {
 public:
  explicit BearerFactory(std::string token) : token_(std::move(token)) {}
  grpc::experimental::Interceptor* CreateClientInterceptor(
      grpc::experimental::ClientRpcInfo*) override {
    return new BearerInterceptor(token_);
  }

 private:
  std::string token_;
};

std::unique_ptr<v1::RenderService::Stub> stub_for(const ServerProcess& server,
                                                  const std::string& token) {
  std::vector<std::unique_ptr<grpc::experimental::ClientInterceptorFactoryInterface>> factories;
  factories.push_back(std::make_unique<BearerFactory>(token));
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 << 20);
  return v1::RenderService::NewStub(grpc::experimental::CreateCustomChannelWithInterceptors(
      server.address(), grpc::InsecureChannelCredentials(), args, std::move(factories)));
}

class TenantServer : public ::testing::Test {
 protected:
  void start(std::vector<std::string> extra = {}) {
    dir_ = make_temp_dir("caustica-tenants");
    std::ofstream(dir_ / "tokens.csv") << "# token,tenant\n"
                                       << kStudioToken << ",studio\n"
                                       << kLabToken << ",lab\n";
    std::vector<std::string> args = {"--tokens", (dir_ / "tokens.csv").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    server_ = ServerProcess::start(args);
    ASSERT_NE(server_, nullptr);
    studio_ = stub_for(*server_, kStudioToken);
    lab_ = stub_for(*server_, kLabToken);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }

  fs::path dir_;
  std::unique_ptr<ServerProcess> server_;
  std::unique_ptr<v1::RenderService::Stub> studio_, lab_;
};

Scene small_box(uint32_t seed = 1) { return cornell_box(16, 16, 1000, 8, seed); }

std::vector<std::string> scene_ids(v1::RenderService::Stub& stub) {
  std::vector<std::string> ids;
  for (const v1::SceneInfo& scene : list_scenes(stub)) ids.push_back(scene.scene_id());
  return ids;
}

v1::Stats stats(v1::RenderService::Stub& stub) {
  grpc::ClientContext context;
  set_deadline(context);
  v1::Stats response;
  const grpc::Status status = stub.GetStats(&context, {}, &response);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return response;
}

TEST_F(TenantServer, EachTenantSeesOnlyItsOwnScenes) {
  start();
  const std::string mine = upload_scene(*studio_, small_box(), "studio's");
  const std::string theirs = upload_scene(*lab_, small_box(2), "lab's");
  EXPECT_EQ(scene_ids(*studio_), std::vector<std::string>{mine});
  EXPECT_EQ(scene_ids(*lab_), std::vector<std::string>{theirs});

  // Every call about another tenant's scene is NOT_FOUND, worded as for an unknown id.
  const grpc::Status get = get_scene_status(*lab_, mine);
  EXPECT_EQ(get.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(get.error_message(), "scene_id: no scene '" + mine + "' on this server");
  {
    grpc::ClientContext context;
    set_deadline(context);
    v1::UpdateLightsRequest request;
    request.set_scene_id(mine);
    *request.add_lights() = point_light(2);
    v1::RebuildReport report;
    EXPECT_EQ(lab_->UpdateLights(&context, request, &report).error_code(),
              grpc::StatusCode::NOT_FOUND);
  }
  {
    v1::Frame frame;
    EXPECT_EQ(render_frame(*lab_, mine, 1, frame_format(v1::RGBA8_SRGB), &frame).error_code(),
              grpc::StatusCode::NOT_FOUND);
  }
  {
    grpc::ClientContext context;
    set_deadline(context);
    v1::DeleteSceneRequest request;
    request.set_scene_id(mine);
    v1::DeleteSceneResponse response;
    EXPECT_EQ(lab_->DeleteScene(&context, request, &response).error_code(),
              grpc::StatusCode::NOT_FOUND);
  }
  {
    grpc::ClientContext context;
    set_deadline(context);
    v1::GetStatsRequest request;
    request.set_scene_id(mine);
    v1::Stats response;
    EXPECT_EQ(lab_->GetStats(&context, request, &response).error_code(),
              grpc::StatusCode::NOT_FOUND);
  }
  const v1::Stats studio_stats = stats(*studio_);
  ASSERT_EQ(studio_stats.scene_stats_size(), 1);
  EXPECT_EQ(studio_stats.scene_stats(0).scene_id(), mine);
  EXPECT_EQ(studio_stats.scenes(), 1u);
  EXPECT_EQ(studio_stats.tenant().name(), "studio");
  EXPECT_EQ(studio_stats.tenant().scenes(), 1u);
  EXPECT_GT(studio_stats.tenant().memory_bytes(), 0u);
  // The owner still has it, whole.
  v1::Frame frame;
  EXPECT_TRUE(render_frame(*studio_, mine, 1, frame_format(v1::RGBA8_SRGB), &frame).ok());
}

TEST_F(TenantServer, MissingOrWrongTokensAreUnauthenticated) {
  start();
  const std::string mine = upload_scene(*studio_, small_box(), "studio's");
  auto anonymous = server_->stub();
  const grpc::Status missing = get_scene_status(*anonymous, mine);
  EXPECT_EQ(missing.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_NE(missing.error_message().find("authorization"), std::string::npos)
      << missing.error_message();
  auto stranger = stub_for(*server_, "not-a-token-of-this-server-at-all");
  const grpc::Status wrong = get_scene_status(*stranger, mine);
  EXPECT_EQ(wrong.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  // An unauthenticated upload stores nothing.
  v1::SceneInfo info;
  EXPECT_EQ(upload(*stranger, scene_chunks(small_box(), "intruder"), &info).error_code(),
            grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(scene_ids(*studio_).size(), 1u);
  EXPECT_TRUE(scene_ids(*lab_).empty());
  // Probes need no token.
  EXPECT_TRUE(health_serving(server_->channel()));
}

TEST_F(TenantServer, ScenesPerTenantAreLimited) {
  start({"--tenant-max-scenes", "2", "--max-scenes", "8"});
  upload_scene(*studio_, small_box(1), "one");
  const std::string second = upload_scene(*studio_, small_box(2), "two");
  v1::SceneInfo info;
  const grpc::Status third = upload(*studio_, scene_chunks(small_box(3), "three"), &info);
  EXPECT_EQ(third.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(third.error_message().find("--tenant-max-scenes"), std::string::npos)
      << third.error_message();
  // Another tenant is not held back by the first.
  upload_scene(*lab_, small_box(4), "lab one");
  upload_scene(*lab_, small_box(5), "lab two");
  // Deleting one makes room again.
  grpc::ClientContext context;
  set_deadline(context);
  v1::DeleteSceneRequest request;
  request.set_scene_id(second);
  v1::DeleteSceneResponse response;
  ASSERT_TRUE(studio_->DeleteScene(&context, request, &response).ok());
  upload_scene(*studio_, small_box(3), "three");
  EXPECT_EQ(stats(*studio_).tenant().max_scenes(), 2u);
}

TEST_F(TenantServer, MemoryShareIsLimited) {
  // A box at this size holds some 1.5 MiB (its film alone is 1 MiB); a tenant's share of 4 MiB
  // takes two, never ten.
  start({"--memory-budget", "8M", "--tenant-memory-share", "0.5"});
  int uploaded = 0;
  grpc::Status refused;
  for (int i = 0; i < 10; ++i) {
    v1::SceneInfo info;
    refused = upload(*studio_, scene_chunks(cornell_box(256, 256, 2000, 8, i + 1), "box"), &info);
    if (!refused.ok()) break;
    ++uploaded;
  }
  EXPECT_GE(uploaded, 1);
  EXPECT_LT(uploaded, 10);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(refused.error_message().find("--tenant-memory-share"), std::string::npos)
      << refused.error_message();
  const v1::Stats mine = stats(*studio_);
  EXPECT_LE(mine.tenant().memory_bytes(), mine.tenant().memory_limit_bytes());
  EXPECT_EQ(mine.tenant().memory_limit_bytes(), 4u << 20);
  // The other half is the other tenant's to use.
  upload_scene(*lab_, cornell_box(256, 256, 2000, 8, 1), "lab box");
}

TEST_F(TenantServer, StreamsPerTenantAreLimited) {
  start({"--tenant-max-streams", "1"});
  const std::string mine = upload_scene(*studio_, small_box(), "streamed");
  const std::string theirs = upload_scene(*lab_, small_box(), "lab streamed");
  grpc::ClientContext first_context;
  set_deadline(first_context);
  v1::StreamFramesRequest request;
  request.set_scene_id(mine);
  request.set_target_passes(1000000);
  *request.mutable_format() = frame_format(v1::RGBA8_SRGB);
  auto first = studio_->StreamFrames(&first_context, request);
  v1::Frame frame;
  ASSERT_TRUE(first->Read(&frame));  // the first stream is open and counted now

  std::vector<StreamedFrame> frames;
  v1::StreamFramesRequest second = request;
  second.set_target_passes(1);
  const grpc::Status refused = stream_frames(*studio_, second, &frames);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(refused.error_message().find("--tenant-max-streams"), std::string::npos)
      << refused.error_message();
  EXPECT_EQ(stats(*studio_).tenant().active_streams(), 1u);
  // Another tenant streams meanwhile.
  v1::StreamFramesRequest other = second;
  other.set_scene_id(theirs);
  EXPECT_TRUE(stream_frames(*lab_, other, &frames).ok());

  first_context.TryCancel();
  while (first->Read(&frame)) {
  }
  first->Finish();
  // The slot is given back once the server sees the cancellation.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  grpc::Status again;
  do {
    again = stream_frames(*studio_, second, &frames);
  } while (!again.ok() && std::chrono::steady_clock::now() < give_up);
  EXPECT_TRUE(again.ok()) << again.error_message();
}

TEST_F(TenantServer, IdleScenesExpire) {
  start({"--scene-idle-ttl", "1.5"});
  const std::string idle = upload_scene(*studio_, small_box(1), "idle");
  const std::string busy = upload_scene(*studio_, small_box(2), "busy");
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(4);
  while (std::chrono::steady_clock::now() < end) {
    ASSERT_TRUE(get_scene_status(*studio_, busy).ok());
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  EXPECT_EQ(get_scene_status(*studio_, idle).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(scene_ids(*studio_), std::vector<std::string>{busy});
  EXPECT_NE(server_->log().find("--scene-idle-ttl"), std::string::npos);
}

TEST_F(TenantServer, TenantsSurviveARestart) {
  const fs::path data = make_temp_dir("caustica-tenant-data");
  start({"--data-dir", data.string()});
  const std::string mine = upload_scene(*studio_, small_box(), "studio's");
  server_->kill_now();
  server_ = ServerProcess::start(
      {"--tokens", (dir_ / "tokens.csv").string(), "--data-dir", data.string()});
  ASSERT_NE(server_, nullptr);
  studio_ = stub_for(*server_, kStudioToken);
  lab_ = stub_for(*server_, kLabToken);
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!health_serving(server_->channel()) && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(scene_ids(*studio_), std::vector<std::string>{mine});
  EXPECT_TRUE(scene_ids(*lab_).empty());
  EXPECT_EQ(get_scene_status(*lab_, mine).error_code(), grpc::StatusCode::NOT_FOUND);
  if (!HasFailure()) fs::remove_all(data);
}

}  // namespace
}  // namespace caustica::testing
