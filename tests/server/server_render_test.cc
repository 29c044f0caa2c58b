// End to end over loopback: frames from the real caustica-server against caustica-render, light,
// camera and settings updates, progressive and chunked streams, animations, formats, statistics
// and concurrent clients.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "proto/wire/scene_wire.h"
#include "renderer/accel/structure_kind.h"
#include "server/frame_encoding.h"
#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

TEST_F(ServerTest, RendersTheSameImageAsCausticaRender) {
  const int size = 48;
  const uint32_t photons = 5000, k = 16, passes = 2, seed = 7;
  const std::filesystem::path pfm = server_->dir() / "reference.pfm";
  const std::string command =
      absl::StrCat("'", CAUSTICA_RENDER_BIN, "' '", CAUSTICA_SCENES_DIR,
                   "/cornell-box/scene.json' -o '", pfm.string(), "' --width ", size, " --height ",
                   size, " --photons ", photons, " --k ", k, " --passes ", passes, " --seed ", seed,
                   " > '", (server_->dir() / "render.log").string(), "' 2>&1");
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  const PfmImage reference = read_pfm(pfm);
  ASSERT_EQ(reference.width, size);
  ASSERT_EQ(reference.height, size);

  const std::string id = upload_scene(*stub_, cornell_box(size, size, photons, k, seed), "box");
  v1::Frame frame;
  const grpc::Status status =
      render_frame(*stub_, id, passes, frame_format(v1::RGBA32F_LINEAR), &frame);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(frame.scene_id(), id);
  EXPECT_EQ(frame.width(), uint32_t(size));
  EXPECT_EQ(frame.height(), uint32_t(size));
  EXPECT_EQ(frame.passes(), passes);
  EXPECT_EQ(frame.pixel_format(), v1::RGBA32F_LINEAR);
  EXPECT_EQ(frame.encoding(), v1::RAW);
  EXPECT_EQ(frame.data_size(), uint64_t(size) * size * 16);
  EXPECT_EQ(frame.data_offset(), 0u);
  EXPECT_TRUE(frame.last_chunk());
  EXPECT_GT(frame.photons_emitted(), 0u);
  EXPECT_GT(frame.timings().render_ms(), 0);

  const std::vector<float> pixels = frame_floats(frame);
  ASSERT_EQ(pixels.size(), size_t(size) * size * 4);
  // Same seed, same engine: the server's passes must give caustica-render's image bit for bit.
  size_t mismatches = 0;
  for (size_t p = 0; p < size_t(size) * size; ++p) {
    for (int c = 0; c < 3; ++c) {
      const float expected = reference.rgb[3 * p + c];
      const float got = pixels[4 * p + c];
      if (got != expected) ++mismatches;
    }
    EXPECT_EQ(pixels[4 * p + 3], 1.0f);
  }
  EXPECT_EQ(mismatches, 0u) << "of " << size * size * 3 << " channels";
  EXPECT_GT(mean_rgb(pixels), 0.01) << "the image should not be black";
}

