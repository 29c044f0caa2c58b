// Bad requests get the documented status and a message naming the field, nothing of a refused
// call stays behind, and the server keeps serving afterwards.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <memory>

#include "proto/wire/scene_wire.h"
#include "renderer/parallel/backend.h"
#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

// Index of the first mesh chunk carrying `array`.
size_t first_chunk(const std::vector<v1::SceneChunk>& chunks, v1::MeshChunk::Array array) {
  for (size_t i = 0; i < chunks.size(); ++i) {
    if (chunks[i].has_mesh() && chunks[i].mesh().array() == array) return i;
  }
  ADD_FAILURE() << "no chunk of array " << array;
  return 0;
}

// Overwrites the first 4 bytes of a chunk's data and fixes its checksum, so only the content is
// wrong.
void poke(v1::SceneChunk& chunk, const void* value) {
  std::string data = chunk.mesh().data();
  std::memcpy(data.data(), value, 4);
  chunk.mutable_mesh()->set_crc32(wire::chunk_crc32(data));
  chunk.mutable_mesh()->set_data(data);
}

size_t resident_scenes(v1::RenderService::Stub& stub) {
  grpc::ClientContext context;
  v1::ListScenesResponse list;
  EXPECT_TRUE(stub.ListScenes(&context, {}, &list).ok());
  return list.scenes_size();
}

// A unary call whose request carries only `scene_id`.
template <typename Request, typename Response, typename Method>
grpc::Status call_with_scene_id(v1::RenderService::Stub& stub, Method method,
                                const std::string& scene_id) {
  grpc::ClientContext context;
  set_deadline(context);
  Request request;
  request.set_scene_id(scene_id);
  Response response;
  return (stub.*method)(&context, request, &response);
}

struct BadUpload {
  const char* what;
  std::function<void(std::vector<v1::SceneChunk>&)> spoil;
  grpc::StatusCode code;
  const char* message;  // a part of the error message that names the problem
};

