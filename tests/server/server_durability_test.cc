// --data-dir against the real caustica-server: the process is killed with SIGKILL at the moments
// that matter (during an upload, during a stream, just after an acknowledged light change) and
// restarted on the same directory, which must then hold exactly what was acknowledged.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "client/health_check.h"
#include "proto/wire/scene_wire.h"
#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

namespace fs = std::filesystem;

class DurableServer : public ::testing::Test {
 protected:
  void SetUp() override { data_dir_ = make_temp_dir("caustica-data"); }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(data_dir_);
  }

  // A server on data_dir_, waited for until it has restored its scenes.
  std::unique_ptr<ServerProcess> start(std::vector<std::string> extra = {}) {
    return start_restored_server(data_dir_, extra);
  }

  size_t blobs() const {
    size_t count = 0;
    for ([[maybe_unused]] const auto& entry : fs::directory_iterator(data_dir_ / "blobs")) ++count;
    return count;
  }

  fs::path data_dir_;
};

// What a restarted server must report of a scene: everything but timings and the film.
void expect_same_scene(const v1::SceneInfo& before, const v1::SceneInfo& after) {
  EXPECT_EQ(after.scene_id(), before.scene_id());
  EXPECT_EQ(after.name(), before.name());
  EXPECT_EQ(after.triangles(), before.triangles());
  EXPECT_EQ(after.lights(), before.lights());
  EXPECT_EQ(after.upload_bytes(), before.upload_bytes());
  EXPECT_EQ(after.camera().SerializeAsString(), before.camera().SerializeAsString());
  EXPECT_EQ(after.settings().SerializeAsString(), before.settings().SerializeAsString());
  EXPECT_EQ(after.epochs().SerializeAsString(), before.epochs().SerializeAsString())
      << "before " << before.epochs().ShortDebugString() << ", after "
      << after.epochs().ShortDebugString();
  EXPECT_EQ(after.structure(), before.structure());
}

