// Lights files and animation scripts: values as the scene format defines them, and errors that name
// the keyframe and the field.
#include "client/light_json.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

namespace caustica::client {
namespace {

using ::testing::HasSubstr;

constexpr char kScript[] = R"json({
  // comments are allowed, as in scene files
  "keyframes": [
    {"lights": [{"type": "point", "name": "bulb", "position": [1, 2, 3], "intensity": [10, 20, 30]}],
     "passes": 2},
    {"lights": [{"type": "spot", "position": [0, 5, 0], "direction": [0, -2, 0],
                 "intensity": [7, 7, 7]},
                {"type": "directional", "direction": [3, 0, 4], "irradiance": [0.5, 0.25, 1]}]},
    {"lights": [], "passes": 4.0}
  ]
})json";

TEST(LightScript, ReadsEveryKeyframeWithTheSceneFormatsValues) {
  absl::StatusOr<std::vector<v1::Keyframe>> keyframes =
      parse_animation_script(kScript, "orbit.json");
  ASSERT_TRUE(keyframes.ok()) << keyframes.status();
  ASSERT_EQ(keyframes->size(), 3u);

  const v1::Keyframe& k0 = (*keyframes)[0];
  EXPECT_EQ(k0.passes(), 2u);
  ASSERT_EQ(k0.lights_size(), 1);
  EXPECT_EQ(k0.lights(0).name(), "bulb");
  EXPECT_EQ(k0.lights(0).type(), v1::Light::POINT);
  EXPECT_EQ(k0.lights(0).position().y(), 2.0f);
  EXPECT_EQ(k0.lights(0).intensity().z(), 30.0f);

  const v1::Keyframe& k1 = (*keyframes)[1];
  EXPECT_EQ(k1.passes(), 0u);  // absent: the server renders one
  ASSERT_EQ(k1.lights_size(), 2);
  const v1::Light& spot = k1.lights(0);
  EXPECT_EQ(spot.type(), v1::Light::SPOT);
  EXPECT_EQ(spot.direction().y(), -1.0f);    // normalised, as on load
  EXPECT_EQ(spot.inner_angle_deg(), 30.0f);  // the scene format's defaults
  EXPECT_EQ(spot.outer_angle_deg(), 45.0f);
  const v1::Light& sun = k1.lights(1);
  EXPECT_EQ(sun.type(), v1::Light::DIRECTIONAL);
  EXPECT_FLOAT_EQ(sun.direction().x(), 0.6f);
  EXPECT_FLOAT_EQ(sun.direction().z(), 0.8f);
  EXPECT_EQ(sun.intensity().y(), 0.25f);  // irradiance travels as intensity

  EXPECT_EQ((*keyframes)[2].lights_size(), 0);
  EXPECT_EQ((*keyframes)[2].passes(), 4u);
}

std::string error_of(const char* text) {
  absl::StatusOr<std::vector<v1::Keyframe>> keyframes = parse_animation_script(text, "s.json");
  EXPECT_FALSE(keyframes.ok());
  EXPECT_EQ(keyframes.status().code(), absl::StatusCode::kInvalidArgument);
  return std::string(keyframes.status().message());
}

TEST(LightScript, ErrorsNameTheKeyframeAndTheField) {
  EXPECT_THAT(error_of(R"({"keyframes": [{"lights": []},
      {"lights": [{"type": "point", "position": [1, 2, 3]}]}]})"),
              HasSubstr("s.json: keyframes[1]: lights[0].intensity"));
  EXPECT_THAT(error_of(R"({"keyframes": [{"lights": [{"type": "point", "position": [1, 2],
      "intensity": [1, 1, 1]}]}]})"),
              HasSubstr("s.json: keyframes[0]: lights[0].position"));
  EXPECT_THAT(error_of(R"({"keyframes": [{"lights": [{"type": "laser"}]}]})"),
              HasSubstr("keyframes[0]: lights[0].type: unknown light type 'laser'"));
  EXPECT_THAT(error_of(R"({"keyframes": [{"lights": [{"type": "point", "position": [0, 0, 0],
      "intensity": [1, 1, 1], "colour": [1, 0, 0]}]}]})"),
              HasSubstr("keyframes[0]: lights[0].colour"));
  EXPECT_THAT(error_of(R"({"keyframes": [{"lights": [], "pases": 2}]})"),
              HasSubstr("s.json: keyframes[0].pases: unknown key (expected lights, passes, camera, "
                        "emitters, environment, meshes)"));
  EXPECT_THAT(
      error_of(R"({"keyframes": [{"lights": []}, {"lights": []}, {"lights": [], "passes": 1.5}]})"),
      HasSubstr("s.json: keyframes[2].passes: expected an integer from 0 to 100000, got 1.5"));
  EXPECT_THAT(error_of(R"({"keyframes": [{"lights": {}}]})"),
              HasSubstr("s.json: keyframes[0]: lights: expected an array"));
  EXPECT_THAT(error_of(R"({"keyframes": [3]})"),
              HasSubstr("s.json: keyframes[0]: expected an object"));
  EXPECT_THAT(error_of(R"({"keyframes": []})"),
              HasSubstr("s.json: keyframes: expected a non-empty"));
  EXPECT_THAT(error_of(R"({"frames": []})"), HasSubstr("s.json: frames: unknown key"));
}