TEST_F(ServerTest, LightUpdateChangesTheImageAndTheEpochs) {
  const std::string id = upload_scene(*stub_, cornell_box(24, 24, 3000, 16, 1));
  v1::Frame before;
  ASSERT_TRUE(render_frame(*stub_, id, 1, frame_format(v1::RGBA32F_LINEAR), &before).ok());

  v1::UpdateLightsRequest request;
  request.set_scene_id(id);
  *request.add_lights() = point_light(2e5f);
  request.set_expected_lights_epoch(before.epochs().lights());
  v1::RebuildReport report;
  {
    grpc::ClientContext context;
    set_deadline(context);
    const grpc::Status status = stub_->UpdateLights(&context, request, &report);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  EXPECT_EQ(report.epochs().lights(), before.epochs().lights() + 1);
  EXPECT_EQ(report.epochs().geometry(), before.epochs().geometry());
  EXPECT_EQ(report.epochs().camera(), before.epochs().camera());
  EXPECT_GT(report.photons_emitted(), 0u);
  EXPECT_NE(std::find(report.rebuilt().begin(), report.rebuilt().end(), "photon_maps"),
            report.rebuilt().end());

  v1::Frame after;
  ASSERT_TRUE(render_frame(*stub_, id, 1, frame_format(v1::RGBA32F_LINEAR), &after).ok());
  EXPECT_EQ(after.epochs().lights(), before.epochs().lights() + 1);
  EXPECT_EQ(after.passes(), 1u) << "the light change restarts accumulation";
  EXPECT_GT(mean_rgb(frame_floats(after)), 1.2 * mean_rgb(frame_floats(before)));

  // The same expected epoch again is stale now.
  grpc::ClientContext context;
  set_deadline(context);
  const grpc::Status stale = stub_->UpdateLights(&context, request, &report);
  EXPECT_EQ(stale.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(stale.error_message().find("expected_lights_epoch"), std::string::npos);

  const v1::SceneInfo info = get_scene(*stub_, id);
  EXPECT_EQ(info.lights(), 1u);
  EXPECT_EQ(info.epochs().lights(), after.epochs().lights())
      << "the refused update changed nothing";
}

TEST_F(ServerTest, StreamFramesRefinesProgressivelyInChunks) {
  const std::string id = upload_scene(*stub_, cornell_box(64, 64, 2000, 16, 3));
  v1::StreamFramesRequest request;
  request.set_scene_id(id);
  request.set_target_passes(3);
  request.set_passes_per_frame(1);
  *request.mutable_format() = frame_format(v1::RGBA32F_LINEAR);
  request.set_max_chunk_bytes(20000);  // 65536-byte frames in 4 pieces
  std::vector<StreamedFrame> frames;
  const grpc::Status status = stream_frames(*stub_, request, &frames);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(frames.size(), 3u);
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].header.frame_number(), i);
    EXPECT_EQ(frames[i].header.passes(), i + 1);
    EXPECT_EQ(frames[i].pieces, 4);
    EXPECT_EQ(frames[i].data.size(), 64u * 64u * 16u);
  }
  // The film now holds 3 passes: a unary frame at 3 passes resolves it without rendering more.
  v1::Frame unary;
  ASSERT_TRUE(render_frame(*stub_, id, 3, frame_format(v1::RGBA32F_LINEAR), &unary).ok());
  EXPECT_EQ(unary.passes(), 3u);
  EXPECT_EQ(unary.data(), frames.back().data);
  EXPECT_NE(frames[0].data, frames[2].data) << "later passes refine the image";
}

// A chunk size of one byte would make a message of every byte of the frame, all held at once.
TEST_F(ServerTest, StreamFramesRaisesATinyChunkSizeToTheMinimum) {
  const std::string id = upload_scene(*stub_, cornell_box(256, 256, 500, 8, 1));
  v1::StreamFramesRequest request;
  request.set_scene_id(id);
  *request.mutable_format() = frame_format(v1::RGBA32F_LINEAR);
  request.set_max_chunk_bytes(1);
  std::vector<StreamedFrame> frames;
  const grpc::Status status = stream_frames(*stub_, request, &frames);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(frames.size(), 1u);
  const size_t bytes = 256 * 256 * 16;
  EXPECT_EQ(static_cast<size_t>(frames[0].pieces),
            (bytes + server::kMinChunkBytes - 1) / server::kMinChunkBytes);
  ASSERT_EQ(frames[0].data.size(), bytes);

  v1::Frame unary;
  ASSERT_TRUE(render_frame(*stub_, id, 1, frame_format(v1::RGBA32F_LINEAR), &unary).ok());
  EXPECT_TRUE(frames[0].data == unary.data()) << "the pieces reassemble to the frame";
}