TEST_F(DurableServer, EveryAcknowledgedChangeSurvivesSigkill) {
  auto server = start();
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const std::string a = upload_scene(*stub, cornell_box(24, 16, 3000, 16, 5), "a");
  const std::string b = upload_scene(*stub, cornell_box(16, 16, 2000, 16, 9), "b");
  const std::string gone = upload_scene(*stub, cornell_box(16, 16, 2000, 16, 1), "gone");
  update_lights(*stub, a, 3.5f);
  update_lights(*stub, a, 2.0f);
  {
    grpc::ClientContext context;
    set_deadline(context);
    v1::UpdateCameraRequest request;
    request.set_scene_id(b);
    *request.mutable_camera() = wire::encode_camera(cornell_box(20, 12, 1, 1, 1).camera);
    request.mutable_camera()->mutable_position()->set_z(request.camera().position().z() + 0.5f);
    v1::RebuildReport report;
    ASSERT_TRUE(stub->UpdateCamera(&context, request, &report).ok());
  }
  {
    grpc::ClientContext context;
    set_deadline(context);
    v1::UpdateSettingsRequest request;
    request.set_scene_id(a);
    request.mutable_settings()->set_k_nearest(24);
    request.mutable_settings()->set_structure(v1::BINNED_SAH);
    v1::RebuildReport report;
    const grpc::Status status = stub->UpdateSettings(&context, request, &report);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  {
    grpc::ClientContext context;
    set_deadline(context);
    v1::DeleteSceneRequest request;
    request.set_scene_id(gone);
    v1::DeleteSceneResponse response;
    ASSERT_TRUE(stub->DeleteScene(&context, request, &response).ok());
  }
  const std::vector<v1::SceneInfo> before = list_scenes(*stub);
  ASSERT_EQ(before.size(), 2u);
  const std::vector<float> image_a = render_linear(*stub, a, 3);
  const std::vector<float> image_b = render_linear(*stub, b, 2);
  server->kill_now();

  server = start();
  ASSERT_NE(server, nullptr);
  stub = server->stub();
  const std::vector<v1::SceneInfo> after = list_scenes(*stub);
  ASSERT_EQ(after.size(), 2u);
  for (size_t i = 0; i < 2; ++i) expect_same_scene(before[i], after[i]);
  EXPECT_EQ(after[0].passes(), 0u);  // the film is not kept: it refills from the same seeds
  EXPECT_EQ(render_linear(*stub, a, 3), image_a);
  EXPECT_EQ(render_linear(*stub, b, 2), image_b);
  EXPECT_EQ(get_scene_status(*stub, gone).error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(blobs(), 2u);
  // New uploads get fresh ids next to the restored ones.
  const std::string c = upload_scene(*stub, cornell_box(8, 8, 500, 8, 1), "c");
  EXPECT_NE(c, a);
  EXPECT_NE(c, b);
  EXPECT_EQ(list_scenes(*stub).size(), 3u);
}

TEST_F(DurableServer, KilledDuringAnUploadKeepsNothingOfIt) {
  auto server = start();
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const std::string kept = upload_scene(*stub, cornell_box(8, 8, 500, 8, 1), "kept");
  // Half a stream, then the server dies under it.
  const std::vector<v1::SceneChunk> chunks =
      scene_chunks(cornell_box(8, 8, 500, 8, 1), "half", 4096);
  ASSERT_GT(chunks.size(), 4u);
  grpc::ClientContext context;
  set_deadline(context);
  v1::SceneInfo info;
  std::unique_ptr<grpc::ClientWriter<v1::SceneChunk>> writer = stub->UploadScene(&context, &info);
  for (size_t i = 0; i < chunks.size() / 2; ++i) ASSERT_TRUE(writer->Write(chunks[i]));
  server->kill_now();
  writer->WritesDone();
  EXPECT_FALSE(writer->Finish().ok());

  server = start();
  ASSERT_NE(server, nullptr);
  stub = server->stub();
  const std::vector<v1::SceneInfo> after = list_scenes(*stub);
  ASSERT_EQ(after.size(), 1u);
  EXPECT_EQ(after[0].scene_id(), kept);
  EXPECT_EQ(blobs(), 1u);
  EXPECT_TRUE(fs::is_empty(data_dir_ / "tmp"));
}

TEST_F(DurableServer, KilledDuringAStreamKeepsTheScene) {
  auto server = start();
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const std::string id = upload_scene(*stub, cornell_box(32, 32, 4000, 16, 2), "streamed");
  update_lights(*stub, id, 4.0f);
  const v1::SceneInfo before = get_scene(*stub, id);
  grpc::ClientContext context;
  set_deadline(context);
  v1::StreamFramesRequest request;
  request.set_scene_id(id);
  request.set_target_passes(100000);
  *request.mutable_format() = frame_format(v1::RGBA8_SRGB);
  std::unique_ptr<grpc::ClientReader<v1::Frame>> reader = stub->StreamFrames(&context, request);
  v1::Frame frame;
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(reader->Read(&frame));
  server->kill_now();
  while (reader->Read(&frame)) {
  }
  EXPECT_FALSE(reader->Finish().ok());

  server = start();
  ASSERT_NE(server, nullptr);
  stub = server->stub();
  expect_same_scene(before, get_scene(*stub, id));
}

TEST_F(DurableServer, KilledJustAfterALightChangeKeepsIt) {
  auto server = start();
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const Scene scene = cornell_box(24, 24, 3000, 16, 4);
  const std::string id = upload_scene(*stub, scene, "lit");
  for (const float intensity : {6.0f, 1.5f}) {
    const v1::RebuildReport report = update_lights(*stub, id, intensity);
    server->kill_now();  // at once: nothing after the acknowledgement may be needed
    server = start();
    ASSERT_NE(server, nullptr);
    stub = server->stub();
    const v1::SceneInfo info = get_scene(*stub, id);
    EXPECT_EQ(info.epochs().lights(), report.epochs().lights());
    EXPECT_EQ(info.epochs().SerializeAsString(), report.epochs().SerializeAsString());
    // The light itself came back: the image matches a server that never stopped.
    auto reference = ServerProcess::start();
    ASSERT_NE(reference, nullptr);
    auto reference_stub = reference->stub();
    const std::string twin = upload_scene(*reference_stub, scene, "lit");
    update_lights(*reference_stub, twin, intensity);
    EXPECT_EQ(render_linear(*stub, id, 2), render_linear(*reference_stub, twin, 2)) << intensity;
  }
}

TEST_F(DurableServer, NotServingUntilRestored) {
  {
    auto server = start();
    ASSERT_NE(server, nullptr);
    auto stub = server->stub();
    upload_scene(*stub, cornell_box(8, 8, 500, 8, 1), "one");
    upload_scene(*stub, cornell_box(8, 8, 500, 8, 2), "two");
    server->kill_now();
  }
  setenv("CAUSTICA_RESTORE_DELAY_MS", "1500", 1);
  std::unique_ptr<ServerProcess> server = ServerProcess::start({"--data-dir", data_dir_.string()});
  unsetenv("CAUSTICA_RESTORE_DELAY_MS");
  ASSERT_NE(server, nullptr);
  absl::StatusOr<client::ServingStatus> health = client::check_health(
      server->channel(), std::chrono::system_clock::now() + std::chrono::seconds(10), false);
  ASSERT_TRUE(health.ok()) << health.status();
  EXPECT_EQ(*health, client::ServingStatus::kNotServing);
  auto stub = server->stub();
  {
    grpc::ClientContext context;
    set_deadline(context);
    v1::ListScenesResponse response;
    const grpc::Status status = stub->ListScenes(&context, {}, &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE);
    EXPECT_NE(status.error_message().find("restoring"), std::string::npos)
        << status.error_message();
  }
  {
    grpc::ClientContext context;
    set_deadline(context);
    v1::VersionInfo version;
    EXPECT_TRUE(stub->GetVersion(&context, {}, &version).ok());
  }
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!health_serving(server->channel()) && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_TRUE(health_serving(server->channel()));
  EXPECT_EQ(list_scenes(*stub).size(), 2u);
}

TEST_F(DurableServer, ADamagedBlobCostsOnlyItsScene) {
  std::string damaged, intact;
  {
    auto server = start();
    ASSERT_NE(server, nullptr);
    auto stub = server->stub();
    damaged = upload_scene(*stub, cornell_box(8, 8, 500, 8, 1), "damaged");
    intact = upload_scene(*stub, cornell_box(8, 8, 500, 8, 2), "intact");
    EXPECT_EQ(server->terminate(), 0);
  }
  // The blob whose header names "damaged" loses its second half.
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(data_dir_ / "blobs"))
    files.push_back(entry.path());
  ASSERT_EQ(files.size(), 2u);
  for (const fs::path& file : files) {
    std::ifstream in(file, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    if (bytes.find("damaged") != std::string::npos) fs::resize_file(file, bytes.size() / 2);
  }
  auto server = start();
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const std::vector<v1::SceneInfo> after = list_scenes(*stub);
  ASSERT_EQ(after.size(), 1u);
  EXPECT_EQ(after[0].scene_id(), intact);
  EXPECT_NE(server->log().find("not restored"), std::string::npos) << server->log();
  expect_server_healthy(*server);
}

}  // namespace
}  // namespace caustica::testing

