// The viewer against the real caustica-server: a ViewerSession driven message by message over a
// gRPC channel to the server (what each WebSocket does over the in-process one), and the
// --http-listen server itself (the page's headers, the loopback rule). The browser test
// (tests/viewer) covers the page.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <nlohmann/json.hpp>

#include "server/frame_encoding.h"
#include "server/viewer/viewer_session.h"
#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

using nlohmann::json;
using ::testing::HasSubstr;
using ::testing::Not;

// What a session sent, for the test to wait on.
class RecordingSink : public server::viewer::ViewerSink {
 public:
  void send_text(const std::string& text) override {
    std::lock_guard lock(mutex_);
    texts_.push_back(json::parse(text));
    changed_.notify_all();
  }
  void send_binary(const std::string& bytes) override {
    uint32_t length = 0;
    for (int i = 0; i < 4; ++i) {
      length |= uint32_t(static_cast<unsigned char>(bytes[i])) << (8 * i);
    }
    json header = json::parse(bytes.substr(4, length));
    const std::string image = bytes.substr(4 + length);
    header["image_bytes"] = image.size();
    // JPEG's start-of-image marker or PNG's signature: the pieces were put together whole.
    header["image_whole"] = image.starts_with("\xff\xd8\xff") ? image.ends_with("\xff\xd9")
                                                              : image.starts_with("\x89PNG");
    if (header.contains("strip_bytes")) {
      // Each strip a whole JPEG of its own, and together all the bytes.
      bool whole = header["strip_rows"].size() == header["strip_bytes"].size();
      size_t offset = 0;
      for (const json& size : header["strip_bytes"]) {
        const std::string strip = image.substr(offset, size.get<size_t>());
        whole = whole && strip.starts_with("\xff\xd8") && strip.ends_with("\xff\xd9");
        offset += size.get<size_t>();
      }
      header["strips_whole"] = whole && offset == image.size();
    }
    std::lock_guard lock(mutex_);
    frames_.push_back(std::move(header));
    changed_.notify_all();
  }
  // The next text message of `type` from index *seen on (which moves past it), waiting up to a
  // minute; null when none came.
  json wait_text(const std::string& type, size_t* seen) {
    std::unique_lock lock(mutex_);
    json found;
    changed_.wait_for(lock, std::chrono::seconds(60), [&] {
      for (; *seen < texts_.size(); ++*seen) {
        if (texts_[*seen]["type"] == type) {
          found = texts_[(*seen)++];
          return true;
        }
      }
      return false;
    });
    return found;
  }
  // Waits until a frame satisfies `accept`; that frame, or null after a minute.
  json wait_frame(const std::function<bool(const json&)>& accept) {
    std::unique_lock lock(mutex_);
    json found;
    changed_.wait_for(lock, std::chrono::seconds(60), [&] {
      for (const json& frame : frames_) {
        if (accept(frame)) {
          found = frame;
          return true;
        }
      }
      return false;
    });
    return found;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<json> texts_;
  std::vector<json> frames_;
};

class ViewerSessionTest : public ServerTest {
 protected:
  void SetUp() override {
    ServerTest::SetUp();
    scene_id_ = upload_scene(
        *stub_, small_scene_from(std::filesystem::path(CAUSTICA_SCENES_DIR) / "ring" / "scene.json",
                                 64, 48, 5000, 16, 1));
    // The smallest pieces the server sends (it raises this to kMinChunkBytes), so that larger
    // frames arrive in several messages to be put together.
    session_ = std::make_unique<server::viewer::ViewerSession>(
        server_->channel(), sink_, server::viewer::ViewerOptions{.stream_chunk_bytes = 512});
  }
  void TearDown() override { session_.reset(); }

