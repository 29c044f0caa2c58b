// UpdateGeometry against the real caustica-server: the Cornell box's tall block (five quads, one
// request) turned and moved, and the floor's vertices replaced, render as the scene uploaded that
// way; bad requests are refused by name and change nothing; a server killed right after an
// acknowledged change comes back with it.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/scene_upload.h"
#include "proto/wire/scene_wire.h"
#include "renderer/scene/load_scene.h"
#include "renderer/scene/shapes.h"
#include "renderer/scene/transform.h"
#include "tests/client/client_run.h"
#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

const Scene& box() {
  static const Scene scene = cornell_box(24, 16, 3000, 16, 5);
  return scene;
}

const std::vector<std::string> kTallBlock = {
    "shapes[11] 'tall block top'", "shapes[12] 'tall block side 1'",
    "shapes[13] 'tall block side 2'", "shapes[14] 'tall block side 3'",
    "shapes[15] 'tall block side 4'"};

// The tall block turned 20 degrees about its own vertical axis and moved towards the door.
Affine block_moved() {
  const Vec3f axis(368, 0, 351);
  return translation(Vec3f(-30, 0, -60)) * translation(axis) * rotation_y_deg(20) *
         translation(Vec3f(0, 0, 0) - axis);
}

// The floor, raised 5 units by new vertices.
std::vector<Vec3f> floor_raised() {
  std::vector<Vec3f> positions = box().meshes[0].positions;
  for (Vec3f& p : positions) p.y += 5;
  return positions;
}

v1::UpdateGeometryRequest move_request(const std::string& id) {
  v1::UpdateGeometryRequest request;
  request.set_scene_id(id);
  for (const std::string& name : kTallBlock)
    *request.add_meshes() =
        wire::encode_mesh_change({name, block_moved(), std::nullopt, std::nullopt});
  *request.add_meshes() =
      wire::encode_mesh_change({"shapes[0] 'floor'", std::nullopt, floor_raised(), std::nullopt});
  return request;
}

// The box as the request above leaves it, built on the client.
Scene box_moved() {
  Scene scene = box();
  for (Mesh& mesh : scene.meshes) {
    for (const std::string& name : kTallBlock)
      if (mesh.name == name) transform_mesh(block_moved(), &mesh);
  }
  scene.meshes[0].positions = floor_raised();
  scene.meshes[0].normals.clear();
  scene.meshes[0].tangents.clear();
  return scene;
}

grpc::Status update_geometry(v1::RenderService::Stub& stub,
                             const v1::UpdateGeometryRequest& request, v1::RebuildReport* report) {
  grpc::ClientContext context;
  set_deadline(context);
  return stub.UpdateGeometry(&context, request, report);
}

TEST(ServerGeometry, MovedMeshesRenderAsTheSceneUploadedMoved) {
  auto server = ServerProcess::start();
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const std::string id = upload_scene(*stub, box(), "box");
  const v1::SceneInfo info = get_scene(*stub, id);
  ASSERT_EQ(info.mesh_names_size(), 16);
  EXPECT_EQ(info.mesh_names(11), kTallBlock[0]);
  const std::vector<float> before = render_linear(*stub, id, 2);
  v1::RebuildReport report;
  const grpc::Status status = update_geometry(*stub, move_request(id), &report);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(report.epochs().geometry(), info.epochs().geometry() + 1);
  EXPECT_EQ(report.epochs().lights(), info.epochs().lights() + 1);
  EXPECT_GT(report.photons_emitted(), 0u);
  // The default structure is refitted (settings.build.refit "auto"), and SceneInfo says so.
  EXPECT_THAT(report.rebuilt(), ::testing::Contains("structure_refit"));
  const v1::SceneInfo moved_info = get_scene(*stub, id);
  EXPECT_EQ(info.structure_refits(), 0u);
  EXPECT_EQ(moved_info.structure_refits(), 1u);
  EXPECT_EQ(moved_info.structure_built_sah_cost(), info.structure_sah_cost());
  EXPECT_EQ(moved_info.settings().build().refit(), v1::REFIT_AUTO);
  const std::vector<float> after = render_linear(*stub, id, 2);
  EXPECT_NE(after, before);
  const std::string twin = upload_scene(*stub, box_moved(), "box moved");
  EXPECT_EQ(after, render_linear(*stub, twin, 2));
}

