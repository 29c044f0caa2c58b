// The environment over RPC against the real caustica-server: a scene with one uploads it (map
// included) and SceneInfo shows it; UpdateLights' environment_intensity and _rotation_deg change
// it as a light change, and the image follows; a scene without one refuses the change with
// FAILED_PRECONDITION and bad values get INVALID_ARGUMENT naming the field, the server unharmed;
// the change survives a SIGKILL with --data-dir; `caustica light environment` sends it and
// `caustica scene info` shows it.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>

#include "renderer/scene/file_io.h"
#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

namespace fs = std::filesystem;

// The Cornell box lit by the bundled sunset too, seen through its open front: the upload carries
// the Radiance HDR file's bytes, which the server decodes.
Scene box_under_sky() {
  Scene scene = cornell_box(16, 16, 2000, 16, 3);
  absl::StatusOr<std::string> bytes =
      read_file(fs::path(CAUSTICA_SCENES_DIR) / "damaged-helmet" / "sunset.hdr");
  EXPECT_TRUE(bytes.ok()) << bytes.status();
  scene.textures.push_back(
      {"sunset.hdr", std::make_shared<const std::string>(bytes.value_or("")), nullptr});
  scene.environment = {.present = true, .texture = 0, .intensity = 2.0f};
  return scene;
}

v1::UpdateLightsRequest environment_change(const std::string& id, std::optional<float> intensity,
                                           std::optional<float> rotation) {
  v1::UpdateLightsRequest request;
  request.set_scene_id(id);
  request.set_keep_lights(true);
  if (intensity) request.set_environment_intensity(*intensity);
  if (rotation) request.set_environment_rotation_deg(*rotation);
  return request;
}

class EnvironmentServer : public ServerTest {};

TEST_F(EnvironmentServer, TheEnvironmentChangesOverRpcAsALight) {
  const std::string id = upload_scene(*stub_, box_under_sky());
  v1::SceneInfo info = get_scene(*stub_, id);
  const uint32_t lights = info.lights();
  ASSERT_TRUE(info.has_environment());
  EXPECT_EQ(info.environment().texture(), 1u);
  EXPECT_EQ(info.environment().intensity(), 2.0f);
  const std::vector<float> before = render_linear(*stub_, id, 2);

  v1::RebuildReport report;
  ASSERT_TRUE(call_update_lights(*stub_, environment_change(id, 6.0f, 90.0f), &report).ok());
  EXPECT_EQ(report.epochs().lights(), info.epochs().lights() + 1);
  info = get_scene(*stub_, id);
  EXPECT_EQ(info.environment().intensity(), 6.0f);
  EXPECT_EQ(info.environment().rotation_deg(), 90.0f);
  EXPECT_EQ(info.lights(), lights) << "keep_lights kept the other lights";
  EXPECT_GT(mean_rgb(render_linear(*stub_, id, 2)), mean_rgb(before));
}

TEST_F(EnvironmentServer, BadChangesAreRefusedAndLeaveTheServerServing) {
  const std::string without = upload_scene(*stub_, cornell_box(16, 16, 2000, 16, 3));
  v1::RebuildReport report;
  grpc::Status status =
      call_update_lights(*stub_, environment_change(without, 2.0f, std::nullopt), &report);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(status.error_message().find("no environment"), std::string::npos)
      << status.error_message();
  const std::string id = upload_scene(*stub_, box_under_sky());
  const uint64_t epoch = get_scene(*stub_, id).epochs().lights();
  status = call_update_lights(*stub_, environment_change(id, -1.0f, std::nullopt), &report);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("environment.intensity"), std::string::npos);
  status = call_update_lights(*stub_, environment_change(id, std::nullopt, INFINITY), &report);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("environment.rotation"), std::string::npos);
  const v1::SceneInfo info = get_scene(*stub_, id);
  EXPECT_EQ(info.epochs().lights(), epoch);
  EXPECT_EQ(info.environment().intensity(), 2.0f);
  expect_server_healthy(*server_);
}

TEST(EnvironmentDurability, AnEnvironmentChangeSurvivesSigkill) {
  const fs::path data_dir = make_temp_dir("caustica-environment");
  auto server = start_restored_server(data_dir);
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const std::string id = upload_scene(*stub, box_under_sky());
  v1::RebuildReport report;
  ASSERT_TRUE(call_update_lights(*stub, environment_change(id, 0.5f, 45.0f), &report).ok());
  const std::vector<float> before = render_linear(*stub, id, 2);
  server->kill_now();

  server = start_restored_server(data_dir);
  ASSERT_NE(server, nullptr);
  stub = server->stub();
  const v1::SceneInfo info = get_scene(*stub, id);
  EXPECT_EQ(info.epochs().lights(), report.epochs().lights());
  EXPECT_EQ(info.environment().intensity(), 0.5f);
  EXPECT_EQ(info.environment().rotation_deg(), 45.0f);
  EXPECT_EQ(render_linear(*stub, id, 2), before);
  fs::remove_all(data_dir);
}

TEST_F(EnvironmentServer, TheCliTurnsTheEnvironment) {
  const std::string id = upload_scene(*stub_, box_under_sky());
  const std::string cli = std::string("'") + CAUSTICA_CLIENT_BIN + "' --server " +
                          server_->address() + " light environment " + id;
  CommandRun run = run_command(cli + " --rotation 30 --intensity 3");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  const v1::SceneInfo info = get_scene(*stub_, id);
  EXPECT_EQ(info.environment().rotation_deg(), 30.0f);
  EXPECT_EQ(info.environment().intensity(), 3.0f);
  run = run_command(cli);
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("give --intensity or --rotation"), std::string::npos) << run.output;
  run = run_command(std::string("'") + CAUSTICA_CLIENT_BIN + "' --server " + server_->address() +
                    " scene info " + id);
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("environment  map sunset.hdr, colour (1, 1, 1), intensity 3, rotation "
                            "30 degrees"),
            std::string::npos)
      << run.output;
}

}  // namespace
}  // namespace caustica::testing
