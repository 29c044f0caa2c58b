// The browser viewer's logic without a browser or a server: image-plane geometry against the
// renderer's own camera, control-message validation, the UpdateLights each light or emitter
// change becomes, the frame message layout, the listen address and origin rules, and the
// embedded page.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "renderer/render/camera.h"
#include "server/viewer/viewer_assets.h"
#include "server/viewer/viewer_geometry.h"
#include "server/viewer/viewer_http.h"
#include "server/viewer/viewer_protocol.h"

namespace caustica::server::viewer {
namespace {

using ::testing::HasSubstr;

v1::Vec3 vec(float x, float y, float z) {
  v1::Vec3 v;
  v.set_x(x);
  v.set_y(y);
  v.set_z(z);
  return v;
}

// The ring scene's camera: looking down at the origin from above and behind.
v1::Camera ring_camera() {
  v1::Camera camera;
  *camera.mutable_position() = vec(0, 750, -450);
  *camera.mutable_look_at() = vec(0, 20, 0);
  *camera.mutable_up() = vec(0, 1, 0);
  camera.set_vertical_fov_deg(35);
  camera.set_width(320);
  camera.set_height(240);
  return camera;
}

double distance(const Vec3d& a, const Vec3d& b) {
  return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) +
                   (a.z - b.z) * (a.z - b.z));
}

TEST(ViewerGeometry, ProjectInvertsPointAt) {
  const v1::Camera camera = ring_camera();
  for (double u : {0.0, 0.25, 0.5, 0.9}) {
    for (double v : {0.0, 0.3, 1.0}) {
      const Vec3d point = point_at(camera, u, v, 400);
      const std::optional<ImagePoint> seen = project(camera, point);
      ASSERT_TRUE(seen.has_value());
      EXPECT_NEAR(seen->u, u, 1e-9);
      EXPECT_NEAR(seen->v, v, 1e-9);
      EXPECT_NEAR(seen->depth, 400, 1e-9);
    }
  }
}

TEST(ViewerGeometry, PointAtLiesOnTheRenderersCameraRay) {
  const v1::Camera wire = ring_camera();
  Camera camera;
  camera.position = {0, 750, -450};
  camera.look_at = {0, 20, 0};
  camera.up = {0, 1, 0};
  camera.vertical_fov_deg = 35;
  camera.width = 320;
  camera.height = 240;
  const PinholeCamera pinhole = PinholeCamera::from(camera);
  // The top-left quarter point: right of and above nothing symmetric, so a flipped axis shows.
  const Ray ray = pinhole.ray_through(0.25f * 320, 0.2f * 240);
  const Vec3d point = point_at(wire, 0.25, 0.2, 500);
  const Vec3d offset{point.x - ray.origin.x, point.y - ray.origin.y, point.z - ray.origin.z};
  const double along =
      offset.x * ray.direction.x + offset.y * ray.direction.y + offset.z * ray.direction.z;
  const Vec3d closest{ray.origin.x + along * ray.direction.x,
                      ray.origin.y + along * ray.direction.y,
                      ray.origin.z + along * ray.direction.z};
  EXPECT_LT(distance(point, closest), 1e-2);
}

TEST(ViewerGeometry, DragMovesTheLightWithinItsImagePlane) {
  const v1::Camera camera = ring_camera();
  const Vec3d light{-424.264, 424.264, 0};
  const std::optional<ImagePoint> before = project(camera, light);
  ASSERT_TRUE(before.has_value());
  const Vec3d moved = move_in_image_plane(camera, light, before->u + 0.2, before->v - 0.1, 1);
  const std::optional<ImagePoint> after = project(camera, moved);
  ASSERT_TRUE(after.has_value());
  EXPECT_NEAR(after->depth, before->depth, 1e-6);
  EXPECT_NEAR(after->u, before->u + 0.2, 1e-9);
  EXPECT_NEAR(after->v, before->v - 0.1, 1e-9);
  // The camera looks along +z (and down) with y up, so the picture's right is -x.
  EXPECT_LT(moved.x, light.x);
  // Not moving leaves it where it was.
  const Vec3d same = move_in_image_plane(camera, light, before->u, before->v, 1);
  EXPECT_LT(distance(same, light), 1e-3);
}