// The box with a finely cut sphere, so that its geometry, not its film, is most of what it holds.
Scene box_with_sphere(RefitPolicy refit) {
  Scene scene = box();
  Mesh sphere = make_sphere(Vec3f(278, 120, 278), 80, 160, 320);
  sphere.name = "sphere";
  sphere.material_ids.assign(sphere.indices.size() / 3, scene.meshes[0].material_ids[0]);
  scene.meshes.push_back(std::move(sphere));
  scene.settings.build.refit = refit;
  return scene;
}

v1::UpdateGeometryRequest sphere_moved(const std::string& id) {
  v1::UpdateGeometryRequest request;
  request.set_scene_id(id);
  *request.add_meshes() = wire::encode_mesh_change(
      {"sphere", translation(Vec3f(0, 40, 0)), std::nullopt, std::nullopt});
  return request;
}

v1::Stats server_stats(v1::RenderService::Stub& stub) {
  grpc::ClientContext context;
  set_deadline(context);
  v1::Stats stats;
  EXPECT_TRUE(stub.GetStats(&context, {}, &stats).ok());
  return stats;
}

// A refused geometry change leaves the scene as it was: its epochs, and its frame.
void expect_unchanged(v1::RenderService::Stub& stub, const std::string& id,
                      const v1::SceneInfo& before, const std::vector<float>& frame) {
  const v1::SceneInfo now = get_scene(stub, id);
  EXPECT_EQ(now.epochs().SerializeAsString(), before.epochs().SerializeAsString());
  EXPECT_EQ(render_linear(stub, id, 2), frame);
}

// What a geometry change builds beside the scene counts against the tenant's share of the
// budget, and against the device's budget: beyond either it is refused, naming the limit, and
// the scene keeps rendering as it did; the same change on a server with room goes through.
TEST(ServerGeometry, AChangeBeyondTheTenantsShareOrTheBudgetIsRefused) {
  size_t held = 0, upload_peak = 0;
  {
    auto roomy = ServerProcess::start({"--memory-budget", "1024M"});
    ASSERT_NE(roomy, nullptr);
    auto stub = roomy->stub();
    const std::string id = upload_scene(*stub, box_with_sphere(RefitPolicy::kNever), "sphere");
    held = get_scene(*stub, id).device_bytes();
    upload_peak = server_stats(*stub).memory_peak_bytes();
    v1::RebuildReport report;
    const grpc::Status moved = update_geometry(*stub, sphere_moved(id), &report);
    ASSERT_TRUE(moved.ok()) << moved.error_message();
    EXPECT_GT(server_stats(*stub).memory_peak_bytes(), upload_peak + held / 2);
  }
  ASSERT_GT(held, size_t(8) << 20);
  // A share that holds the scene but not a second copy of its geometry beside it.
  {
    const size_t budget_mib = (upload_peak >> 20) + 2 * (held >> 20) + 4;
    const double share = 1.4 * double(held) / double(budget_mib << 20);
    auto server = ServerProcess::start({"--memory-budget", absl::StrCat(budget_mib, "M"),
                                        "--tenant-memory-share", absl::StrCat(share)});
    ASSERT_NE(server, nullptr);
    auto stub = server->stub();
    const std::string id = upload_scene(*stub, box_with_sphere(RefitPolicy::kAuto), "sphere");
    const v1::SceneInfo info = get_scene(*stub, id);
    const std::vector<float> frame = render_linear(*stub, id, 2);
    v1::RebuildReport report;
    const grpc::Status refused = update_geometry(*stub, sphere_moved(id), &report);
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
    EXPECT_THAT(refused.error_message(),
                ::testing::AllOf(::testing::HasSubstr("the geometry change of scene 'sphere'"),
                                 ::testing::HasSubstr("--tenant-memory-share")));
    expect_unchanged(*stub, id, info, frame);
  }
  // A device budget with room for the upload's build but not for the change's beside the scene.
  {
    const size_t budget_mib = (upload_peak >> 20) + 2;
    auto server = ServerProcess::start({"--memory-budget", absl::StrCat(budget_mib, "M")});
    ASSERT_NE(server, nullptr);
    auto stub = server->stub();
    const std::string id = upload_scene(*stub, box_with_sphere(RefitPolicy::kNever), "sphere");
    const v1::SceneInfo info = get_scene(*stub, id);
    const std::vector<float> frame = render_linear(*stub, id, 2);
    v1::RebuildReport report;
    const grpc::Status refused = update_geometry(*stub, sphere_moved(id), &report);
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED)
        << refused.error_message();
    expect_unchanged(*stub, id, info, frame);
    std::printf("held %zu MiB, upload peak %zu MiB, budget %zu MiB: %s\n", held >> 20,
                upload_peak >> 20, budget_mib, refused.error_message().c_str());
  }
}