// A keyframe may move the camera, read as a scene file's camera without its size.
TEST(LightScript, AKeyframeMayMoveTheCamera) {
  absl::StatusOr<std::vector<v1::Keyframe>> keyframes = parse_animation_script(
      R"({"keyframes": [{"lights": []},
          {"lights": [], "camera": {"position": [1, 2, 3], "look_at": [1, 2, 4], "fov": 50}}]})",
      "flight.json");
  ASSERT_TRUE(keyframes.ok()) << keyframes.status();
  EXPECT_FALSE((*keyframes)[0].has_camera());
  ASSERT_TRUE((*keyframes)[1].has_camera());
  const v1::Camera& camera = (*keyframes)[1].camera();
  EXPECT_EQ(camera.position().z(), 3.0f);
  EXPECT_EQ(camera.look_at().z(), 4.0f);
  EXPECT_EQ(camera.up().y(), 1.0f);  // the scene format's default
  EXPECT_EQ(camera.vertical_fov_deg(), 50.0f);
  EXPECT_EQ(camera.width(), 0u);  // the scene's size
  EXPECT_EQ(camera.height(), 0u);

  EXPECT_THAT(error_of(R"({"keyframes": [{"lights": [], "camera": {"position": [0, 0, 0],
      "look_at": [0, 0, 1], "fov": 40, "width": 64}}]})"),
              HasSubstr("s.json: keyframes[0].camera.width: unknown key (expected position, "
                        "look_at, up, fov)"));
  EXPECT_THAT(error_of(R"({"keyframes": [{"lights": []}, {"lights": [], "camera": {
      "position": [0, 0], "look_at": [0, 0, 1], "fov": 40}}]})"),
              HasSubstr("s.json: keyframes[1]: camera.position"));
  EXPECT_THAT(error_of(R"({"keyframes": [{"lights": [], "camera": [0, 0, 0]}]})"),
              HasSubstr("s.json: keyframes[0].camera: expected an object"));
}