TEST(ViewerGeometry, LightBehindTheCameraComesToTheFallbackDepth) {
  const v1::Camera camera = ring_camera();
  EXPECT_FALSE(project(camera, {0, 800, -600}).has_value());
  const Vec3d moved = move_in_image_plane(camera, {0, 800, -600}, 0.5, 0.5, 300);
  const std::optional<ImagePoint> seen = project(camera, moved);
  ASSERT_TRUE(seen.has_value());
  EXPECT_NEAR(seen->depth, 300, 1e-6);
  EXPECT_NEAR(seen->u, 0.5, 1e-9);
}

TEST(ViewerGeometry, OrbitKeepsThePivotAndDistance) {
  const v1::Camera camera = ring_camera();
  const double pivot_distance = scene_scale_hint(camera);
  const Vec3d pivot = point_at(camera, 0.5, 0.5, pivot_distance);
  const v1::Camera turned = orbit(camera, 0.25, 0, pivot_distance);
  EXPECT_NEAR(distance(to_vec3d(turned.look_at()), pivot), 0, 1e-2);
  EXPECT_NEAR(distance(to_vec3d(turned.position()), pivot), pivot_distance, 1e-2);
  EXPECT_NEAR(turned.position().y(), camera.position().y(), 1e-2);  // about the up axis only
  EXPECT_GT(std::abs(turned.position().x()), 100);
  const v1::Camera raised = orbit(camera, 0, 0.05, pivot_distance);
  EXPECT_GT(raised.position().y(), camera.position().y());
  EXPECT_NEAR(distance(to_vec3d(raised.position()), pivot), pivot_distance, 1e-2);
  // Never over the pole: the view direction keeps away from the up vector.
  const v1::Camera top = orbit(camera, 0, 5, pivot_distance);
  const Vec3d look = to_vec3d(top.look_at());
  const Vec3d eye = to_vec3d(top.position());
  EXPECT_GT(distance({look.x, 0, look.z}, {eye.x, 0, eye.z}), 1);
}

TEST(ViewerGeometry, ZoomMovesTowardsThePivot) {
  const v1::Camera camera = ring_camera();
  const double pivot_distance = 800;
  const Vec3d pivot = point_at(camera, 0.5, 0.5, pivot_distance);
  const v1::Camera closer = zoom(camera, 2, pivot_distance);
  EXPECT_NEAR(distance(to_vec3d(closer.position()), pivot), 800 * 0.81, 1e-2);
  const std::optional<ImagePoint> centre = project(closer, pivot);
  ASSERT_TRUE(centre.has_value());
  EXPECT_NEAR(centre->u, 0.5, 1e-6);
  EXPECT_NEAR(centre->v, 0.5, 1e-6);
  const v1::Camera farthest_in = zoom(camera, 100, pivot_distance);
  EXPECT_NEAR(distance(to_vec3d(farthest_in.position()), pivot), 8, 1e-2);
}