TEST_F(ServerTest, ConcurrentLightChangeRestartsAStream) {
  const std::string id = upload_scene(*stub_, cornell_box(16, 16, 2000, 16, 3));
  v1::StreamFramesRequest request;
  request.set_scene_id(id);
  request.set_target_passes(100000);  // cancelled long before
  *request.mutable_format() = frame_format(v1::RGBA32F_LINEAR);
  grpc::ClientContext context;
  set_deadline(context);
  auto reader = stub_->StreamFrames(&context, request);
  v1::Frame frame;
  ASSERT_TRUE(reader->Read(&frame));
  const uint64_t old_lights = frame.epochs().lights();

  auto other = server_->stub();
  v1::UpdateLightsRequest update;
  update.set_scene_id(id);
  *update.add_lights() = point_light(1e5f);
  v1::RebuildReport report;
  grpc::ClientContext update_context;
  set_deadline(update_context);
  ASSERT_TRUE(other->UpdateLights(&update_context, update, &report).ok());

  // Frames already in flight show the old state; then the first new frame has the new epoch and
  // a film restarted from its first pass.
  std::vector<uint32_t> new_passes;
  uint32_t last_old_passes = frame.passes();
  while (new_passes.size() < 3 && reader->Read(&frame)) {
    if (frame.epochs().lights() == old_lights) {
      EXPECT_EQ(frame.passes(), last_old_passes + 1);
      last_old_passes = frame.passes();
    } else {
      EXPECT_EQ(frame.epochs().lights(), report.epochs().lights());
      new_passes.push_back(frame.passes());
    }
  }
  EXPECT_EQ(new_passes, (std::vector<uint32_t>{1, 2, 3}));
  context.TryCancel();
  while (reader->Read(&frame)) {
  }
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
}

TEST_F(ServerTest, RepeatFramesResendsOneResolvedFrame) {
  const std::string id = upload_scene(*stub_, cornell_box(16, 16, 2000, 16, 3));
  v1::StreamFramesRequest request;
  request.set_scene_id(id);
  request.set_target_passes(2);
  request.set_repeat_frames(4);
  std::vector<StreamedFrame> frames;
  ASSERT_TRUE(stream_frames(*stub_, request, &frames).ok());
  ASSERT_EQ(frames.size(), 4u);
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].header.frame_number(), i);
    EXPECT_EQ(frames[i].header.passes(), 2u);
    EXPECT_EQ(frames[i].header.pixel_format(), v1::RGBA8_SRGB);
    EXPECT_EQ(frames[i].data, frames[0].data);
  }
  EXPECT_EQ(get_scene(*stub_, id).passes(), 2u) << "repeats must not render more";
}

TEST_F(ServerTest, PixelFormatsAndEncodingsAgree) {
  const std::string id = upload_scene(*stub_, cornell_box(20, 12, 3000, 16, 5));
  v1::Frame f32, f16, rgba8, png, exr;
  ASSERT_TRUE(render_frame(*stub_, id, 2, frame_format(v1::RGBA32F_LINEAR), &f32).ok());
  // The film already holds 2 passes: every later format resolves the same film.
  ASSERT_TRUE(render_frame(*stub_, id, 2, frame_format(v1::RGBA16F_LINEAR), &f16).ok());
  ASSERT_TRUE(render_frame(*stub_, id, 2, frame_format(v1::RGBA8_SRGB), &rgba8).ok());
  ASSERT_TRUE(render_frame(*stub_, id, 2, frame_format(v1::RGBA8_SRGB, v1::PNG), &png).ok());
  ASSERT_TRUE(render_frame(*stub_, id, 2, frame_format(v1::RGBA32F_LINEAR, v1::EXR), &exr).ok());

  const std::vector<float> linear = frame_floats(f32);
  ASSERT_EQ(f16.data().size(), linear.size() * 2);
  for (size_t i = 0; i < linear.size(); ++i) {
    uint16_t half;
    std::memcpy(&half, f16.data().data() + 2 * i, 2);
    ASSERT_EQ(half, caustica::float_to_half(linear[i])) << i;
  }
  EXPECT_EQ(rgba8.data().size(), 20u * 12u * 4u);
  // sRGB of the linear value, to within one step of rounding.
  for (size_t i = 0; i < linear.size(); ++i) {
    if (i % 4 == 3) {
      EXPECT_EQ(uint8_t(rgba8.data()[i]), 255);
      continue;
    }
    const float v = std::clamp(linear[i], 0.0f, 1.0f);
    const float srgb = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1 / 2.4f) - 0.055f;
    EXPECT_NEAR(uint8_t(rgba8.data()[i]), srgb * 255, 1.0) << i;
  }
  EXPECT_EQ(png.encoding(), v1::PNG);
  EXPECT_EQ(png.data().substr(1, 3), "PNG");
  EXPECT_EQ(exr.encoding(), v1::EXR);
  EXPECT_EQ(exr.data().substr(0, 4), std::string("\x76\x2f\x31\x01", 4)) << "EXR magic number";

  v1::Frame refused;
  const grpc::Status bad =
      render_frame(*stub_, id, 2, frame_format(v1::RGBA32F_LINEAR, v1::PNG), &refused);
  EXPECT_EQ(bad.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(bad.error_message().find("format.encoding"), std::string::npos) << bad.error_message();
}

