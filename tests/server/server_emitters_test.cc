// Area lights over RPC against the real caustica-server: UpdateLights' emitters change an
// emissive material (SceneInfo lists it), keep_lights keeps the other lights, bad changes get
// INVALID_ARGUMENT naming the field with the server unharmed, the change survives a SIGKILL with
// --data-dir, and `caustica light emit` sends it.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <thread>

#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

namespace fs = std::filesystem;

v1::UpdateLightsRequest emit(const std::string& id, const std::string& material,
                             std::optional<float> radiance, std::optional<bool> off) {
  v1::UpdateLightsRequest request;
  request.set_scene_id(id);
  request.set_keep_lights(true);
  v1::Emitter& emitter = *request.add_emitters();
  emitter.set_material(material);
  if (radiance) {
    emitter.mutable_radiance()->set_x(*radiance);
    emitter.mutable_radiance()->set_y(*radiance);
    emitter.mutable_radiance()->set_z(*radiance);
  }
  if (off) emitter.set_off(*off);
  return request;
}

const v1::Emitter* emitter_named(const v1::SceneInfo& info, const std::string& material) {
  for (const v1::Emitter& e : info.emitters())
    if (e.material() == material) return &e;
  return nullptr;
}

class EmitterServer : public ServerTest {};

TEST_F(EmitterServer, EmittersChangeOverRpcAndKeepTheOtherLights) {
  Scene scene = cornell_box(16, 16, 3000, 16, 3);
  scene.lights = {Light{"key", LightType::kPoint, Vec3f(278, 400, 279), Vec3f(0, -1, 0),
                        Vec3f(1e5f, 1e5f, 1e5f)}};
  const std::string id = upload_scene(*stub_, scene);
  v1::SceneInfo info = get_scene(*stub_, id);
  ASSERT_EQ(info.emitters_size(), 1);
  EXPECT_EQ(info.emitters(0).material(), "light");
  EXPECT_EQ(info.emitters(0).radiance().x(), 17);
  EXPECT_FALSE(info.emitters(0).off());
  const std::vector<float> both = render_linear(*stub_, id, 2);

  v1::RebuildReport report;
  ASSERT_TRUE(call_update_lights(*stub_, emit(id, "light", std::nullopt, true), &report).ok());
  info = get_scene(*stub_, id);
  EXPECT_TRUE(emitter_named(info, "light")->off());
  EXPECT_EQ(emitter_named(info, "light")->radiance().x(), 17);
  EXPECT_EQ(info.lights(), 1u) << "keep_lights kept the point light";
  ASSERT_EQ(info.light_list_size(), 1);
  EXPECT_EQ(info.light_list(0).name(), "key");
  EXPECT_EQ(info.light_list(0).position().y(), 400);
  EXPECT_EQ(info.light_list(0).intensity().x(), 1e5f);
  EXPECT_EQ(info.epochs().lights(), report.epochs().lights());
  const std::vector<float> point_only = render_linear(*stub_, id, 2);
  EXPECT_LT(mean_rgb(point_only), mean_rgb(both));
  EXPECT_GT(mean_rgb(point_only), 0);

  ASSERT_TRUE(call_update_lights(*stub_, emit(id, "light", 34.0f, false), &report).ok());
  info = get_scene(*stub_, id);
  EXPECT_FALSE(emitter_named(info, "light")->off());
  EXPECT_EQ(emitter_named(info, "light")->radiance().y(), 34);
  EXPECT_GT(mean_rgb(render_linear(*stub_, id, 2)), mean_rgb(both));
}