TEST(ViewerProtocol, ParsesEveryMessageType) {
  absl::StatusOr<ViewerRequest> hello = parse_request(R"({"type":"hello","token":"t","id":3})");
  ASSERT_TRUE(hello.ok()) << hello.status();
  EXPECT_EQ(hello->type, RequestType::kHello);
  EXPECT_EQ(hello->token, "t");
  EXPECT_EQ(hello->id, 3);
  absl::StatusOr<ViewerRequest> open = parse_request(R"({"type":"open","scene":"s-1","passes":8})");
  ASSERT_TRUE(open.ok()) << open.status();
  EXPECT_EQ(open->scene, "s-1");
  EXPECT_EQ(open->passes, 8u);
  EXPECT_EQ(open->strips, 0u) << "no strips field: the session's default";
  open = parse_request(R"({"type":"open","scene":"s-1","strips":2})");
  ASSERT_TRUE(open.ok()) << open.status();
  EXPECT_EQ(open->strips, 2u);
  absl::StatusOr<ViewerRequest> move =
      parse_request(R"({"type":"move_light","light":1,"u":0.25,"v":-0.5})");
  ASSERT_TRUE(move.ok()) << move.status();
  EXPECT_EQ(move->light, 1u);
  EXPECT_EQ(move->u, 0.25);
  EXPECT_EQ(move->v, -0.5);
  EXPECT_TRUE(parse_request(R"({"type":"set_intensity","light":0,"intensity":1e5})").ok());
  absl::StatusOr<ViewerRequest> emitter =
      parse_request(R"({"type":"set_emitter","emitter":2,"on":false})");
  ASSERT_TRUE(emitter.ok()) << emitter.status();
  EXPECT_EQ(emitter->type, RequestType::kSetEmitter);
  EXPECT_EQ(emitter->emitter, 2u);
  EXPECT_EQ(emitter->on, false);
  EXPECT_FALSE(emitter->radiance.has_value());
  absl::StatusOr<ViewerRequest> radiance =
      parse_request(R"({"type":"set_emitter","emitter":0,"radiance":8.5})");
  ASSERT_TRUE(radiance.ok()) << radiance.status();
  EXPECT_EQ(radiance->radiance, 8.5);
  EXPECT_FALSE(radiance->on.has_value());
  EXPECT_TRUE(parse_request(R"({"type":"orbit","dx":0.1,"dy":0})").ok());
  EXPECT_TRUE(parse_request(R"({"type":"zoom","steps":-1.5})").ok());
  EXPECT_TRUE(parse_request(R"({"type":"list"})").ok());
  EXPECT_TRUE(parse_request(R"({"type":"hello"})").ok());  // no token without --tokens
}

TEST(ViewerProtocol, RefusalsSayWhatIsWrong) {
  auto refusal = [](std::string_view text) {
    absl::StatusOr<ViewerRequest> request = parse_request(text);
    EXPECT_FALSE(request.ok()) << text;
    if (request.ok()) return std::string();
    EXPECT_EQ(request.status().code(), absl::StatusCode::kInvalidArgument);
    return std::string(request.status().message());
  };
  EXPECT_THAT(refusal("{nope"), HasSubstr("not JSON"));
  EXPECT_THAT(refusal("[1,2]"), HasSubstr("not a JSON object"));
  EXPECT_THAT(refusal(R"({"scene":"x"})"), HasSubstr("type: is missing"));
  EXPECT_THAT(refusal(R"({"type":"teleport"})"),
              HasSubstr("unknown message type 'teleport' (expected hello, list, open"));
  EXPECT_THAT(refusal(R"({"type":"open","scene":"s","colour":"red"})"),
              HasSubstr("open.colour: unknown field (open takes type, id, scene, passes, strips)"));
  EXPECT_THAT(refusal(R"({"type":"open","scene":"s","strips":17})"),
              HasSubstr("open.strips: must be an integer in [0, 16]"));
  EXPECT_THAT(refusal(R"({"type":"open"})"), HasSubstr("open.scene: is missing"));
  EXPECT_THAT(refusal(R"({"type":"open","scene":7})"), HasSubstr("open.scene: must be a string"));
  EXPECT_THAT(refusal(R"({"type":"move_light","light":-1,"u":0,"v":0})"),
              HasSubstr("move_light.light: must be an integer"));
  EXPECT_THAT(refusal(R"({"type":"move_light","light":0,"u":"left","v":0})"),
              HasSubstr("move_light.u: must be a number"));
  EXPECT_THAT(refusal(R"({"type":"move_light","light":0,"u":1e9,"v":0})"),
              HasSubstr("move_light.u: must be in [-10, 10]"));
  EXPECT_THAT(refusal(R"({"type":"set_intensity","light":0,"intensity":-1})"),
              HasSubstr("set_intensity.intensity: must be in [0"));
  EXPECT_THAT(refusal(R"({"type":"set_emitter","emitter":0})"),
              HasSubstr("set_emitter: says nothing to change"));
  EXPECT_THAT(refusal(R"({"type":"set_emitter","emitter":0,"on":"yes"})"),
              HasSubstr("set_emitter.on: must be true or false"));
  EXPECT_THAT(refusal(R"({"type":"set_emitter","emitter":0,"radiance":-2})"),
              HasSubstr("set_emitter.radiance: must be in [0"));
  EXPECT_THAT(refusal(R"({"type":"set_emitter","on":true})"),
              HasSubstr("set_emitter.emitter: is missing"));
  EXPECT_THAT(refusal(R"({"type":"set_emitter","emitter":0,"on":true,"material":"light"})"),
              HasSubstr("set_emitter.material: unknown field (set_emitter takes type, id, "
                        "emitter, on, radiance)"));
  EXPECT_THAT(refusal(R"({"type":"zoom","steps":1,"id":"one"})"),
              HasSubstr("zoom.id: must be an integer"));
  EXPECT_THAT(refusal(std::string(kMaxControlMessageBytes + 1, ' ')),
              HasSubstr("control messages are at most"));
}