TEST_F(ServerTest, PlayAnimationStreamsOneFramePerKeyframe) {
  const std::string id = upload_scene(*stub_, cornell_box(16, 16, 2000, 16, 2));
  v1::PlayAnimationRequest request;
  request.set_scene_id(id);
  *request.mutable_format() = frame_format(v1::RGBA32F_LINEAR);
  for (float intensity : {1e3f, 1e5f, 4e5f}) {
    v1::Keyframe* keyframe = request.add_keyframes();
    *keyframe->add_lights() = point_light(intensity);
    keyframe->set_passes(2);
  }
  std::vector<StreamedFrame> frames;
  const grpc::Status status = play_animation(*stub_, request, &frames);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(frames.size(), 3u);
  double previous_brightness = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].header.keyframe(), i);
    EXPECT_EQ(frames[i].header.frame_number(), i);
    EXPECT_EQ(frames[i].header.passes(), 2u);
    if (i > 0) {
      EXPECT_EQ(frames[i].header.epochs().lights(), frames[i - 1].header.epochs().lights() + 1);
    }
    const double brightness = mean_rgb(frame_floats(frames[i].data));
    EXPECT_GT(brightness, previous_brightness) << "keyframe " << i;
    previous_brightness = brightness;
  }
}

// A keyframe's camera moves the view before its frame and keeps the scene's size; a keyframe
// without one leaves the camera where it is.
TEST_F(ServerTest, PlayAnimationMovesTheCameraWhereAKeyframeSaysSo) {
  const std::string id = upload_scene(*stub_, cornell_box(16, 12, 2000, 16, 2));
  v1::PlayAnimationRequest request;
  request.set_scene_id(id);
  *request.mutable_format() = frame_format(v1::RGBA32F_LINEAR);
  for (int i = 0; i < 3; ++i) {
    v1::Keyframe* keyframe = request.add_keyframes();
    *keyframe->add_lights() = point_light(1e5f);
    if (i == 1) {
      // Into the box's back wall, from 1 mm away: nearly the whole frame is that one white wall.
      v1::Camera* camera = keyframe->mutable_camera();
      camera->mutable_position()->set_x(278);
      camera->mutable_position()->set_y(273);
      camera->mutable_position()->set_z(558);
      camera->mutable_look_at()->set_x(278);
      camera->mutable_look_at()->set_y(273);
      camera->mutable_look_at()->set_z(560);
      camera->mutable_up()->set_y(1);
      camera->set_vertical_fov_deg(10);
    }
  }
  std::vector<StreamedFrame> frames;
  const grpc::Status status = play_animation(*stub_, request, &frames);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[1].header.epochs().camera(), frames[0].header.epochs().camera() + 1);
  EXPECT_EQ(frames[2].header.epochs().camera(), frames[1].header.epochs().camera());
  for (const StreamedFrame& frame : frames) {
    EXPECT_EQ(frame.header.width(), 16u);
    EXPECT_EQ(frame.header.height(), 12u);
  }
  EXPECT_NE(frame_floats(frames[0].data), frame_floats(frames[1].data));
  EXPECT_EQ(get_scene(*stub_, id).camera().position().z(), 558.0f);
}