TEST(ServerGeometry, BadUpdatesAreRefusedByNameAndChangeNothing) {
  auto server = ServerProcess::start();
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const std::string id = upload_scene(*stub, box(), "box");
  const std::vector<float> before = render_linear(*stub, id, 2);
  const v1::SceneInfo info = get_scene(*stub, id);
  struct Case {
    const char* what;
    std::function<void(v1::UpdateGeometryRequest&)> spoil;
    grpc::StatusCode code;
    const char* message;
  };
  const Case cases[] = {
      {"unknown mesh", [](auto& r) { r.mutable_meshes(2)->set_mesh("shapes[99] 'no such'"); },
       grpc::StatusCode::NOT_FOUND, "meshes[2].mesh: the scene has no mesh named"},
      {"short transform", [](auto& r) { r.mutable_meshes(1)->mutable_transform()->RemoveLast(); },
       grpc::StatusCode::INVALID_ARGUMENT, "meshes[1].transform: has 11 numbers; it takes 12"},
      {"NaN vertex",
       [](auto& r) {
         r.mutable_meshes(5)->set_positions(4, std::numeric_limits<float>::quiet_NaN());
       },
       grpc::StatusCode::INVALID_ARGUMENT, "meshes[5].positions[1]: ("},
      {"wrong count",
       [](auto& r) {
         for (const float x : {1.0f, 2.0f, 3.0f}) r.mutable_meshes(5)->add_positions(x);
       },
       grpc::StatusCode::INVALID_ARGUMENT, "meshes[5].positions: 5 vertices, but the mesh has 4"},
      {"singular", [](auto& r) { r.mutable_meshes(0)->set_transform(5, 0); },
       grpc::StatusCode::INVALID_ARGUMENT, "meshes[0].transform: is not an invertible map"},
      {"stale epoch", [&](auto& r) { r.set_expected_geometry_epoch(info.epochs().geometry() + 7); },
       grpc::StatusCode::FAILED_PRECONDITION,
       "expected_geometry_epoch: the scene's geometry epoch"},
  };
  for (const Case& c : cases) {
    v1::UpdateGeometryRequest request = move_request(id);
    c.spoil(request);
    v1::RebuildReport report;
    const grpc::Status status = update_geometry(*stub, request, &report);
    EXPECT_EQ(status.error_code(), c.code) << c.what << ": " << status.error_message();
    EXPECT_NE(status.error_message().find(c.message), std::string::npos)
        << c.what << ": " << status.error_message();
  }
  EXPECT_EQ(get_scene(*stub, id).epochs().SerializeAsString(), info.epochs().SerializeAsString());
  EXPECT_EQ(render_linear(*stub, id, 2), before);
}