v1::Light light(const std::string& name, v1::Light::Type type, v1::Vec3 position, float intensity) {
  v1::Light out;
  out.set_name(name);
  out.set_type(type);
  *out.mutable_position() = position;
  *out.mutable_direction() = vec(0, -1, 0);
  *out.mutable_intensity() = vec(intensity, intensity / 2, intensity / 4);
  return out;
}

// A scene with a point light, a directional light and a spot light, and two emissive materials.
v1::SceneInfo lit_scene() {
  v1::SceneInfo info;
  *info.add_light_list() = light("key", v1::Light::POINT, vec(100, 300, 0), 1e5f);
  *info.add_light_list() = light("sun", v1::Light::DIRECTIONAL, vec(0, 0, 0), 2);
  *info.add_light_list() = light("spot", v1::Light::SPOT, vec(-100, 300, 0), 4e4f);
  for (const char* name : {"lamp", "panel"}) {
    v1::Emitter& emitter = *info.add_emitters();
    emitter.set_material(name);
    *emitter.mutable_radiance() = vec(16, 8, 4);
    emitter.set_off(false);
  }
  info.mutable_epochs()->set_lights(7);
  *info.mutable_camera() = ring_camera();
  return info;
}

ViewerRequest request_of(std::string_view text) {
  absl::StatusOr<ViewerRequest> request = parse_request(text);
  EXPECT_TRUE(request.ok()) << request.status();
  return request.ok() ? *request : ViewerRequest{};
}