TEST_F(ServerTest, UpdateCameraAndSettings) {
  const std::string id = upload_scene(*stub_, cornell_box(16, 16, 2000, 16, 2));
  v1::UpdateSettingsRequest settings;
  settings.set_scene_id(id);
  settings.mutable_settings()->set_k_nearest(8);
  settings.set_width(24);
  settings.set_height(10);
  v1::RebuildReport report;
  {
    grpc::ClientContext context;
    set_deadline(context);
    const grpc::Status status = stub_->UpdateSettings(&context, settings, &report);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  v1::Frame frame;
  ASSERT_TRUE(render_frame(*stub_, id, 1, frame_format(v1::RGBA8_SRGB), &frame).ok());
  EXPECT_EQ(frame.width(), 24u);
  EXPECT_EQ(frame.height(), 10u);
  EXPECT_EQ(frame.data().size(), 24u * 10u * 4u);
  EXPECT_EQ(frame.epochs().settings(), report.epochs().settings());

  const v1::SceneInfo info = get_scene(*stub_, id);
  EXPECT_EQ(info.settings().k_nearest(), 8u);
  EXPECT_EQ(info.settings().photons_per_pass(), 2000u) << "unset settings keep their values";
  EXPECT_EQ(info.camera().width(), 24u);

  v1::UpdateCameraRequest camera;
  camera.set_scene_id(id);
  *camera.mutable_camera() = info.camera();
  camera.mutable_camera()->mutable_position()->set_z(-700);
  {
    grpc::ClientContext context;
    set_deadline(context);
    ASSERT_TRUE(stub_->UpdateCamera(&context, camera, &report).ok());
  }
  EXPECT_EQ(report.epochs().camera(), info.epochs().camera() + 1);
  v1::Frame moved;
  ASSERT_TRUE(render_frame(*stub_, id, 1, frame_format(v1::RGBA8_SRGB), &moved).ok());
  EXPECT_EQ(moved.epochs().camera(), report.epochs().camera());
  EXPECT_NE(moved.data(), frame.data());
}

TEST_F(ServerTest, UpdateSettingsChangesTheStructure) {
  const std::string id = upload_scene(*stub_, cornell_box(16, 16, 2000, 16, 2));
  const v1::SceneInfo before = get_scene(*stub_, id);
  EXPECT_EQ(before.structure(), "lbvh4") << "the default for a new scene";
  EXPECT_EQ(before.settings().structure(), v1::LBVH4);

  v1::UpdateSettingsRequest request;
  request.set_scene_id(id);
  request.mutable_settings()->set_structure(v1::BINNED_SAH);
  v1::RebuildReport report;
  {
    grpc::ClientContext context;
    set_deadline(context);
    const grpc::Status status = stub_->UpdateSettings(&context, request, &report);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  EXPECT_EQ(std::count(report.rebuilt().begin(), report.rebuilt().end(), "geometry"), 1)
      << "rebuilt: " << absl::StrJoin(report.rebuilt(), ", ");
  EXPECT_GT(report.timings().structure_build_ms(), 0);
  EXPECT_GT(report.epochs().geometry(), before.epochs().geometry());

  const v1::SceneInfo after = get_scene(*stub_, id);
  EXPECT_EQ(after.structure(), "binned-sah");
  EXPECT_EQ(after.settings().structure(), v1::BINNED_SAH);
  EXPECT_GT(after.structure_nodes(), 0u);
  EXPECT_GT(after.structure_bytes(), 0u);
  EXPECT_GT(after.structure_sah_cost(), 0);
  EXPECT_GT(after.structure_build_ms(), 0);
  EXPECT_EQ(after.epochs().geometry(), report.epochs().geometry());
  EXPECT_EQ(after.settings().k_nearest(), 16u) << "unset settings keep their values";

  v1::Frame frame;
  const grpc::Status rendered =
      render_frame(*stub_, id, 1, frame_format(v1::RGBA32F_LINEAR), &frame);
  ASSERT_TRUE(rendered.ok()) << rendered.error_message();
  EXPECT_EQ(frame.epochs().geometry(), report.epochs().geometry());
  EXPECT_GT(mean_rgb(frame_floats(frame)), 0.01) << "the image should not be black";
}

// The path integrator through the wire: uploaded with the scene, it renders with no photons traced
// ahead of a light change; a change to a structure that answers batches only is refused as
// INVALID_ARGUMENT naming the setting, and the scene renders as before.
TEST_F(ServerTest, PathIntegratorRendersThroughTheServer) {
  Scene scene = cornell_box(16, 16, 2000, 16, 2);
  scene.settings.integrator = Integrator::kPath;
  const std::string id = upload_scene(*stub_, scene);
  EXPECT_EQ(get_scene(*stub_, id).settings().integrator(), v1::PATH);
  v1::Frame frame;
  grpc::Status rendered = render_frame(*stub_, id, 2, frame_format(v1::RGBA32F_LINEAR), &frame);
  ASSERT_TRUE(rendered.ok()) << rendered.error_message();
  EXPECT_GT(mean_rgb(frame_floats(frame)), 0.01) << "the image should not be black";

  v1::UpdateSettingsRequest request;
  request.set_scene_id(id);
  request.mutable_settings()->set_structure(v1::DACRT);
  v1::RebuildReport report;
  {
    grpc::ClientContext context;
    set_deadline(context);
    const grpc::Status refused = stub_->UpdateSettings(&context, request, &report);
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(refused.error_message().find("settings.structure"), std::string::npos)
        << refused.error_message();
    EXPECT_NE(refused.error_message().find("dacrt answers batches only"), std::string::npos)
        << refused.error_message();
  }
  EXPECT_EQ(get_scene(*stub_, id).settings().structure(), v1::LBVH4);

  request.mutable_settings()->set_structure(v1::BINNED_SAH);
  {
    grpc::ClientContext context;
    set_deadline(context);
    ASSERT_TRUE(stub_->UpdateSettings(&context, request, &report).ok());
  }
  EXPECT_EQ(report.photons_emitted(), 0u) << "the path integrator traces no photons";
  rendered = render_frame(*stub_, id, 1, frame_format(v1::RGBA32F_LINEAR), &frame);
  EXPECT_TRUE(rendered.ok()) << rendered.error_message();
}

TEST_F(ServerTest, UploadedStructureIsReported) {
  Scene scene = cornell_box(16, 16, 2000, 16, 2);
  scene.settings.structure = StructureKind::kBinnedSah;
  v1::SceneInfo info;
  const grpc::Status status = upload(*stub_, scene_chunks(scene, "binned"), &info);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(info.structure(), "binned-sah");
  EXPECT_EQ(info.settings().structure(), v1::BINNED_SAH);
  EXPECT_GT(info.structure_nodes(), 0u);
  EXPECT_GT(info.structure_bytes(), 0u);
  EXPECT_GT(info.structure_sah_cost(), 0);
  EXPECT_GT(info.structure_build_ms(), 0);

  // GetStats carries the same SceneInfo per scene.
  v1::Stats stats;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(stub_->GetStats(&context, {}, &stats).ok());
  }
  ASSERT_EQ(stats.scene_stats_size(), 1);
  EXPECT_EQ(stats.scene_stats(0).structure(), "binned-sah");
  EXPECT_EQ(stats.scene_stats(0).structure_nodes(), info.structure_nodes());
  EXPECT_EQ(stats.scene_stats(0).structure_sah_cost(), info.structure_sah_cost());
}

TEST_F(ServerTest, CausticaRenderTakesAStructureByName) {
  const std::string scene_file = absl::StrCat(CAUSTICA_SCENES_DIR, "/cornell-box/scene.json");
  auto run = [&](const std::string& structure, const std::string& log_name) {
    const std::string command =
        absl::StrCat("'", CAUSTICA_RENDER_BIN, "' '", scene_file, "' -o '",
                     (server_->dir() / "structure.pfm").string(),
                     "' --width 16 --height 16 --photons 2000 --k 16 --structure ", structure,
                     " > '", (server_->dir() / log_name).string(), "' 2>&1");
    return std::system(command.c_str());
  };
  auto read_log = [&](const std::string& log_name) {
    std::ifstream in(server_->dir() / log_name);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };

  EXPECT_EQ(run("binned-sah", "binned.log"), 0) << read_log("binned.log");
  const std::string log = read_log("binned.log");
  EXPECT_NE(log.find("structure    binned-sah, "), std::string::npos) << log;
  EXPECT_NE(log.find(", SAH "), std::string::npos) << log;

  EXPECT_NE(run("kd-tree", "bad.log"), 0);
  const std::string bad = read_log("bad.log");
  EXPECT_NE(bad.find("unknown structure 'kd-tree' (expected " + structure_kind_list() + ")"),
            std::string::npos)
      << bad;
}

TEST_F(ServerTest, ListGetAndDeleteScenes) {
  const Scene scene = cornell_box(16, 16, 2000, 16, 2);
  const std::string first = upload_scene(*stub_, scene, "first");
  const std::string second = upload_scene(*stub_, scene, "second");
  EXPECT_NE(first, second);

  v1::ListScenesResponse list;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(stub_->ListScenes(&context, {}, &list).ok());
  }
  ASSERT_EQ(list.scenes_size(), 2);
  EXPECT_EQ(list.scenes(0).scene_id(), first);
  EXPECT_EQ(list.scenes(0).name(), "first");
  EXPECT_EQ(list.scenes(1).name(), "second");
  const v1::SceneInfo& info = list.scenes(0);
  size_t vertices = 0;
  for (const Mesh& mesh : scene.meshes) vertices += mesh.positions.size();
  EXPECT_EQ(info.triangles(), scene.triangle_count());
  EXPECT_EQ(info.vertices(), vertices);
  EXPECT_EQ(info.meshes(), scene.meshes.size());
  EXPECT_EQ(info.materials(), scene.materials.size());
  EXPECT_EQ(info.area_lights(), 2u) << "the ceiling light is one quad";
  EXPECT_EQ(info.lights(), 0u);
  EXPECT_EQ(info.camera().width(), 16u);
  EXPECT_EQ(info.settings().photons_per_pass(), 2000u);
  EXPECT_EQ(info.upload_bytes(), wire::upload_bytes(scene));
  EXPECT_EQ(info.structure(), "lbvh4");
  EXPECT_GT(info.structure_nodes(), 0u);
  EXPECT_GT(info.structure_bytes(), 0u);
  EXPECT_GT(info.structure_build_ms(), 0);
  EXPECT_GT(info.device_bytes(), 0u);
  EXPECT_GE(info.epochs().geometry(), 1u);

  v1::Stats before;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(stub_->GetStats(&context, {}, &before).ok());
  }
  v1::DeleteSceneRequest del;
  del.set_scene_id(first);
  v1::DeleteSceneResponse deleted;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(stub_->DeleteScene(&context, del, &deleted).ok());
  }
  EXPECT_GT(deleted.bytes_freed(), 0u);
  v1::Stats after;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(stub_->GetStats(&context, {}, &after).ok());
  }
  EXPECT_EQ(after.memory_used_bytes(), before.memory_used_bytes() - deleted.bytes_freed());
  EXPECT_EQ(after.scenes(), 1u);
  {
    grpc::ClientContext context;
    v1::DeleteSceneResponse again;
    EXPECT_EQ(stub_->DeleteScene(&context, del, &again).error_code(), grpc::StatusCode::NOT_FOUND);
  }
  {
    grpc::ClientContext context;
    v1::GetSceneRequest get;
    get.set_scene_id(first);
    v1::SceneInfo gone;
    EXPECT_EQ(stub_->GetScene(&context, get, &gone).error_code(), grpc::StatusCode::NOT_FOUND);
  }
}