  RecordingSink sink_;
  std::unique_ptr<server::viewer::ViewerSession> session_;
  std::string scene_id_;
  size_t seen_ = 0;
};

TEST_F(ViewerSessionTest, BadMessagesGetErrorsAndTheSessionCarriesOn) {
  session_->handle_text("{nope");
  EXPECT_THAT(sink_.wait_text("error", &seen_)["message"].get<std::string>(),
              HasSubstr("not JSON"));
  session_->handle_text(R"({"type":"list"})");
  EXPECT_THAT(sink_.wait_text("error", &seen_)["message"].get<std::string>(), HasSubstr("hello"));
  session_->handle_text(R"({"type":"hello","tokn":"x","id":5})");
  const json unknown = sink_.wait_text("error", &seen_);
  EXPECT_THAT(unknown["message"].get<std::string>(),
              HasSubstr("hello.tokn: unknown field (hello takes type, id, token)"));
  EXPECT_EQ(unknown["id"], 5) << "a refused message's error carries its id";
  session_->handle_text(R"({"type":"zoom","steps":"far","id":6})");
  EXPECT_EQ(sink_.wait_text("error", &seen_)["id"], 6);
  session_->handle_text(R"({"type":"zoom","steps":1,"id":"seven"})");
  EXPECT_FALSE(sink_.wait_text("error", &seen_).contains("id")) << "an id that is not an integer";
  session_->handle_binary();
  EXPECT_THAT(sink_.wait_text("error", &seen_)["message"].get<std::string>(),
              HasSubstr("binary messages are not accepted"));
  session_->handle_text(R"({"type":"hello","id":1})");
  const json scenes = sink_.wait_text("scenes", &seen_);
  ASSERT_EQ(scenes["scenes"].size(), 1u);
  EXPECT_EQ(scenes["scenes"][0]["id"], scene_id_);
  EXPECT_EQ(scenes["id"], 1);
  session_->handle_text(R"({"type":"open","scene":"s-nonexistent"})");
  const json missing = sink_.wait_text("error", &seen_);
  EXPECT_EQ(missing["code"], "NOT_FOUND");
  EXPECT_THAT(missing["message"].get<std::string>(), HasSubstr("GetScene: "));
  expect_server_healthy(*server_);
}

// gRPC aborts the process on a metadata value outside visible ASCII, so such a token must be
// refused before the session keeps it; a page that then says hello properly is served as usual.
TEST_F(ViewerSessionTest, TokensOutsideVisibleAsciiAreRefusedAndTheSessionCarriesOn) {
  const struct {
    std::string token;
    std::string refusal;
  } cases[] = {{"é", "byte 0xc3 at offset 0"},
               {"\n", "byte 0x0a at offset 0"},
               {"\r\n", "byte 0x0d at offset 0"},
               {"\t", "byte 0x09 at offset 0"},
               {std::string(1, '\0'), "byte 0x00 at offset 0"},
               {"\x7f", "byte 0x7f at offset 0"},
               {"abc def", "byte 0x20 at offset 3"}};
  for (const auto& [token, refusal] : cases) {
    session_->handle_text(json({{"type", "hello"}, {"token", token}}).dump());
    const json error = sink_.wait_text("error", &seen_);
    EXPECT_EQ(error["code"], "INVALID_ARGUMENT") << refusal;
    EXPECT_THAT(error["message"].get<std::string>(), HasSubstr("hello.token: " + refusal));
  }
  session_->handle_text(R"({"type":"list"})");
  EXPECT_THAT(sink_.wait_text("error", &seen_)["message"].get<std::string>(), HasSubstr("hello"))
      << "a refused hello greets nobody";

  session_->handle_text(R"({"type":"hello","token":"any-token-in-development-mode"})");
  ASSERT_EQ(sink_.wait_text("scenes", &seen_)["scenes"].size(), 1u);
  session_->handle_text(json({{"type", "open"}, {"scene", scene_id_}, {"passes", 1}}).dump());
  EXPECT_FALSE(sink_.wait_frame([](const json& frame) { return frame["passes"] == 1; }).is_null());
  session_->close();
  expect_server_healthy(*server_);
}

TEST_F(ViewerSessionTest, FramesRefineAndALightDragShowsInANewEpoch) {
  session_->handle_text(R"({"type":"hello"})");
  sink_.wait_text("scenes", &seen_);
  session_->handle_text(json({{"type", "open"}, {"scene", scene_id_}, {"passes", 3}}).dump());
  const json scene = sink_.wait_text("scene", &seen_);
  ASSERT_EQ(scene["scene"]["id"], scene_id_);
  // The ring scene's own point light, where its camera sees it.
  ASSERT_EQ(scene["lights"].size(), 1u);
  const json light = scene["lights"][0];
  EXPECT_EQ(light["name"], "key light");
  EXPECT_TRUE(light["draggable"]);
  EXPECT_FALSE(light["viewer_light"]);
  EXPECT_TRUE(light["visible"]);
  EXPECT_EQ(scene["emitters"].size(), 0u);
  const v1::SceneInfo opened = get_scene(*stub_, scene_id_);
  ASSERT_EQ(opened.light_list_size(), 1);
  EXPECT_NEAR(light["position"][1].get<double>(), opened.light_list(0).position().y(), 1e-3);
  const json finished = sink_.wait_frame([](const json& frame) { return frame["passes"] == 3; });
  ASSERT_FALSE(finished.is_null());
  EXPECT_EQ(finished["width"], 64);
  EXPECT_GT(finished["image_bytes"].get<size_t>(), 512u);
  EXPECT_TRUE(finished["image_whole"]);
  // JPEG frames come as strips by default; 48 rows make three 16-row strips.
  EXPECT_EQ(finished["strip_rows"], json({16, 16, 16}));
  EXPECT_TRUE(finished["strips_whole"]);
  const uint64_t lights_epoch = finished["epochs"]["lights"];
  sink_.wait_text("idle", &seen_);

  session_->handle_text(R"({"type":"move_light","light":0,"u":0.7,"v":0.4,"id":9})");
  const json updated = sink_.wait_text("updated", &seen_);
  EXPECT_EQ(updated["id"], 9);
  EXPECT_EQ(updated["what"], "lights");
  EXPECT_GT(updated["epochs"]["lights"].get<uint64_t>(), lights_epoch);
  ASSERT_EQ(updated["lights"].size(), 1u) << "the drag moved the scene's light, adding none";
  EXPECT_NEAR(updated["lights"][0]["u"].get<double>(), 0.7, 1e-4);
  EXPECT_NEAR(updated["lights"][0]["v"].get<double>(), 0.4, 1e-4);
  // The finished stream restarts for the change, and refines the new epoch to the target.
  const uint64_t new_epoch = updated["epochs"]["lights"];
  ASSERT_FALSE(sink_
                   .wait_frame([&](const json& frame) {
                     return frame["epochs"]["lights"] == new_epoch && frame["passes"] == 3;
                   })
                   .is_null());

  // The server holds the moved light: a second session (or any client) sees it there.
  const v1::SceneInfo moved = get_scene(*stub_, scene_id_);
  ASSERT_EQ(moved.light_list_size(), 1);
  EXPECT_EQ(moved.light_list(0).name(), "key light");
  EXPECT_NEAR(moved.light_list(0).position().x(), updated["lights"][0]["position"][0].get<double>(),
              1e-3);
  EXPECT_EQ(moved.epochs().lights(), new_epoch);
  RecordingSink other_sink;
  server::viewer::ViewerSession other(server_->channel(), other_sink);
  size_t other_seen = 0;
  other.handle_text(R"({"type":"hello"})");
  other.handle_text(json({{"type", "open"}, {"scene", scene_id_}, {"passes", 1}}).dump());
  const json other_scene = other_sink.wait_text("scene", &other_seen);
  EXPECT_NEAR(other_scene["lights"][0]["u"].get<double>(), 0.7, 1e-4);
  other.close();

  session_->handle_text(R"({"type":"set_intensity","light":0,"intensity":1000})");
  const json brighter = sink_.wait_text("updated", &seen_);
  EXPECT_NEAR(brighter["lights"][0]["intensity"].get<double>(), 1000, 1e-3);
  session_->handle_text(R"({"type":"move_light","light":3,"u":0.5,"v":0.5})");
  EXPECT_THAT(sink_.wait_text("error", &seen_)["message"].get<std::string>(),
              HasSubstr("move_light.light: 3 is not a light"));
  session_->handle_text(R"({"type":"orbit","dx":0.1,"dy":0.02})");
  const json orbited = sink_.wait_text("updated", &seen_);
  EXPECT_EQ(orbited["what"], "camera");
  const uint64_t camera_epoch = orbited["epochs"]["camera"];
  ASSERT_FALSE(
      sink_.wait_frame([&](const json& frame) { return frame["epochs"]["camera"] == camera_epoch; })
          .is_null());
  session_->handle_text(R"({"type":"zoom","steps":1})");
  EXPECT_EQ(sink_.wait_text("updated", &seen_)["what"], "camera");
  session_->close();
  expect_server_healthy(*server_);
}

TEST_F(ViewerSessionTest, FramesOfSeveralPiecesArriveWhole) {
  // The Cornell box's noisy first pass: a JPEG of several pieces.
  const std::string id = upload_scene(*stub_, cornell_box(256, 256, 2000, 16, 1));
  session_->handle_text(R"({"type":"hello"})");
  session_->handle_text(json({{"type", "open"}, {"scene", id}, {"passes", 1}}).dump());
  const json frame = sink_.wait_frame([](const json& frame) { return frame["passes"] == 1; });
  ASSERT_FALSE(frame.is_null());
  ASSERT_GT(frame["image_bytes"].get<size_t>(), server::kMinChunkBytes) << "one piece only";
  EXPECT_TRUE(frame["image_whole"]);
  EXPECT_TRUE(frame["strips_whole"]);
  session_->close();
}

TEST_F(ViewerSessionTest, TheOpenMessageChoosesTheStripCount) {
  session_->handle_text(R"({"type":"hello"})");
  sink_.wait_text("scenes", &seen_);
  session_->handle_text(R"({"type":"open","scene":"x","strips":17})");
  EXPECT_THAT(sink_.wait_text("error", &seen_)["message"].get<std::string>(),
              HasSubstr("open.strips"));
  session_->handle_text(
      json({{"type", "open"}, {"scene", scene_id_}, {"passes", 2}, {"strips", 1}}).dump());
  const json finished = sink_.wait_frame([](const json& frame) { return frame["passes"] == 2; });
  ASSERT_FALSE(finished.is_null());
  EXPECT_TRUE(finished["image_whole"]);
  EXPECT_FALSE(finished.contains("strip_bytes")) << "one strip is one JPEG, as before strips";
  session_->close();
}

TEST_F(ServerTest, RenderFrameInJpegStrips) {
  const std::string id = upload_scene(
      *stub_, small_scene_from(std::filesystem::path(CAUSTICA_SCENES_DIR) / "ring" / "scene.json",
                               64, 72, 5000, 16, 1));
  v1::FrameFormat format;
  format.set_encoding(v1::JPEG);
  format.set_jpeg_strips(4);
  v1::Frame frame;
  grpc::Status status = render_frame(*stub_, id, 1, format, &frame);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(frame.strip_bytes_size(), 4);
  ASSERT_EQ(frame.strip_rows_size(), 4);
  EXPECT_THAT(frame.strip_rows(), ::testing::ElementsAre(32, 16, 16, 8));
  size_t offset = 0;
  for (uint32_t size : frame.strip_bytes()) {
    const std::string strip = frame.data().substr(offset, size);
    EXPECT_TRUE(strip.starts_with("\xff\xd8")) << "strip at " << offset;
    EXPECT_TRUE(strip.ends_with("\xff\xd9")) << "strip at " << offset;
    offset += size;
  }
  EXPECT_EQ(offset, frame.data().size());

  format.set_jpeg_strips(17);
  status = render_frame(*stub_, id, 1, format, &frame);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), HasSubstr("format.jpeg_strips"));
}