TEST(ViewerLights, ADragMovesOnlyThatLightAndSendsTheWholeList) {
  const v1::SceneInfo info = lit_scene();
  const v1::Light offered = light("viewer light", v1::Light::POINT, vec(0, 100, 0), 1);
  SceneLights scene = scene_lights(info, offered);
  EXPECT_FALSE(scene.viewer_light.has_value()) << "the scene has lights to drag";
  absl::StatusOr<v1::UpdateLightsRequest> update = light_update(
      request_of(R"({"type":"move_light","light":2,"u":0.7,"v":0.4})"), scene, ring_camera(), 800);
  ASSERT_TRUE(update.ok()) << update.status();
  EXPECT_EQ(update->expected_lights_epoch(), 7u);
  EXPECT_FALSE(update->keep_lights());
  ASSERT_EQ(update->lights_size(), 3);
  EXPECT_EQ(update->lights(0).SerializeAsString(), info.light_list(0).SerializeAsString());
  EXPECT_EQ(update->lights(1).SerializeAsString(), info.light_list(1).SerializeAsString());
  const std::optional<ImagePoint> before = project(ring_camera(), to_vec3d(vec(-100, 300, 0)));
  const std::optional<ImagePoint> after =
      project(ring_camera(), to_vec3d(update->lights(2).position()));
  ASSERT_TRUE(before && after);
  EXPECT_NEAR(after->u, 0.7, 1e-4);
  EXPECT_NEAR(after->v, 0.4, 1e-4);
  EXPECT_NEAR(after->depth, before->depth, 1e-3 * before->depth) << "the light keeps its depth";
  EXPECT_EQ(update->lights(2).name(), "spot");
  EXPECT_EQ(update->lights(2).intensity().x(), 4e4f);

  apply_light_update(scene, *update, 8);
  EXPECT_EQ(scene.epoch, 8u);
  const nlohmann::json lights = lights_json(scene, ring_camera());
  ASSERT_EQ(lights.size(), 3u);
  EXPECT_NEAR(lights[2]["u"].get<double>(), 0.7, 1e-4);
  EXPECT_EQ(lights[1]["type"], "directional");
  EXPECT_FALSE(lights[1]["draggable"]);
  EXPECT_FALSE(lights[1].contains("u"));
  EXPECT_FALSE(lights[0]["viewer_light"]);

  // The slider scales one light and keeps its colour.
  update = light_update(request_of(R"({"type":"set_intensity","light":0,"intensity":2e5})"), scene,
                        ring_camera(), 800);
  ASSERT_TRUE(update.ok()) << update.status();
  EXPECT_EQ(update->expected_lights_epoch(), 8u);
  EXPECT_FLOAT_EQ(update->lights(0).intensity().x(), 2e5f);
  EXPECT_FLOAT_EQ(update->lights(0).intensity().z(), 5e4f);
  EXPECT_EQ(update->lights(2).SerializeAsString(), scene.lights[2].SerializeAsString());
}

TEST(ViewerLights, BadTargetsSayWhatIsWrong) {
  const SceneLights scene =
      scene_lights(lit_scene(), light("viewer light", v1::Light::POINT, vec(0, 1, 0), 1));
  auto refusal = [&](std::string_view text) {
    absl::StatusOr<v1::UpdateLightsRequest> update =
        light_update(request_of(text), scene, ring_camera(), 800);
    EXPECT_FALSE(update.ok()) << text;
    if (update.ok()) return std::string();
    EXPECT_EQ(update.status().code(), absl::StatusCode::kInvalidArgument);
    return std::string(update.status().message());
  };
  EXPECT_THAT(refusal(R"({"type":"move_light","light":3,"u":0.5,"v":0.5})"),
              HasSubstr("move_light.light: 3 is not a light (the scene message lists 3)"));
  EXPECT_THAT(refusal(R"({"type":"set_intensity","light":9,"intensity":1})"),
              HasSubstr("set_intensity.light: 9 is not a light"));
  EXPECT_THAT(refusal(R"({"type":"move_light","light":1,"u":0.5,"v":0.5})"),
              HasSubstr("move_light.light: light 1 ('sun') is directional: only point and spot "
                        "lights have a position to drag"));
  EXPECT_THAT(refusal(R"({"type":"set_emitter","emitter":2,"on":false})"),
              HasSubstr("set_emitter.emitter: 2 is not an emitter (the scene has 2 emissive"));
  // A directional light's intensity may still change.
  EXPECT_TRUE(light_update(request_of(R"({"type":"set_intensity","light":1,"intensity":3})"), scene,
                           ring_camera(), 800)
                  .ok());
}