class ServerStatsTest : public ServerTest {
 protected:
  std::vector<std::string> server_args() const override { return {"--memory-budget", "1G"}; }
};

TEST_F(ServerStatsTest, GetStatsReportsTheServersActivity) {
  const Scene scene = cornell_box(16, 16, 2000, 16, 2);
  const std::string id = upload_scene(*stub_, scene);
  v1::Frame frame;
  ASSERT_TRUE(render_frame(*stub_, id, 2, frame_format(v1::RGBA8_SRGB), &frame).ok());

  v1::Stats stats;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(stub_->GetStats(&context, {}, &stats).ok());
  }
  EXPECT_GT(stats.uptime_s(), 0);
  // --device auto: the GPU where there is one, else the CPU; or what CAUSTICA_TEST_DEVICE names.
  EXPECT_TRUE(stats.device().kind() == "cpu" || stats.device().kind() == "cuda")
      << stats.device().kind();
  if (const char* device = std::getenv("CAUSTICA_TEST_DEVICE");
      device != nullptr && *device != '\0' && std::string(device) != "auto") {
    EXPECT_EQ(stats.device().kind(), device);
  }
  EXPECT_FALSE(stats.device().name().empty());
  EXPECT_GT(stats.device().compute_units(), 0u);
  EXPECT_EQ(stats.memory_budget_bytes(), uint64_t{1} << 30);
  EXPECT_GT(stats.memory_used_bytes(), 0u);
  EXPECT_GE(stats.memory_peak_bytes(), stats.memory_used_bytes());
  EXPECT_EQ(stats.scenes(), 1u);
  EXPECT_EQ(stats.max_scenes(), 16u);
  EXPECT_EQ(stats.frames_served(), 1u);
  EXPECT_EQ(stats.requests_served(), 2u) << "the upload and the frame";
  EXPECT_EQ(stats.active_streams(), 0u);
  ASSERT_EQ(stats.scene_stats_size(), 1);
  EXPECT_EQ(stats.scene_stats(0).scene_id(), id);
  EXPECT_EQ(stats.scene_stats(0).passes(), 2u);

  auto find = [&](const std::string& name) -> const v1::LatencySummary* {
    for (const v1::LatencySummary& s : stats.latencies()) {
      if (s.stage() == name) return &s;
    }
    return nullptr;
  };
  const v1::LatencySummary* render_rpc = find("rpc/RenderFrame");
  ASSERT_NE(render_rpc, nullptr);
  EXPECT_EQ(render_rpc->count(), 1u);
  EXPECT_GT(render_rpc->p50_ms(), 0);
  EXPECT_LE(render_rpc->p50_ms(), render_rpc->p90_ms());
  EXPECT_LE(render_rpc->p90_ms(), render_rpc->p99_ms());
  EXPECT_LE(render_rpc->p99_ms(), render_rpc->max_ms());
  const v1::LatencySummary* render_stage = find("stage/render");
  ASSERT_NE(render_stage, nullptr);
  EXPECT_EQ(render_stage->count(), 2u) << "one per pass";
  EXPECT_NE(find("rpc/UploadScene"), nullptr);
  EXPECT_NE(find("stage/structure_build"), nullptr);

  v1::GetStatsRequest unknown;
  unknown.set_scene_id("s-nope");
  grpc::ClientContext context;
  EXPECT_EQ(stub_->GetStats(&context, unknown, &stats).error_code(), grpc::StatusCode::NOT_FOUND);
}