TEST_F(ServerTest, MalformedUploadsAreRefusedNamingTheProblem) {
  const std::vector<v1::SceneChunk> good = scene_chunks(cornell_box(16, 16, 2000, 16, 1), "box");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const uint32_t far_vertex = 9999;
  // A homogeneous medium named fog, added to the header.
  auto add_fog = [](std::vector<v1::SceneChunk>& c) {
    v1::Medium* fog = c[0].mutable_header()->add_media();
    fog->set_name("fog");
    fog->set_type(v1::Medium::HOMOGENEOUS);
    return fog;
  };
  const std::vector<BadUpload> cases = {
      {"bad crc", [](auto& c) { c[1].mutable_mesh()->set_crc32(c[1].mesh().crc32() ^ 1); },
       grpc::StatusCode::INVALID_ARGUMENT, "mesh.crc32"},
      {"offset gap", [](auto& c) { c[1].mutable_mesh()->set_offset(12); },
       grpc::StatusCode::INVALID_ARGUMENT, "mesh.offset"},
      {"chunk over 1 MiB",
       [](auto& c) {
         std::string big((size_t{1} << 20) + 12, '\0');
         c[1].mutable_mesh()->set_data(big);
         c[1].mutable_mesh()->set_crc32(wire::chunk_crc32(big));
       },
       grpc::StatusCode::INVALID_ARGUMENT, "chunk limit"},
      {"chunk before header", [](auto& c) { c.erase(c.begin()); },
       grpc::StatusCode::INVALID_ARGUMENT, "before the scene header"},
      {"counts disagree",
       [](auto& c) {
         auto* mesh = c[0].mutable_header()->mutable_meshes(0);
         mesh->set_vertex_count(mesh->vertex_count() + 1);
       },
       grpc::StatusCode::INVALID_ARGUMENT, "header declares"},
      {"index out of range",
       [&](auto& c) { poke(c[first_chunk(c, v1::MeshChunk::INDICES)], &far_vertex); },
       grpc::StatusCode::INVALID_ARGUMENT, "refers to vertex 9999"},
      {"NaN vertex", [&](auto& c) { poke(c[first_chunk(c, v1::MeshChunk::POSITIONS)], &nan); },
       grpc::StatusCode::INVALID_ARGUMENT, "not finite"},
      {"width 0", [](auto& c) { c[0].mutable_header()->mutable_camera()->set_width(0); },
       grpc::StatusCode::INVALID_ARGUMENT, "camera.width"},
      {"height 100000",
       [](auto& c) { c[0].mutable_header()->mutable_camera()->set_height(100000); },
       grpc::StatusCode::INVALID_ARGUMENT, "camera.height"},
      {"material without a type",
       [](auto& c) {
         for (auto& m : *c[0].mutable_header()->mutable_materials())
           m.set_type(v1::Material::TYPE_UNSPECIFIED);
       },
       grpc::StatusCode::INVALID_ARGUMENT, "materials[0]"},
      {"vertex count over the limit",
       [](auto& c) {
         c[0].mutable_header()->mutable_meshes(0)->set_vertex_count(uint64_t{1} << 40);
       },
       grpc::StatusCode::RESOURCE_EXHAUSTED, "vertex_count"},
      {"empty stream", [](auto& c) { c.clear(); }, grpc::StatusCode::INVALID_ARGUMENT, "header"},
      {"medium with g = 1",
       [&](auto& c) {
         add_fog(c)->set_g(1.0f);
         c[0].mutable_header()->set_medium(1);
       },
       grpc::StatusCode::INVALID_ARGUMENT, "media.fog.g: 1 is outside (-1, 1)"},
      {"open mesh enclosing a medium",
       [&](auto& c) {
         add_fog(c);
         c[0].mutable_header()->mutable_meshes(0)->set_interior_medium(1);
       },
       grpc::StatusCode::INVALID_ARGUMENT, "encloses medium 'fog' but is not closed"},
      {"a medium with an estimator that does not render media",
       [&](auto& c) {
         add_fog(c);
         c[0].mutable_header()->set_medium(1);
         c[0].mutable_header()->mutable_settings()->set_estimator(v1::SPPM);
       },
       grpc::StatusCode::UNIMPLEMENTED, "does not render participating media"},
  };
  for (const BadUpload& bad : cases) {
    SCOPED_TRACE(bad.what);
    std::vector<v1::SceneChunk> chunks = good;
    bad.spoil(chunks);
    v1::SceneInfo info;
    const grpc::Status status = upload(*stub_, chunks, &info);
    EXPECT_EQ(status.error_code(), bad.code) << status.error_message();
    EXPECT_NE(status.error_message().find(bad.message), std::string::npos)
        << status.error_message();
    EXPECT_TRUE(info.scene_id().empty());
  }
  EXPECT_EQ(resident_scenes(*stub_), 0u) << "a refused upload keeps nothing";
  expect_server_healthy(*server_);
}

// A textured model's files reach the server and are decoded there; a texture that does not decode
// is refused by name, with nothing kept and the server serving on.
TEST_F(ServerTest, TexturesAreDecodedOnUploadAndABrokenOneIsRefusedByName) {
  Scene scene = cornell_box(16, 16, 2000, 16, 1);
  std::ifstream in(std::filesystem::path(CAUSTICA_TEST_DATA) /
                       "scene/thirdparty/gltf2/BoxTextured/CesiumLogoFlat.png",
                   std::ios::binary);
  const std::string png{std::istreambuf_iterator<char>(in), {}};
  ASSERT_GT(png.size(), 1000u);
  scene.textures.push_back({"CesiumLogoFlat.png", std::make_shared<const std::string>(png), {}});
  scene.materials.at(0).color_map.texture = 0;
  const std::string id = upload_scene(*stub_, scene, "textured");
  const v1::SceneInfo info = get_scene(*stub_, id);
  ASSERT_EQ(info.textures_size(), 1);
  EXPECT_EQ(info.textures(0).name(), "CesiumLogoFlat.png");
  EXPECT_EQ(info.textures(0).width(), 211u);
  EXPECT_EQ(info.textures(0).height(), 211u);
  EXPECT_FALSE(info.textures(0).is_float());
  EXPECT_EQ(info.textures(0).decoded_bytes(), 211u * 211u * 4u);
  delete_scene(*stub_, id);

  scene.textures[0].encoded = std::make_shared<const std::string>(png.substr(0, png.size() / 2));
  v1::SceneInfo refused;
  const grpc::Status status = upload(*stub_, scene_chunks(scene, "broken"), &refused);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(
      status.error_message().find("textures[0] 'CesiumLogoFlat.png': not a readable PNG image"),
      std::string::npos)
      << status.error_message();
  EXPECT_TRUE(refused.scene_id().empty());
  EXPECT_EQ(resident_scenes(*stub_), 0u) << "a refused upload keeps nothing";
  expect_server_healthy(*server_);
}