TEST(ViewerLights, AnEmitterChangeKeepsTheLightsAndNamesOneMaterial) {
  SceneLights scene =
      scene_lights(lit_scene(), light("viewer light", v1::Light::POINT, vec(0, 1, 0), 1));
  absl::StatusOr<v1::UpdateLightsRequest> off = light_update(
      request_of(R"({"type":"set_emitter","emitter":1,"on":false})"), scene, ring_camera(), 800);
  ASSERT_TRUE(off.ok()) << off.status();
  EXPECT_TRUE(off->keep_lights());
  EXPECT_EQ(off->lights_size(), 0);
  EXPECT_EQ(off->expected_lights_epoch(), 7u);
  ASSERT_EQ(off->emitters_size(), 1);
  EXPECT_EQ(off->emitters(0).material(), "panel");
  EXPECT_TRUE(off->emitters(0).has_off() && off->emitters(0).off());
  EXPECT_FALSE(off->emitters(0).has_radiance()) << "a switch leaves the radiance as it is";
  apply_light_update(scene, *off, 8);
  nlohmann::json emitters = emitters_json(scene);
  EXPECT_TRUE(emitters[0]["on"]);
  EXPECT_FALSE(emitters[1]["on"]);
  EXPECT_EQ(scene.lights.size(), 3u);

  absl::StatusOr<v1::UpdateLightsRequest> brighter = light_update(
      request_of(R"({"type":"set_emitter","emitter":0,"radiance":32})"), scene, ring_camera(), 800);
  ASSERT_TRUE(brighter.ok()) << brighter.status();
  EXPECT_FALSE(brighter->emitters(0).has_off());
  EXPECT_FLOAT_EQ(brighter->emitters(0).radiance().x(), 32);
  EXPECT_FLOAT_EQ(brighter->emitters(0).radiance().z(), 8) << "the colour stays";
  apply_light_update(scene, *brighter, 9);
  emitters = emitters_json(scene);
  EXPECT_FLOAT_EQ(emitters[0]["brightness"].get<float>(), 32);
  EXPECT_FALSE(emitters[1]["on"]);
}

// The environment's sliders send its intensity and rotation with keep_lights; a scene without one
// refuses them, and a message that changes nothing or goes out of range is refused by name.
TEST(ViewerLights, AnEnvironmentChangeKeepsTheLightsAndSetsIntensityAndRotation) {
  const v1::Light viewer_light = light("viewer light", v1::Light::POINT, vec(0, 1, 0), 1);
  SceneLights without = scene_lights(lit_scene(), viewer_light);
  EXPECT_TRUE(environment_json(without).is_null());
  const ViewerRequest turn = request_of(R"({"type":"set_environment","rotation":45})");
  absl::StatusOr<v1::UpdateLightsRequest> refused = light_update(turn, without, ring_camera(), 800);
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kFailedPrecondition);

  v1::SceneInfo info = lit_scene();
  info.mutable_environment()->set_intensity(2);
  info.mutable_environment()->set_rotation_deg(10);
  SceneLights scene = scene_lights(info, viewer_light);
  EXPECT_EQ(environment_json(scene)["intensity"], 2.0);
  absl::StatusOr<v1::UpdateLightsRequest> update = light_update(turn, scene, ring_camera(), 800);
  ASSERT_TRUE(update.ok()) << update.status();
  EXPECT_TRUE(update->keep_lights());
  EXPECT_EQ(update->lights_size(), 0);
  EXPECT_EQ(update->expected_lights_epoch(), 7u);
  EXPECT_FALSE(update->has_environment_intensity());
  EXPECT_EQ(update->environment_rotation_deg(), 45.0f);
  apply_light_update(scene, *update, 8);
  EXPECT_EQ(environment_json(scene)["rotation"], 45.0);
  EXPECT_EQ(environment_json(scene)["intensity"], 2.0);

  for (const auto& [text, message] :
       {std::pair{R"({"type":"set_environment"})", "set_environment: says nothing to change"},
        {R"({"type":"set_environment","intensity":-1})", "set_environment.intensity: must be in"},
        {R"({"type":"set_environment","rotation":"east"})", "set_environment.rotation"}}) {
    const absl::StatusOr<ViewerRequest> bad = parse_request(text);
    ASSERT_FALSE(bad.ok()) << text;
    EXPECT_THAT(std::string(bad.status().message()), HasSubstr(message)) << text;
  }
}