// The Cornell box with a point light and a directional light besides its area light.
Scene lit_cornell_box() {
  Scene scene = cornell_box(48, 48, 5000, 16, 2);
  scene.lights = {Light{"key", LightType::kPoint, Vec3f(278, 400, 279), Vec3f(0, -1, 0),
                        Vec3f(4e4f, 4e4f, 4e4f)},
                  Light{"sun", LightType::kDirectional, Vec3f(0, 0, 0), Vec3f(0.2f, -1, 0.3f),
                        Vec3f(0.5f, 0.5f, 0.5f)}};
  return scene;
}

double mean_of_render(v1::RenderService::Stub& stub, const std::string& id) {
  v1::Frame frame;
  const grpc::Status status = render_frame(stub, id, 2, frame_format(v1::RGBA32F_LINEAR), &frame);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return mean_rgb(frame_floats(frame));
}

TEST_F(ViewerSessionTest, DragsTheScenesOwnLightAndSwitchesItsAreaLight) {
  const std::string id = upload_scene(*stub_, lit_cornell_box(), "lit box");
  const v1::SceneInfo before = get_scene(*stub_, id);
  session_->handle_text(R"({"type":"hello"})");
  sink_.wait_text("scenes", &seen_);
  session_->handle_text(json({{"type", "open"}, {"scene", id}, {"passes", 2}}).dump());
  const json scene = sink_.wait_text("scene", &seen_);
  ASSERT_EQ(scene["lights"].size(), 2u) << "the scene's two lights and no viewer light";
  EXPECT_EQ(scene["lights"][0]["name"], "key");
  EXPECT_TRUE(scene["lights"][0]["draggable"]);
  EXPECT_EQ(scene["lights"][1]["type"], "directional");
  EXPECT_FALSE(scene["lights"][1]["draggable"]);
  ASSERT_EQ(scene["emitters"].size(), 1u);
  EXPECT_EQ(scene["emitters"][0]["material"], "light");
  EXPECT_TRUE(scene["emitters"][0]["on"]);
  sink_.wait_text("idle", &seen_);

  session_->handle_text(R"({"type":"move_light","light":1,"u":0.5,"v":0.5})");
  EXPECT_THAT(sink_.wait_text("error", &seen_)["message"].get<std::string>(),
              HasSubstr("move_light.light: light 1 ('sun') is directional"));
  session_->handle_text(R"({"type":"set_emitter","emitter":4,"on":false})");
  EXPECT_THAT(sink_.wait_text("error", &seen_)["message"].get<std::string>(),
              HasSubstr("set_emitter.emitter: 4 is not an emitter"));

  session_->handle_text(R"({"type":"move_light","light":0,"u":0.3,"v":0.35})");
  const json dragged = sink_.wait_text("updated", &seen_);
  ASSERT_EQ(dragged["lights"].size(), 2u);
  EXPECT_NEAR(dragged["lights"][0]["u"].get<double>(), 0.3, 1e-4);
  const v1::SceneInfo after = get_scene(*stub_, id);
  ASSERT_EQ(after.light_list_size(), 2);
  EXPECT_EQ(after.light_list(0).name(), "key");
  EXPECT_NEAR(after.light_list(0).position().x(), dragged["lights"][0]["position"][0].get<double>(),
              1e-3);
  EXPECT_NE(after.light_list(0).position().x(), before.light_list(0).position().x());
  EXPECT_EQ(after.light_list(0).intensity().SerializeAsString(),
            before.light_list(0).intensity().SerializeAsString());
  EXPECT_EQ(after.light_list(1).SerializeAsString(), before.light_list(1).SerializeAsString())
      << "the directional light is unchanged";
  EXPECT_EQ(after.emitters(0).SerializeAsString(), before.emitters(0).SerializeAsString());
  sink_.wait_text("idle", &seen_);

  const double lit = mean_of_render(*stub_, id);
  session_->handle_text(R"({"type":"set_emitter","emitter":0,"on":false,"id":4})");
  const json switched = sink_.wait_text("updated", &seen_);
  EXPECT_EQ(switched["id"], 4);
  EXPECT_FALSE(switched["emitters"][0]["on"]);
  EXPECT_GT(switched["epochs"]["lights"].get<uint64_t>(),
            dragged["epochs"]["lights"].get<uint64_t>());
  const uint64_t off_epoch = switched["epochs"]["lights"];
  ASSERT_FALSE(
      sink_.wait_frame([&](const json& frame) { return frame["epochs"]["lights"] == off_epoch; })
          .is_null());
  const v1::SceneInfo off = get_scene(*stub_, id);
  ASSERT_EQ(off.emitters_size(), 1);
  EXPECT_TRUE(off.emitters(0).off());
  EXPECT_FLOAT_EQ(off.emitters(0).radiance().x(), before.emitters(0).radiance().x());
  EXPECT_EQ(off.light_list(0).SerializeAsString(), after.light_list(0).SerializeAsString())
      << "keep_lights left the dragged light where it was";
  EXPECT_LT(mean_of_render(*stub_, id), 0.9 * lit) << "the area light is off";

  session_->handle_text(R"({"type":"set_emitter","emitter":0,"on":true,"radiance":34})");
  const json back = sink_.wait_text("updated", &seen_);
  EXPECT_TRUE(back["emitters"][0]["on"]);
  EXPECT_NEAR(back["emitters"][0]["brightness"].get<double>(), 34, 1e-3);
  EXPECT_FLOAT_EQ(get_scene(*stub_, id).emitters(0).radiance().x(), 34);
  session_->close();
  expect_server_healthy(*server_);
}