TEST_F(ServerTest, UnknownSceneIsNotFound) {
  const std::string missing = "s-00000000";
  auto expect_not_found = [&](const grpc::Status& status, const char* call) {
    EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND) << call;
    EXPECT_NE(status.error_message().find("scene_id"), std::string::npos)
        << call << ": " << status.error_message();
    EXPECT_NE(status.error_message().find(missing), std::string::npos) << call;
  };
  using Stub = v1::RenderService::Stub;
  expect_not_found(
      call_with_scene_id<v1::GetSceneRequest, v1::SceneInfo>(*stub_, &Stub::GetScene, missing),
      "GetScene");
  expect_not_found(call_with_scene_id<v1::DeleteSceneRequest, v1::DeleteSceneResponse>(
                       *stub_, &Stub::DeleteScene, missing),
                   "DeleteScene");
  expect_not_found(call_with_scene_id<v1::UpdateLightsRequest, v1::RebuildReport>(
                       *stub_, &Stub::UpdateLights, missing),
                   "UpdateLights");
  expect_not_found(call_with_scene_id<v1::UpdateCameraRequest, v1::RebuildReport>(
                       *stub_, &Stub::UpdateCamera, missing),
                   "UpdateCamera");
  expect_not_found(call_with_scene_id<v1::UpdateSettingsRequest, v1::RebuildReport>(
                       *stub_, &Stub::UpdateSettings, missing),
                   "UpdateSettings");
  {
    v1::Frame frame;
    expect_not_found(render_frame(*stub_, missing, 1, {}, &frame), "RenderFrame");
  }
  std::vector<StreamedFrame> frames;
  {
    v1::StreamFramesRequest request;
    request.set_scene_id(missing);
    expect_not_found(stream_frames(*stub_, request, &frames), "StreamFrames");
    EXPECT_TRUE(frames.empty());
  }
  {
    v1::PlayAnimationRequest request;
    request.set_scene_id(missing);
    expect_not_found(play_animation(*stub_, request, &frames), "PlayAnimation");
    EXPECT_TRUE(frames.empty());
  }
  const grpc::Status empty =
      call_with_scene_id<v1::GetSceneRequest, v1::SceneInfo>(*stub_, &Stub::GetScene, "");
  EXPECT_EQ(empty.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(empty.error_message().find("scene_id"), std::string::npos);
  expect_server_healthy(*server_);
}

TEST_F(ServerTest, BadUpdatesNameTheFieldAndChangeNothing) {
  const std::string id = upload_scene(*stub_, cornell_box(16, 16, 2000, 16, 1));
  const v1::SceneInfo before = get_scene(*stub_, id);
  auto expect_invalid = [](const grpc::Status& status, const char* field) {
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << field;
    EXPECT_NE(status.error_message().find(field), std::string::npos)
        << field << ": " << status.error_message();
  };
  v1::RebuildReport report;
  for (uint32_t width : {0u, 100000u}) {
    grpc::ClientContext context;
    v1::UpdateCameraRequest request;
    request.set_scene_id(id);
    *request.mutable_camera() = before.camera();
    request.mutable_camera()->set_width(width);
    expect_invalid(stub_->UpdateCamera(&context, request, &report), "camera.width");
  }
  {
    grpc::ClientContext context;
    v1::UpdateCameraRequest request;
    request.set_scene_id(id);
    expect_invalid(stub_->UpdateCamera(&context, request, &report), "camera");
  }
  {
    grpc::ClientContext context;
    v1::UpdateSettingsRequest request;
    request.set_scene_id(id);
    request.set_height(100000);
    expect_invalid(stub_->UpdateSettings(&context, request, &report), "height");
  }
  {
    grpc::ClientContext context;
    v1::UpdateSettingsRequest request;
    request.set_scene_id(id);
    request.mutable_settings()->set_k_nearest(0);
    expect_invalid(stub_->UpdateSettings(&context, request, &report), "settings.k");
  }
  {
    grpc::ClientContext context;
    v1::UpdateLightsRequest request;
    request.set_scene_id(id);
    *request.add_lights() = point_light(1e5f);
    *request.add_lights() = point_light(1e5f);
    request.mutable_lights(1)->mutable_position()->set_y(std::numeric_limits<float>::quiet_NaN());
    expect_invalid(stub_->UpdateLights(&context, request, &report), "lights[1]");
  }
  {
    v1::PlayAnimationRequest request;
    request.set_scene_id(id);
    request.add_keyframes();
    *request.add_keyframes()->add_lights() = point_light(1e5f);
    request.mutable_keyframes(1)->mutable_lights(0)->set_type(v1::Light::TYPE_UNSPECIFIED);
    std::vector<StreamedFrame> frames;
    expect_invalid(play_animation(*stub_, request, &frames), "keyframes[1].lights[0]");
    EXPECT_TRUE(frames.empty()) << "a bad script plays no keyframe";
  }
  {
    v1::Frame frame;
    expect_invalid(render_frame(*stub_, id, 1, frame_format(v1::RGBA8_SRGB, v1::EXR), &frame),
                   "format.encoding");
  }
  const v1::SceneInfo after = get_scene(*stub_, id);
  EXPECT_EQ(after.epochs().SerializeAsString(), before.epochs().SerializeAsString());
  EXPECT_EQ(after.camera().SerializeAsString(), before.camera().SerializeAsString());
  EXPECT_EQ(after.settings().SerializeAsString(), before.settings().SerializeAsString());
  expect_server_healthy(*server_);
}