TEST(ViewerLights, TheViewerLightIsOfferedOnlyWithoutADraggableLightAndIsAdded) {
  v1::SceneInfo info = lit_scene();
  info.clear_light_list();
  *info.add_light_list() = light("sun", v1::Light::DIRECTIONAL, vec(0, 0, 0), 2);
  const v1::Light offered = light("viewer light", v1::Light::POINT, vec(0, 100, 0), 1);
  SceneLights scene = scene_lights(info, offered);
  ASSERT_TRUE(scene.viewer_light.has_value());
  nlohmann::json lights = lights_json(scene, ring_camera());
  ASSERT_EQ(lights.size(), 2u);
  EXPECT_EQ(lights[1]["index"], 1);
  EXPECT_TRUE(lights[1]["viewer_light"]);
  EXPECT_TRUE(lights[1]["draggable"]);

  absl::StatusOr<v1::UpdateLightsRequest> update = light_update(
      request_of(R"({"type":"move_light","light":1,"u":0.3,"v":0.6})"), scene, ring_camera(), 800);
  ASSERT_TRUE(update.ok()) << update.status();
  ASSERT_EQ(update->lights_size(), 2) << "the viewer light joins the scene's lights";
  EXPECT_EQ(update->lights(0).name(), "sun");
  EXPECT_EQ(update->lights(1).name(), "viewer light");
  EXPECT_EQ(update->expected_lights_epoch(), 7u);
  apply_light_update(scene, *update, 8);
  EXPECT_FALSE(scene.viewer_light.has_value());
  lights = lights_json(scene, ring_camera());
  ASSERT_EQ(lights.size(), 2u);
  EXPECT_FALSE(lights[1]["viewer_light"]);
  EXPECT_NEAR(lights[1]["u"].get<double>(), 0.3, 1e-4);

  // An area-lit scene without any light gets the viewer light as light 0.
  info.clear_light_list();
  scene = scene_lights(info, offered);
  update = light_update(request_of(R"({"type":"set_intensity","light":0,"intensity":5})"), scene,
                        ring_camera(), 800);
  ASSERT_TRUE(update.ok()) << update.status();
  ASSERT_EQ(update->lights_size(), 1);
  EXPECT_FLOAT_EQ(update->lights(0).intensity().x(), 5);
}

TEST(ViewerProtocol, ErrorMessageCarriesCodeMessageAndId) {
  const nlohmann::json message = nlohmann::json::parse(
      error_message(absl::UnauthenticatedError("ListScenes: missing 'authorization' header"), 7));
  EXPECT_EQ(message["type"], "error");
  EXPECT_EQ(message["code"], "UNAUTHENTICATED");
  EXPECT_EQ(message["message"], "ListScenes: missing 'authorization' header");
  EXPECT_EQ(message["id"], 7);
  EXPECT_FALSE(nlohmann::json::parse(error_message(absl::InternalError("x"))).contains("id"));
}