TEST_F(ViewerSessionTest, AnAreaLitSceneGetsAViewerLightAddedToItsLights) {
  const std::string id = upload_scene(*stub_, cornell_box(48, 48, 5000, 16, 2), "box");
  session_->handle_text(R"({"type":"hello"})");
  session_->handle_text(json({{"type", "open"}, {"scene", id}, {"passes", 1}}).dump());
  const json scene = sink_.wait_text("scene", &seen_);
  ASSERT_EQ(scene["lights"].size(), 1u);
  EXPECT_TRUE(scene["lights"][0]["viewer_light"]);
  EXPECT_TRUE(scene["lights"][0]["draggable"]);
  EXPECT_EQ(scene["emitters"].size(), 1u);
  session_->handle_text(R"({"type":"move_light","light":0,"u":0.5,"v":0.4})");
  const json updated = sink_.wait_text("updated", &seen_);
  ASSERT_EQ(updated["lights"].size(), 1u);
  EXPECT_FALSE(updated["lights"][0]["viewer_light"]);
  const v1::SceneInfo info = get_scene(*stub_, id);
  ASSERT_EQ(info.light_list_size(), 1);
  EXPECT_EQ(info.light_list(0).name(), "viewer light");
  EXPECT_FALSE(info.emitters(0).off()) << "the area light stays";
  session_->close();
}