TEST_F(ServerTest, EightConcurrentClientsRenderTheirOwnScenes) {
  constexpr int kClients = 8;
  std::vector<std::string> ids(kClients);
  std::vector<std::vector<StreamedFrame>> streams(kClients);
  std::vector<grpc::Status> results(kClients);
  std::vector<std::thread> clients;
  for (int c = 0; c < kClients; ++c) {
    clients.emplace_back([&, c] {
      // A channel of its own: a separate connection, like a separate client process.
      auto channel = grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials());
      auto stub = v1::RenderService::NewStub(channel);
      ids[c] = upload_scene(*stub, cornell_box(16 + c, 16, 2000, 16, c + 1), absl::StrCat("c", c));
      v1::StreamFramesRequest request;
      request.set_scene_id(ids[c]);
      request.set_target_passes(3);
      *request.mutable_format() = frame_format(v1::RGBA32F_LINEAR);
      results[c] = stream_frames(*stub, request, &streams[c]);
    });
  }
  for (std::thread& t : clients) t.join();
  for (int c = 0; c < kClients; ++c) {
    ASSERT_TRUE(results[c].ok()) << "client " << c << ": " << results[c].error_message();
    ASSERT_EQ(streams[c].size(), 3u) << "client " << c;
    const v1::Frame& last = streams[c].back().header;
    EXPECT_EQ(last.scene_id(), ids[c]);
    EXPECT_EQ(last.width(), uint32_t(16 + c));
    EXPECT_EQ(last.passes(), 3u);
    EXPECT_EQ(streams[c].back().data.size(), size_t(16 + c) * 16 * 16);
  }
  // Each client's image is what a lone render of its scene gives: interleaving passes of other
  // scenes on the device must not change anyone's pixels.
  const std::string alone_id = upload_scene(*stub_, cornell_box(16 + 3, 16, 2000, 16, 3 + 1));
  v1::Frame alone;
  ASSERT_TRUE(render_frame(*stub_, alone_id, 3, frame_format(v1::RGBA32F_LINEAR), &alone).ok());
  EXPECT_EQ(alone.data(), streams[3].back().data);
  v1::Stats stats;
  grpc::ClientContext context;
  ASSERT_TRUE(stub_->GetStats(&context, {}, &stats).ok());
  EXPECT_EQ(stats.scenes(), uint32_t(kClients) + 1);
  EXPECT_EQ(stats.frames_served(), uint64_t(kClients) * 3 + 1);
}

}  // namespace
}  // namespace caustica::testing