TEST(ViewerProtocol, FrameMessageIsLengthJsonThenImage) {
  v1::Frame header;
  header.set_scene_id("s-1");
  header.set_frame_number(4);
  header.set_width(32);
  header.set_height(16);
  header.set_passes(5);
  header.set_encoding(v1::PNG);
  header.mutable_epochs()->set_lights(3);
  header.mutable_timings()->set_render_ms(12.5);
  const std::string image = std::string("\x89PNG\r\n\x1a\n", 8) + "pixels";
  const std::string message = frame_message(header, image);
  ASSERT_GE(message.size(), 4u);
  uint32_t length = 0;
  for (int i = 0; i < 4; ++i) length |= uint32_t(static_cast<unsigned char>(message[i])) << (8 * i);
  ASSERT_EQ(message.size(), 4 + length + image.size());
  const nlohmann::json fields = nlohmann::json::parse(message.substr(4, length));
  EXPECT_EQ(fields["frame"], 4);
  EXPECT_EQ(fields["passes"], 5);
  EXPECT_EQ(fields["mime"], "image/png");
  EXPECT_EQ(fields["epochs"]["lights"], 3);
  EXPECT_EQ(fields["timings"]["render_ms"], 12.5);
  EXPECT_FALSE(fields.contains("strip_bytes")) << "one image, no strips";
  EXPECT_EQ(message.substr(4 + length), image);

  header.add_strip_bytes(10);
  header.add_strip_bytes(4);
  header.add_strip_rows(16);
  header.add_strip_rows(0);
  const std::string strips = frame_message(header, image);
  length = 0;
  for (int i = 0; i < 4; ++i) length |= uint32_t(static_cast<unsigned char>(strips[i])) << (8 * i);
  const nlohmann::json strip_fields = nlohmann::json::parse(strips.substr(4, length));
  EXPECT_EQ(strip_fields["strip_bytes"], nlohmann::json({10, 4}));
  EXPECT_EQ(strip_fields["strip_rows"], nlohmann::json({16, 0}));
}

TEST(ViewerProtocol, PrefersJpegWhereTheApiHasIt) {
  v1::Encoding jpeg;
  const v1::Encoding chosen = preferred_frame_encoding();
  if (v1::Encoding_Parse("JPEG", &jpeg)) {
    EXPECT_EQ(chosen, jpeg);
    EXPECT_EQ(encoding_mime_type(chosen), "image/jpeg");
  } else {
    EXPECT_EQ(chosen, v1::PNG);
  }
}

TEST(ViewerHttp, WebSocketsOnlyFromThePagesOwnOrigin) {
  EXPECT_TRUE(same_origin("http://127.0.0.1:8080", "127.0.0.1:8080"));
  EXPECT_TRUE(same_origin("HTTP://LocalHost:8080", "localhost:8080"));
  EXPECT_TRUE(same_origin("", "127.0.0.1:8080"));  // not a browser
  EXPECT_FALSE(same_origin("http://evil.example", "127.0.0.1:8080"));
  EXPECT_FALSE(same_origin("http://127.0.0.1:9999", "127.0.0.1:8080"));
  EXPECT_FALSE(same_origin("null", "127.0.0.1:8080"));
}

TEST(ViewerAssets, ThePageIsEmbeddedWithItsTypes) {
  const ViewerAsset* page = find_viewer_asset("/");
  ASSERT_NE(page, nullptr);
  EXPECT_EQ(page->path, "/index.html");
  EXPECT_EQ(page->content_type, "text/html; charset=utf-8");
  EXPECT_THAT(std::string(page->body), HasSubstr("viewer.js"));
  EXPECT_TRUE(page->etag.starts_with("\"") && page->etag.ends_with("\""));
  const ViewerAsset* script = find_viewer_asset("/viewer.js");
  ASSERT_NE(script, nullptr);
  EXPECT_EQ(script->content_type, "text/javascript; charset=utf-8");
  EXPECT_THAT(std::string(script->body), HasSubstr("causticaViewer"));
  EXPECT_EQ(find_viewer_asset("/viewer.css")->content_type, "text/css; charset=utf-8");
  EXPECT_EQ(find_viewer_asset("/../etc/passwd"), nullptr);
  EXPECT_EQ(find_viewer_asset("/missing.js"), nullptr);
  EXPECT_EQ(content_type_of("x.unknown"), "application/octet-stream");
}

}  // namespace
}  // namespace caustica::server::viewer