TEST_F(ServerTest, UnknownStructureIsRefusedAndTheSceneKeepsRendering) {
  const std::string id = upload_scene(*stub_, cornell_box(16, 16, 2000, 16, 1));
  const v1::SceneInfo before = get_scene(*stub_, id);
  v1::UpdateSettingsRequest request;
  request.set_scene_id(id);
  request.mutable_settings()->set_k_nearest(8);
  request.mutable_settings()->set_structure(static_cast<v1::Structure>(99));
  v1::RebuildReport report;
  {
    grpc::ClientContext context;
    set_deadline(context);
    const grpc::Status status = stub_->UpdateSettings(&context, request, &report);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("settings.structure"), std::string::npos)
        << status.error_message();
  }
  // Nothing of the refused request applies, not even its valid k.
  const v1::SceneInfo after = get_scene(*stub_, id);
  EXPECT_EQ(after.epochs().SerializeAsString(), before.epochs().SerializeAsString());
  EXPECT_EQ(after.settings().SerializeAsString(), before.settings().SerializeAsString());
  EXPECT_EQ(after.structure(), before.structure());
  EXPECT_EQ(after.structure_nodes(), before.structure_nodes());
  EXPECT_EQ(after.structure_bytes(), before.structure_bytes());
  EXPECT_EQ(after.triangles(), before.triangles());

  v1::Frame frame;
  const grpc::Status rendered =
      render_frame(*stub_, id, 1, frame_format(v1::RGBA32F_LINEAR), &frame);
  ASSERT_TRUE(rendered.ok()) << rendered.error_message();
  EXPECT_EQ(frame.epochs().SerializeAsString(), before.epochs().SerializeAsString());
  EXPECT_GT(mean_rgb(frame_floats(frame)), 0.01) << "the image should not be black";
  expect_server_healthy(*server_);
}

class SmallBudgetTest : public ServerTest {
 protected:
  std::vector<std::string> server_args() const override {
    return {"--memory-budget", "2M", "--max-scenes", "3"};
  }
};