TEST(ServerGeometry, AnAcknowledgedChangeSurvivesSigkill) {
  const std::filesystem::path data_dir = make_temp_dir("caustica-geometry");
  auto server = start_restored_server(data_dir, {});
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const std::string id = upload_scene(*stub, box(), "box");
  v1::RebuildReport report;
  ASSERT_TRUE(update_geometry(*stub, move_request(id), &report).ok());
  server->kill_now();  // at once: nothing after the acknowledgement may be needed
  server = start_restored_server(data_dir, {});
  ASSERT_NE(server, nullptr);
  stub = server->stub();
  EXPECT_EQ(get_scene(*stub, id).epochs().SerializeAsString(), report.epochs().SerializeAsString());
  const std::string twin = upload_scene(*stub, box_moved(), "box moved");
  EXPECT_EQ(render_linear(*stub, id, 2), render_linear(*stub, twin, 2));
  server.reset();
  std::filesystem::remove_all(data_dir);
}

// A client moves the tall block a step further with every call, as fast as the server answers,
// and the server is killed mid-stream: restarted, the scene stands at the last acknowledged step,
// or at the one in flight when it died, and renders as the box uploaded so.
TEST(ServerGeometry, AStreamOfChangesKilledMidwayLosesNoAcknowledgedOne) {
  const std::filesystem::path data_dir = make_temp_dir("caustica-geometry-stream");
  auto server = start_restored_server(data_dir, {});
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const std::string id = upload_scene(*stub, box(), "box");
  const uint64_t base_epoch = get_scene(*stub, id).epochs().geometry();
  auto step_transform = [](int step) { return translation(Vec3f(-4.0f * float(step), 0, 0)); };
  std::atomic<int> acknowledged{0};
  std::thread client([&] {
    for (int step = 1;; ++step) {
      v1::UpdateGeometryRequest request;
      request.set_scene_id(id);
      for (const std::string& name : kTallBlock)
        *request.add_meshes() =
            wire::encode_mesh_change({name, step_transform(step), std::nullopt, std::nullopt});
      v1::RebuildReport report;
      if (!update_geometry(*stub, request, &report).ok()) return;
      acknowledged = step;
    }
  });
  while (acknowledged < 6) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  server->kill_now();
  client.join();
  const int acked = acknowledged;
  server = start_restored_server(data_dir, {});
  ASSERT_NE(server, nullptr);
  stub = server->stub();
  const int restored = int(get_scene(*stub, id).epochs().geometry() - base_epoch);
  EXPECT_GE(restored, acked);
  EXPECT_LE(restored, acked + 1);
  Scene moved = box();
  for (Mesh& mesh : moved.meshes)
    for (const std::string& name : kTallBlock)
      if (mesh.name == name) transform_mesh(step_transform(restored), &mesh);
  const std::string twin = upload_scene(*stub, moved, "box moved");
  EXPECT_EQ(render_linear(*stub, id, 2), render_linear(*stub, twin, 2));
  server.reset();
  std::filesystem::remove_all(data_dir);
}

// `caustica mesh move` sends a scene file's kind of transform; `scene info` lists the names.
TEST(ServerGeometry, TheCliMovesAMesh) {
  auto server = ServerProcess::start();
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const std::string id = upload_scene(*stub, box(), "box");
  const std::string cli =
      std::string("'") + CAUSTICA_CLIENT_BIN + "' --server " + server->address() + " ";
  CommandRun run = run_command(cli + "scene info " + id);
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("mesh         shapes[6] 'short block top'"), std::string::npos)
      << run.output;
  run =
      run_command(cli + "mesh move " + id +
                  " \"shapes[6] 'short block top'\" --translate 0,40,0 --rotate 0,90,0 --scale 2");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("geometry"), std::string::npos) << run.output;
  Scene moved = box();
  // The scene format's composition, as the CLI builds it.
  transform_mesh(translation(Vec3f(0, 40, 0)) * rotation_z_deg(0) * rotation_y_deg(90) *
                     rotation_x_deg(0) * scaling(Vec3f(2.0f)),
                 &moved.meshes[6]);
  const std::string twin = upload_scene(*stub, moved, "moved");
  EXPECT_EQ(render_linear(*stub, id, 1), render_linear(*stub, twin, 1));
  run = run_command(cli + "mesh move " + id + " \"shapes[6] 'short block top'\"");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("give --translate, --rotate or --scale"), std::string::npos)
      << run.output;
  run = run_command(cli + "mesh move " + id + " nothing --translate 1,2,3");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("the scene has no mesh named 'nothing'"), std::string::npos)
      << run.output;
}