TEST_F(ViewerSessionTest, AChangeByAnotherClientIsNotOverwritten) {
  session_->handle_text(R"({"type":"hello"})");
  session_->handle_text(json({{"type", "open"}, {"scene", scene_id_}, {"passes", 1}}).dump());
  sink_.wait_text("scene", &seen_);
  // Another client adds a light under the page.
  v1::SceneInfo info = get_scene(*stub_, scene_id_);
  v1::UpdateLightsRequest other;
  other.set_scene_id(scene_id_);
  *other.mutable_lights() = info.light_list();
  v1::Light& added = *other.add_lights();
  added = info.light_list(0);
  added.set_name("second");
  v1::RebuildReport report;
  grpc::ClientContext context;
  set_deadline(context);
  ASSERT_TRUE(stub_->UpdateLights(&context, other, &report).ok());

  session_->handle_text(R"({"type":"move_light","light":0,"u":0.2,"v":0.2})");
  const json reloaded = sink_.wait_text("lights", &seen_);
  ASSERT_EQ(reloaded["lights"].size(), 2u) << "the page now shows the other client's lights";
  EXPECT_EQ(reloaded["lights"][1]["name"], "second");
  EXPECT_EQ(sink_.wait_text("error", &seen_)["code"], "FAILED_PRECONDITION");
  info = get_scene(*stub_, scene_id_);
  EXPECT_EQ(info.light_list_size(), 2);
  EXPECT_EQ(info.epochs().lights(), report.epochs().lights()) << "nothing was overwritten";
  session_->close();
}