TEST_F(EmitterServer, BadChangesNameTheFieldAndLeaveTheServerServing) {
  const std::string id = upload_scene(*stub_, cornell_box(16, 16, 2000, 16, 3));
  const uint64_t epoch = get_scene(*stub_, id).epochs().lights();
  struct Case {
    v1::UpdateLightsRequest request;
    std::string message;
  };
  std::vector<Case> cases = {
      {emit(id, "lamp", 1.0f, std::nullopt), "emitters[0].material: the scene has no material"},
      {emit(id, "white", 1.0f, std::nullopt), "'white' is diffuse and emits nothing"},
      {emit(id, "light", -1.0f, std::nullopt), "emitters[0].radiance"},
      {emit(id, "light", std::nullopt, std::nullopt), "changes nothing of 'light'"},
      {emit(id, "", 1.0f, std::nullopt), "emitters[0].material: is empty"},
  };
  v1::UpdateLightsRequest with_lights = emit(id, "light", 1.0f, std::nullopt);
  *with_lights.add_lights() = point_light(1e5f);
  cases.push_back({with_lights, "lights: must be empty with keep_lights"});
  for (const Case& c : cases) {
    v1::RebuildReport report;
    const grpc::Status status = call_update_lights(*stub_, c.request, &report);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << c.message;
    EXPECT_NE(status.error_message().find(c.message), std::string::npos) << status.error_message();
  }
  const v1::SceneInfo info = get_scene(*stub_, id);
  EXPECT_EQ(info.epochs().lights(), epoch);
  EXPECT_EQ(info.emitters(0).radiance().x(), 17);
  expect_server_healthy(*server_);
}

TEST(EmitterDurability, AnEmitterChangeSurvivesSigkill) {
  const fs::path data_dir = make_temp_dir("caustica-emitters");
  auto start = [&] {
    std::unique_ptr<ServerProcess> server = ServerProcess::start({"--data-dir", data_dir.string()});
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (server != nullptr && !health_serving(server->channel()) &&
           std::chrono::steady_clock::now() < give_up) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return server;
  };
  auto server = start();
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const Scene scene = cornell_box(16, 16, 2000, 16, 3);
  const std::string id = upload_scene(*stub, scene);
  v1::RebuildReport report;
  ASSERT_TRUE(call_update_lights(*stub, emit(id, "light", 5.0f, std::nullopt), &report).ok());
  ASSERT_TRUE(call_update_lights(*stub, emit(id, "light", std::nullopt, true), &report).ok());
  ASSERT_TRUE(call_update_lights(*stub, emit(id, "light", std::nullopt, false), &report).ok());
  const std::vector<float> before = render_linear(*stub, id, 2);
  server->kill_now();

  server = start();
  ASSERT_NE(server, nullptr);
  stub = server->stub();
  const v1::SceneInfo info = get_scene(*stub, id);
  EXPECT_EQ(info.epochs().lights(), report.epochs().lights());
  ASSERT_EQ(info.emitters_size(), 1);
  EXPECT_EQ(info.emitters(0).radiance().x(), 5);
  EXPECT_FALSE(info.emitters(0).off());
  EXPECT_EQ(render_linear(*stub, id, 2), before);
  fs::remove_all(data_dir);
}

TEST_F(EmitterServer, TheCliSwitchesAnAreaLight) {
  const std::string id = upload_scene(*stub_, cornell_box(16, 16, 2000, 16, 3));
  const std::string cli = std::string("'") + CAUSTICA_CLIENT_BIN + "' --server " +
                          server_->address() + " light emit " + id + " light ";
  CommandRun run = run_command(cli + "--off");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_TRUE(get_scene(*stub_, id).emitters(0).off());
  run = run_command(cli + "--on --radiance 3,2,1");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  const v1::Emitter emitter = get_scene(*stub_, id).emitters(0);
  EXPECT_FALSE(emitter.off());
  EXPECT_EQ(emitter.radiance().z(), 1);
  run = run_command(cli);
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("give --radiance, --on or --off"), std::string::npos) << run.output;
  run = run_command(std::string("'") + CAUSTICA_CLIENT_BIN + "' --server " + server_->address() +
                    " light emit " + id + " white --radiance 1");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("'white' is diffuse and emits nothing"), std::string::npos)
      << run.output;
}

}  // namespace
}  // namespace caustica::testing