// Keyframes that move meshes: each frame is the scene uploaded with the meshes where that
// keyframe puts them (a transform places a mesh as uploaded, so the second keyframe's does not
// add to the first's), and the lights stay where keep_lights keeps them.
TEST(ServerGeometry, AnimationKeyframesMoveMeshes) {
  auto server = ServerProcess::start();
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const std::string id = upload_scene(*stub, box(), "box");
  const v1::SceneInfo info = get_scene(*stub, id);
  const Affine placements[] = {block_moved(), translation(Vec3f(40, 0, 0))};
  v1::PlayAnimationRequest request;
  request.set_scene_id(id);
  *request.mutable_format() = frame_format(v1::RGBA32F_LINEAR);
  for (const Affine& placed : placements) {
    v1::Keyframe& keyframe = *request.add_keyframes();
    keyframe.set_keep_lights(true);
    keyframe.set_passes(2);
    for (const std::string& name : kTallBlock)
      *keyframe.add_meshes() = wire::encode_mesh_change({name, placed, std::nullopt, std::nullopt});
  }
  std::vector<StreamedFrame> frames;
  const grpc::Status status = play_animation(*stub, request, &frames);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(frames.size(), 2u);
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].header.epochs().geometry(), info.epochs().geometry() + 1 + i);
    Scene moved = box();
    for (Mesh& mesh : moved.meshes) {
      for (const std::string& name : kTallBlock)
        if (mesh.name == name) transform_mesh(placements[i], &mesh);
    }
    const std::string twin = upload_scene(*stub, moved, "moved");
    EXPECT_EQ(frame_floats(frames[i].data), render_linear(*stub, twin, 2)) << "keyframe " << i;
  }
}

// Every keyframe is checked before the first plays: a mesh the scene lacks in the last keyframe
// is refused by its keyframe and field, no frame is sent and nothing changes.
TEST(ServerGeometry, AnAnimationWithABadKeyframeChangesNothing) {
  auto server = ServerProcess::start();
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const std::string id = upload_scene(*stub, box(), "box");
  const v1::SceneInfo info = get_scene(*stub, id);
  const std::vector<float> before = render_linear(*stub, id, 2);
  struct Case {
    const char* what;
    std::function<void(v1::Keyframe&)> spoil;
    grpc::StatusCode code;
    const char* message;
  };
  const Case cases[] = {
      {"unknown mesh", [](auto& k) { k.mutable_meshes(0)->set_mesh("no such mesh"); },
       grpc::StatusCode::NOT_FOUND, "keyframes[2].meshes[0].mesh: the scene has no mesh named"},
      {"short transform", [](auto& k) { k.mutable_meshes(0)->mutable_transform()->RemoveLast(); },
       grpc::StatusCode::INVALID_ARGUMENT, "keyframes[2].meshes[0].transform: has 11 numbers"},
      {"lights with keep_lights", [](auto& k) { k.add_lights()->set_type(v1::Light::POINT); },
       grpc::StatusCode::INVALID_ARGUMENT, "keyframes[2].lights: must be empty with keep_lights"},
      {"unknown emitter",
       [](auto& k) {
         v1::Emitter& emitter = *k.add_emitters();
         emitter.set_material("no such material");
         emitter.set_off(true);
       },
       grpc::StatusCode::INVALID_ARGUMENT, "keyframes[2].emitters[0]"},
  };
  for (const Case& c : cases) {
    v1::PlayAnimationRequest request;
    request.set_scene_id(id);
    *request.mutable_format() = frame_format(v1::RGBA32F_LINEAR);
    for (int i = 0; i < 3; ++i) {
      v1::Keyframe& keyframe = *request.add_keyframes();
      keyframe.set_keep_lights(true);
      *keyframe.add_meshes() = wire::encode_mesh_change(
          {kTallBlock[0], translation(Vec3f(10.0f * i, 0, 0)), std::nullopt, std::nullopt});
    }
    c.spoil(*request.mutable_keyframes(2));
    std::vector<StreamedFrame> frames;
    const grpc::Status status = play_animation(*stub, request, &frames);
    EXPECT_EQ(status.error_code(), c.code) << c.what << ": " << status.error_message();
    EXPECT_NE(status.error_message().find(c.message), std::string::npos)
        << c.what << ": " << status.error_message();
    EXPECT_TRUE(frames.empty()) << c.what;
  }
  EXPECT_EQ(get_scene(*stub, id).epochs().SerializeAsString(), info.epochs().SerializeAsString());
  EXPECT_EQ(render_linear(*stub, id, 2), before);
}