namespace caustica::testing {
namespace {

TEST(EmbeddedServer, KeepsUploadsBetweenCommands) {
  const fs::path data = make_temp_dir("caustica-cli-data");
  const std::string scene = (fs::path(CAUSTICA_SCENES_DIR) / "cornell-box" / "scene.json").string();
  const std::string dir_flag = "--data-dir '" + data.string() + "'";
  auto run_cli = [](const std::string& args, std::string* output) {
    const CommandRun run = run_command(std::string("'") + CAUSTICA_CLIENT_BIN + "' " + args);
    *output = run.output;
    return run.exit_code;
  };
  std::string output;
  // The scene's own resolution and photon count do not matter here; upload only builds it.
  ASSERT_EQ(run_cli(dir_flag + " scene upload '" + scene + "' --name kept", &output), 0) << output;
  EXPECT_NE(output.find("kept in " + data.string()), std::string::npos) << output;
  // The id is stdout's one line; the note went to stderr.
  const size_t at = output.rfind("\ns-") + 1;
  ASSERT_GT(at, 0u) << output;
  const std::string id = output.substr(at, output.find('\n', at) - at);

  ASSERT_EQ(run_cli(dir_flag + " scene list", &output), 0) << output;
  EXPECT_NE(output.find(id), std::string::npos) << output;
  EXPECT_NE(output.find("kept"), std::string::npos) << output;
  ASSERT_EQ(run_cli(dir_flag + " scene delete " + id, &output), 0) << output;
  ASSERT_EQ(run_cli(dir_flag + " scene list", &output), 0) << output;
  EXPECT_EQ(output.find(id), std::string::npos) << output;

  // While a server holds the directory, a command runs without it and says so.
  auto holder = ServerProcess::start({"--data-dir", data.string()});
  ASSERT_NE(holder, nullptr);
  ASSERT_EQ(run_cli(dir_flag + " scene upload '" + scene + "'", &output), 0) << output;
  EXPECT_NE(output.find("not kept"), std::string::npos) << output;
  if (!HasFailure()) fs::remove_all(data);
}

}  // namespace
}  // namespace caustica::testing