// A keyframe may move meshes (a scene file's shape transform), change area lights and the
// environment; without "lights" it keeps those of the keyframe before.
TEST(LightScript, AKeyframeMayMoveMeshesAndChangeEmittersAndTheEnvironment) {
  absl::StatusOr<std::vector<v1::Keyframe>> keyframes = parse_animation_script(
      R"({"keyframes": [
          {"meshes": [{"mesh": "glass sphere", "transform": {"translate": [1, 2, 3]}},
                      {"mesh": "dragon", "transform": {"rotate": [0, 90, 0], "scale": 2}}],
           "emitters": [{"material": "light", "radiance": [4, 5, 6]}, {"material": "lamp",
                         "off": true}],
           "environment": {"intensity": 0.5, "rotation": 30}},
          {"lights": []}]})",
      "turn.json");
  ASSERT_TRUE(keyframes.ok()) << keyframes.status();
  const v1::Keyframe& k0 = (*keyframes)[0];
  EXPECT_TRUE(k0.keep_lights());
  EXPECT_FALSE((*keyframes)[1].keep_lights());  // an empty array: only the area lights
  ASSERT_EQ(k0.meshes_size(), 2);
  EXPECT_EQ(k0.meshes(0).mesh(), "glass sphere");
  // The top three rows of the 4x4 matrix, row by row: a translation's last column.
  ASSERT_EQ(k0.meshes(0).transform_size(), 12);
  EXPECT_EQ(k0.meshes(0).transform(3), 1.0);
  EXPECT_EQ(k0.meshes(0).transform(7), 2.0);
  EXPECT_EQ(k0.meshes(0).transform(11), 3.0);
  // Scale 2 then 90 degrees about y: x goes to -z, twice as long.
  ASSERT_EQ(k0.meshes(1).transform_size(), 12);
  EXPECT_NEAR(k0.meshes(1).transform(8), -2.0, 1e-12);
  EXPECT_EQ(k0.meshes(1).positions_size(), 0);
  ASSERT_EQ(k0.emitters_size(), 2);
  EXPECT_EQ(k0.emitters(0).material(), "light");
  EXPECT_EQ(k0.emitters(0).radiance().z(), 6.0f);
  EXPECT_FALSE(k0.emitters(0).has_off());
  EXPECT_TRUE(k0.emitters(1).off());
  EXPECT_EQ(k0.environment_intensity(), 0.5f);
  EXPECT_EQ(k0.environment_rotation_deg(), 30.0f);
  EXPECT_FALSE((*keyframes)[1].has_environment_intensity());

  EXPECT_THAT(
      error_of(R"({"keyframes": [{"meshes": [{"mesh": "a", "transform": {"scale": 0}}]}]})"),
      HasSubstr("s.json: keyframes[0].meshes[0].transform.scale: must not be zero"));
  EXPECT_THAT(error_of(R"({"keyframes": [{}, {"meshes": [{"mesh": "a"}]}]})"),
              HasSubstr("s.json: keyframes[1].meshes[0].transform: is required"));
  EXPECT_THAT(error_of(R"({"keyframes": [{"meshes": [{"mesh": "a", "transform": {},
      "position": [1, 2, 3]}]}]})"),
              HasSubstr("s.json: keyframes[0].meshes[0].position: unknown key"));
  EXPECT_THAT(error_of(R"({"keyframes": [{"emitters": [{"radiance": [1, 1, 1]}]}]})"),
              HasSubstr("s.json: keyframes[0].emitters[0].material: is required"));
  EXPECT_THAT(error_of(R"({"keyframes": [{"environment": {"intensity": "high"}}]})"),
              HasSubstr("s.json: keyframes[0].environment.intensity"));
  EXPECT_THAT(error_of(R"({"keyframes": [{"meshes": {}}]})"),
              HasSubstr("s.json: keyframes[0].meshes: expected an array"));
}

TEST(LightScript, SyntaxErrorsGiveLineAndColumn) {
  EXPECT_THAT(error_of("{\"keyframes\": [\n  {\"lights\": [}\n]}"),
              HasSubstr("s.json:2:15: JSON syntax error"));
}

TEST(LightsFile, AcceptsTheObjectAndTheBareArray) {
  constexpr char kLight[] = R"([{"type": "point", "position": [4, 5, 6], "intensity": 2}])";
  absl::StatusOr<std::vector<v1::Light>> bare = parse_lights_file(kLight, "l.json");
  // A single number is not a colour in scene files either.
  ASSERT_FALSE(bare.ok());
  EXPECT_THAT(bare.status().message(), HasSubstr("l.json: lights[0].intensity"));

  absl::StatusOr<std::vector<v1::Light>> object = parse_lights_file(
      R"({"lights": [{"type": "point", "position": [4, 5, 6], "intensity": [2, 2, 2]},
                     {"type": "point", "position": [0, 1, 0], "intensity": [1, 0, 0]}]})",
      "l.json");
  ASSERT_TRUE(object.ok()) << object.status();
  ASSERT_EQ(object->size(), 2u);
  EXPECT_EQ((*object)[0].position().z(), 6.0f);
  EXPECT_EQ((*object)[1].intensity().x(), 1.0f);

  absl::StatusOr<std::vector<v1::Light>> array = parse_lights_file(
      R"([{"type": "directional", "direction": [0, -1, 0], "irradiance": [3, 3, 3]}])", "l.json");
  ASSERT_TRUE(array.ok()) << array.status();
  ASSERT_EQ(array->size(), 1u);
  EXPECT_EQ((*array)[0].type(), v1::Light::DIRECTIONAL);

  absl::StatusOr<std::vector<v1::Light>> neither = parse_lights_file(R"({"light": []})", "l.json");
  EXPECT_THAT(neither.status().message(), HasSubstr("expected {\"lights\": [...]}"));
}

}  // namespace
}  // namespace caustica::client