// `caustica animate --gltf-animation` plays the bundled walking man: one frame a sample, each
// showing him elsewhere in his stride.
TEST(ServerGeometry, TheCliPlaysAGltfAnimation) {
  auto server = ServerProcess::start();
  ASSERT_NE(server, nullptr);
  const std::filesystem::path dir = make_temp_dir("caustica-gltf-animate");
  const std::string scene =
      (std::filesystem::path(CAUSTICA_SCENES_DIR) / "cesium-man" / "scene.json").string();
  const std::string cli = std::string("'") + CAUSTICA_CLIENT_BIN + "' --server " +
                          server->address() + " animate '" + scene + "' -o '" + dir.string() +
                          "' --format pfm --width 24 --height 16 --photons 3000 --fps 2 ";
  CommandRun run = run_command(cli + "--gltf-animation 0");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const std::string first = read_text_file(dir / "frame_0000.pfm");
  const std::string second = read_text_file(dir / "frame_0001.pfm");
  ASSERT_FALSE(first.empty()) << run.output;
  ASSERT_FALSE(second.empty()) << run.output;
  EXPECT_NE(first, second);
  EXPECT_TRUE(std::filesystem::exists(dir / "frame_0004.pfm")) << run.output;  // 2 s at 2 fps
  run = run_command(cli + "--gltf-animation Run");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("no animation named 'Run'"), std::string::npos) << run.output;
  std::filesystem::remove_all(dir);
}

// The caustics box, small, whose glass sphere has thousands of vertices: many chunks.
Scene caustics_box() {
  absl::StatusOr<Scene> scene =
      load_scene(std::filesystem::path(CAUSTICA_SCENES_DIR) / "cornell-caustics" / "scene.json");
  EXPECT_TRUE(scene.ok()) << scene.status();
  scene->camera.width = 24;
  scene->camera.height = 16;
  scene->settings.photons_per_pass = 3000;
  return *scene;
}

grpc::Status stream_geometry(v1::RenderService::Stub& stub,
                             const std::vector<v1::GeometryChunk>& chunks,
                             v1::RebuildReport* report) {
  grpc::ClientContext context;
  set_deadline(context);
  std::unique_ptr<grpc::ClientWriter<v1::GeometryChunk>> writer =
      stub.StreamGeometry(&context, report);
  for (const v1::GeometryChunk& chunk : chunks) {
    if (!writer->Write(chunk)) break;
  }
  writer->WritesDone();
  return writer->Finish();
}