TEST_F(SmallBudgetTest, ScenesOverTheBudgetOrLimitsAreResourceExhausted) {
  // Declared mesh data beyond the budget: refused right after the header, before any data.
  {
    std::vector<v1::SceneChunk> chunks = scene_chunks(cornell_box(16, 16, 2000, 16, 1), "big");
    chunks[0].mutable_header()->mutable_meshes(0)->set_vertex_count(1000000);  // 12 MB
    chunks.resize(1);
    v1::SceneInfo info;
    const grpc::Status status = upload(*stub_, chunks, &info);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
    EXPECT_NE(status.error_message().find("--memory-budget"), std::string::npos)
        << status.error_message();
  }
  // Small geometry but a film (32 bytes a pixel and more) far beyond 2 MiB: the build fails.
  {
    v1::SceneInfo info;
    const grpc::Status status =
        upload(*stub_, scene_chunks(cornell_box(1024, 1024, 2000, 16, 1), "wide"), &info);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  }
  EXPECT_EQ(resident_scenes(*stub_), 0u);
  v1::Stats stats;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(stub_->GetStats(&context, {}, &stats).ok());
  }
  EXPECT_EQ(stats.memory_used_bytes(), 0u) << "a failed build frees what it allocated";

  // --max-scenes 3.
  std::vector<std::string> ids;
  for (int i = 0; i < 3; ++i) ids.push_back(upload_scene(*stub_, cornell_box(8, 8, 500, 8, 1)));
  v1::SceneInfo info;
  const grpc::Status full =
      upload(*stub_, scene_chunks(cornell_box(8, 8, 500, 8, 1), "4th"), &info);
  EXPECT_EQ(full.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(full.error_message().find("--max-scenes"), std::string::npos) << full.error_message();
  {
    grpc::ClientContext context;
    v1::DeleteSceneRequest del;
    del.set_scene_id(ids[0]);
    v1::DeleteSceneResponse response;
    ASSERT_TRUE(stub_->DeleteScene(&context, del, &response).ok());
  }
  EXPECT_FALSE(upload_scene(*stub_, cornell_box(8, 8, 500, 8, 1)).empty())
      << "deleting a scene makes room";
  EXPECT_TRUE(health_serving(server_->channel()));
}

// A device that runs out of memory within the budget (the budget is larger than what is free),
// simulated by the backends' fault-injection hook: every allocation above 16 MiB fails as a
// device's would. The call gets RESOURCE_EXHAUSTED naming it, nothing of it stays, and the
// server keeps serving its other scenes.
class DeviceOutOfMemoryTest : public ServerTest {
 protected:
  void SetUp() override {
    setenv(kFailAllocationsAboveVariable, "16777216", 1);
    ServerTest::SetUp();
    unsetenv(kFailAllocationsAboveVariable);
  }
};

TEST_F(DeviceOutOfMemoryTest, AnAllocationTheDeviceRefusesIsResourceExhausted) {
  const std::string id = upload_scene(*stub_, cornell_box(32, 24, 2000, 16, 1));
  // A 2048 x 2048 film's accumulators alone are 64 MiB.
  v1::SceneInfo info;
  const grpc::Status upload_status =
      upload(*stub_, scene_chunks(cornell_box(2048, 2048, 2000, 16, 1), "wide"), &info);
  EXPECT_EQ(upload_status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(upload_status.error_message().find("the device is out of memory"), std::string::npos)
      << upload_status.error_message();
  EXPECT_EQ(resident_scenes(*stub_), 1u);

  // A resize the device cannot hold changes neither the size nor the settings.
  {
    grpc::ClientContext context;
    v1::UpdateSettingsRequest request;
    request.set_scene_id(id);
    request.set_width(2048);
    request.set_height(2048);
    request.mutable_settings()->set_k_nearest(24);
    v1::RebuildReport report;
    const grpc::Status status = stub_->UpdateSettings(&context, request, &report);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  }
  const v1::SceneInfo kept = get_scene(*stub_, id);
  EXPECT_EQ(kept.camera().width(), 32u);
  EXPECT_EQ(kept.settings().k_nearest(), 16u);
  v1::Frame frame;
  EXPECT_TRUE(render_frame(*stub_, id, 1, frame_format(v1::RGBA32F_LINEAR), &frame).ok());
  expect_server_healthy(*server_);
}

class SmallMessageTest : public ServerTest {
 protected:
  std::vector<std::string> server_args() const override { return {"--max-message-mb", "1"}; }
};

TEST_F(SmallMessageTest, FramesOverTheMessageLimitMustBeStreamed) {
  const std::string id = upload_scene(*stub_, cornell_box(256, 256, 500, 8, 1));
  v1::Frame frame;
  const grpc::Status refused =
      render_frame(*stub_, id, 1, frame_format(v1::RGBA32F_LINEAR), &frame);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_NE(refused.error_message().find("StreamFrames"), std::string::npos);

  v1::StreamFramesRequest request;
  request.set_scene_id(id);
  *request.mutable_format() = frame_format(v1::RGBA32F_LINEAR);
  request.set_max_chunk_bytes(64 << 20);  // clamped to fit the 1 MiB message limit
  std::vector<StreamedFrame> frames;
  ASSERT_TRUE(stream_frames(*stub_, request, &frames).ok());
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].data.size(), 256u * 256u * 16u);
  EXPECT_EQ(frames[0].pieces, 2);
}

}  // namespace
}  // namespace caustica::testing