// --http-listen on the real binary.
class ViewerHttpTest : public ServerTest {
 protected:
  std::vector<std::string> server_args() const override {
    return {"--http-listen", "127.0.0.1:0", "--http-port-file", http_port_file().string()};
  }
  std::filesystem::path http_port_file() const {
    static const std::filesystem::path file = make_temp_dir("caustica-viewer-http") / "http-port";
    return file;
  }
};

TEST_F(ViewerHttpTest, ServesThePageWithTypesAndCacheHeaders) {
  std::string port = read_text_file(http_port_file());
  while (!port.empty() && (port.back() == '\n')) port.pop_back();
  ASSERT_FALSE(port.empty());
  const std::string base = "http://127.0.0.1:" + port;
  const CommandRun page = run_command("curl -sS -i " + base + "/");
  ASSERT_EQ(page.exit_code, 0) << page.output;
  EXPECT_THAT(page.output, HasSubstr("HTTP/1.1 200 OK"));
  EXPECT_THAT(page.output, HasSubstr("Content-Type: text/html; charset=utf-8"));
  EXPECT_THAT(page.output, HasSubstr("Cache-Control: no-cache"));
  EXPECT_THAT(page.output, HasSubstr("Content-Security-Policy: default-src 'self'"));
  EXPECT_THAT(page.output, HasSubstr("<canvas"));
  const CommandRun script = run_command("curl -sS -I " + base + "/viewer.js");
  EXPECT_THAT(script.output, HasSubstr("Content-Type: text/javascript; charset=utf-8"));
  const size_t etag_at = script.output.find("ETag: ");
  ASSERT_NE(etag_at, std::string::npos);
  const std::string etag =
      script.output.substr(etag_at + 6, script.output.find('\r', etag_at) - etag_at - 6);
  const CommandRun revalidated =
      run_command("curl -sS -i -H 'If-None-Match: " + etag + "' " + base + "/viewer.js");
  EXPECT_THAT(revalidated.output, HasSubstr("HTTP/1.1 304 Not Modified"));
  EXPECT_THAT(run_command("curl -sS -i " + base + "/secret").output, HasSubstr("404"));
  // A WebSocket upgrade from another site's page is refused.
  const CommandRun cross_site = run_command(
      "curl -sS -i -H 'Connection: Upgrade' -H 'Upgrade: websocket' -H 'Sec-WebSocket-Version: "
      "13' -H 'Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==' -H 'Origin: http://evil.example' " +
      base + "/ws --max-time 5");
  EXPECT_THAT(cross_site.output, Not(HasSubstr("101 Switching Protocols")));
  const CommandRun same_site = run_command(
      "curl -sS -i -H 'Connection: Upgrade' -H 'Upgrade: websocket' -H 'Sec-WebSocket-Version: "
      "13' -H 'Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==' -H 'Origin: " +
      base + "' " + base + "/ws --max-time 2");
  EXPECT_THAT(same_site.output, HasSubstr("101 Switching Protocols"));
  EXPECT_EQ(server_->terminate(), 0) << server_->log();
}

TEST(ViewerOptions, PlaintextViewerOffLoopbackNeedsInsecure) {
  const CommandRun run = run_command(std::string(CAUSTICA_SERVER_BIN) +
                                     " --listen 127.0.0.1:0 --http-listen 0.0.0.0:0");
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_THAT(run.output, HasSubstr("--http-listen: 0.0.0.0:0 is not loopback"));
  EXPECT_THAT(run.output, HasSubstr("--insecure"));
}

}  // namespace
}  // namespace caustica::testing