// A sphere's vertices streamed in 1 KiB chunks render as the scene uploaded with them; broken
// streams are refused by name and change nothing.
TEST(ServerGeometry, StreamedVerticesRenderAsTheSceneUploadedWithThem) {
  auto server = ServerProcess::start();
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const Scene scene = caustics_box();
  const std::string id = upload_scene(*stub, scene, "caustics");
  const v1::SceneInfo info = get_scene(*stub, id);
  const std::vector<float> before = render_linear(*stub, id, 2);
  size_t sphere = 0;
  while (scene.meshes[sphere].name != "shapes[6] 'glass sphere'") ++sphere;
  std::vector<Vec3f> squashed = scene.meshes[sphere].positions;
  for (Vec3f& p : squashed) p.y = 0.5f * p.y;
  const MeshChange change{"glass sphere", std::nullopt, squashed, std::nullopt};
  const std::vector<v1::GeometryChunk> chunks =
      client::geometry_chunks(id, change, std::nullopt, 1024);
  ASSERT_GT(chunks.size(), 10u);

  struct Case {
    const char* what;
    std::function<void(std::vector<v1::GeometryChunk>&)> spoil;
    const char* message;
  };
  const Case cases[] = {
      {"bad checksum", [](auto& c) { c[3].mutable_mesh()->set_crc32(c[3].mesh().crc32() ^ 1); },
       "meshes[0].positions: checksum"},
      {"a chunk left out", [](auto& c) { c.erase(c.begin() + 4); }, "meshes[0].positions: offset"},
      {"the request last", [](auto& c) { std::rotate(c.begin(), c.begin() + 1, c.end()); },
       "mesh: arrives before the request"},
      {"inline and chunked",
       [](auto& c) { c[0].mutable_request()->mutable_meshes(0)->add_positions(1); },
       "meshes[0].positions: comes both in the request and in chunks"},
      {"too few vertices", [](auto& c) { c.pop_back(); }, "meshes[0].positions: "},
      {"not a vertex array",
       [](auto& c) { c[2].mutable_mesh()->set_array(v1::MeshChunk::INDICES); },
       "mesh.array: INDICES does not change"},
  };
  for (const Case& c : cases) {
    std::vector<v1::GeometryChunk> spoilt = chunks;
    c.spoil(spoilt);
    v1::RebuildReport report;
    const grpc::Status status = stream_geometry(*stub, spoilt, &report);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT)
        << c.what << ": " << status.error_message();
    EXPECT_NE(status.error_message().find(c.message), std::string::npos)
        << c.what << ": " << status.error_message();
  }
  EXPECT_EQ(get_scene(*stub, id).epochs().SerializeAsString(), info.epochs().SerializeAsString());
  EXPECT_EQ(render_linear(*stub, id, 2), before);

  v1::RebuildReport report;
  const grpc::Status status = stream_geometry(*stub, chunks, &report);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(report.epochs().geometry(), info.epochs().geometry() + 1);
  Scene reshaped = scene;
  reshaped.meshes[sphere].positions = squashed;
  reshaped.meshes[sphere].normals.clear();
  reshaped.meshes[sphere].tangents.clear();
  const std::string twin = upload_scene(*stub, reshaped, "squashed");
  EXPECT_EQ(render_linear(*stub, id, 2), render_linear(*stub, twin, 2));
}

// `caustica mesh reshape` streams a model file's vertices: the box's floor raised by a PLY file
// of its four corners.
TEST(ServerGeometry, TheCliReshapesAMeshFromAFile) {
  auto server = ServerProcess::start();
  ASSERT_NE(server, nullptr);
  auto stub = server->stub();
  const std::string id = upload_scene(*stub, box(), "box");
  const std::filesystem::path dir = make_temp_dir("caustica-reshape");
  const std::vector<Vec3f> raised = floor_raised();
  {
    std::ofstream ply(dir / "floor.ply");
    ply << "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
           "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
           "end_header\n";
    for (const Vec3f& p : raised) ply << p.x << " " << p.y << " " << p.z << "\n";
    ply << "4 0 1 2 3\n";
  }
  const std::string cli =
      std::string("'") + CAUSTICA_CLIENT_BIN + "' --server " + server->address() + " ";
  CommandRun run = run_command(cli + "mesh reshape " + id + " floor --from '" +
                               (dir / "floor.ply").string() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("geometry"), std::string::npos) << run.output;
  Scene expected = box();
  expected.meshes[0].positions = raised;
  expected.meshes[0].normals.clear();
  expected.meshes[0].tangents.clear();
  const std::string twin = upload_scene(*stub, expected, "raised");
  EXPECT_EQ(render_linear(*stub, id, 1), render_linear(*stub, twin, 1));
  run = run_command(cli + "mesh reshape " + id + " nothing --from '" +
                    (dir / "floor.ply").string() + "'");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("the scene has no mesh named 'nothing'"), std::string::npos)
      << run.output;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace caustica::testing
