// A bare model file as a scene (mesh_scene.h): the generated camera sees the whole model, the
// floor lies under it and the light above it; a glTF's own camera and lights are used instead.
#include "renderer/scene/mesh_scene.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "renderer/scene/load_scene.h"
#include "tests/renderer/scene/scene_test_util.h"

namespace caustica {
namespace {

using ::caustica::testing::message_of;
using ::caustica::testing::scene_data;
using ::caustica::testing::Vec3Near;
using ::testing::HasSubstr;

constexpr float kPi = 3.14159265358979f;

// Pixel coordinates of `p` through a pinhole camera as the renderer builds it (render/camera.h:
// forward, right = forward x up, image plane at distance 1), written out here from the
// definitions so that the test does not reuse the code it checks. False when p is behind.
bool project(const Camera& c, Vec3f p, float* x, float* y) {
  const Vec3f forward = normalize(c.look_at - c.position);
  const Vec3f right = normalize(cross(forward, c.up));
  const Vec3f up = cross(right, forward);
  const Vec3f d = p - c.position;
  const float depth = dot(d, forward);
  if (!(depth > 0)) return false;
  const float tan_half = std::tan(0.5f * c.vertical_fov_deg * kPi / 180.0f);
  const float aspect = float(c.width) / float(c.height);
  const float sx = dot(d, right) / depth / (tan_half * aspect);  // -1 left edge, +1 right edge
  const float sy = dot(d, up) / depth / tan_half;                // +1 top edge
  *x = 0.5f * (sx + 1) * c.width;
  *y = 0.5f * (1 - sy) * c.height;
  return true;
}

std::array<Vec3f, 8> corners(const Bounds& b) {
  std::array<Vec3f, 8> out;
  for (int i = 0; i < 8; ++i) {
    out[i] = {(i & 1) ? b.hi.x : b.lo.x, (i & 2) ? b.hi.y : b.lo.y, (i & 4) ? b.hi.z : b.lo.z};
  }
  return out;
}

void expect_frames(const Camera& camera, const Bounds& bounds) {
  for (const Vec3f& corner : corners(bounds)) {
    float x = 0, y = 0;
    ASSERT_TRUE(project(camera, corner, &x, &y)) << "corner behind the camera";
    EXPECT_GT(x, 0);
    EXPECT_LT(x, camera.width);
    EXPECT_GT(y, 0);
    EXPECT_LT(y, camera.height);
  }
}

TEST(FrameBounds, EveryCornerIsInsideTheImage) {
  const std::vector<Bounds> cases = {
      {{-1, -1, -1}, {1, 1, 1}},
      {{0, 0, 0}, {100, 1, 1}},              // long along x
      {{5, -3, 2}, {5.5f, 40, 2.1f}},        // tall and thin, off the origin
      {{-1e4f, 0, -1e4f}, {1e4f, 0, 1e4f}},  // flat, huge
  };
  for (const Camera image :
       {Camera{}, Camera{.width = 1920, .height = 1080}, Camera{.width = 400, .height = 1000}}) {
    for (const Bounds& bounds : cases) {
      const Camera camera = frame_bounds(bounds, image);
      EXPECT_EQ(camera.width, image.width);
      EXPECT_EQ(camera.height, image.height);
      expect_frames(camera, bounds);
      // From the front (+z) and above (+y).
      EXPECT_GT(camera.position.z, bounds.hi.z);
      EXPECT_GT(camera.position.y, bounds.hi.y);
    }
  }
}

void expect_floor_and_light(const Scene& scene, const Bounds& model) {
  const Mesh* floor = ::caustica::testing::find_mesh(scene, "floor");
  ASSERT_NE(floor, nullptr);
  const Bounds floor_bounds = mesh_bounds({*floor});
  EXPECT_LT(floor_bounds.hi.y, model.lo.y);
  EXPECT_EQ(floor_bounds.lo.y, floor_bounds.hi.y);
  // Wide enough to catch shadows: many times the model's extent each way.
  const float extent = length(model.size());
  EXPECT_LT(floor_bounds.lo.x, model.lo.x - 5 * extent);
  EXPECT_GT(floor_bounds.hi.x, model.hi.x + 5 * extent);
  EXPECT_LT(floor_bounds.lo.z, model.lo.z - 5 * extent);
  EXPECT_GT(floor_bounds.hi.z, model.hi.z + 5 * extent);
  EXPECT_GT(::caustica::testing::triangle_cross(*floor, 0).y, 0);  // facing up

  ASSERT_EQ(scene.lights.size(), 1u);
  const Light& light = scene.lights[0];
  EXPECT_EQ(light.type, LightType::kPoint);
  EXPECT_GT(light.position.y, model.hi.y);
  EXPECT_GT(light.position.z, model.center().z);  // in front
  // Exposure scales with size: irradiance at the model's centre is the same for every model.
  const float distance = length(light.position - model.center());
  EXPECT_NEAR(light.intensity.x / (distance * distance), 2.0f, 1e-3f);
}

class BareMeshTest : public ::testing::TestWithParam<const char*> {};

TEST_P(BareMeshTest, LoadSceneFramesFloorsAndLightsTheModel) {
  const absl::StatusOr<MeshFile> file = load_mesh_file(scene_data(GetParam()));
  ASSERT_TRUE(file.ok()) << file.status();
  std::vector<std::string> warnings;
  const absl::StatusOr<Scene> scene = load_scene(scene_data(GetParam()), &warnings);
  ASSERT_TRUE(scene.ok()) << scene.status();
  // The model's meshes plus the floor.
  EXPECT_EQ(scene->meshes.size(), file->meshes.size() + 1);
  std::vector<Mesh> model_meshes(scene->meshes.begin(), scene->meshes.end() - 1);
  const Bounds model = mesh_bounds(model_meshes);
  expect_frames(scene->camera, model);
  expect_floor_and_light(*scene, model);
  // Triangles without a material in the file got the default one.
  for (const Mesh& mesh : scene->meshes) {
    for (const uint32_t id : mesh.material_ids) ASSERT_LT(id, scene->materials.size());
  }
}

INSTANTIATE_TEST_SUITE_P(Formats, BareMeshTest,
                         ::testing::Values("meshes/quad_tri_ascii.ply", "meshes/plain.obj",
                                           "meshes/strips_fans.gltf",
                                           "thirdparty/stl/Spider_binary.stl",
                                           "thirdparty/collada/cube_tristrips.dae",
                                           "thirdparty/fbx/box.fbx", "thirdparty/off/Cube.off",
                                           "thirdparty/3mf/box.3mf"));

TEST(BareMesh, EmissiveMaterialsReplaceTheDefaultLight) {
  // box.mtl's "lamp" has Ke: the model lights itself, so no point light is added.
  const absl::StatusOr<Scene> scene = load_scene(scene_data("meshes/box.obj"));
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_TRUE(scene->lights.empty());
  const Material* lamp = ::caustica::testing::find_material(*scene, "lamp");
  ASSERT_NE(lamp, nullptr);
  EXPECT_EQ(lamp->type, MaterialType::kEmissive);
}

TEST(BareMesh, ZUpFormatsAreTurnedYUp) {
  // box.3mf spans x 0..10, y 0..20, z 0..30 with z up: standing 30 tall and 20 deep.
  const absl::StatusOr<Scene> scene = load_mesh_scene(scene_data("thirdparty/3mf/box.3mf"));
  ASSERT_TRUE(scene.ok()) << scene.status();
  const Bounds model = mesh_bounds({scene->meshes.front()});
  EXPECT_THAT(model.size(), Vec3Near(Vec3f(10, 30, 20), 1e-4f));
  EXPECT_NEAR(model.lo.y, 0, 1e-4f);
}

TEST(BareMesh, GltfCameraAndLightsAreUsed) {
  std::vector<std::string> warnings;
  const absl::StatusOr<Scene> scene =
      load_mesh_scene(scene_data("meshes/camera_light.gltf"), &warnings);
  ASSERT_TRUE(scene.ok()) << scene.status();
  // Node "Eye": at (1, 2, 10), turned 90 degrees about +y, so it looks down -x; yfov 0.6 rad,
  // aspect 1.5 on the default height.
  const Camera& camera = scene->camera;
  EXPECT_THAT(camera.position, Vec3Near(Vec3f(1, 2, 10), 1e-5f));
  EXPECT_THAT(normalize(camera.look_at - camera.position), Vec3Near(Vec3f(-1, 0, 0), 1e-5f));
  EXPECT_THAT(camera.up, Vec3Near(Vec3f(0, 1, 0), 1e-5f));
  EXPECT_NEAR(camera.vertical_fov_deg, 0.6f * 180 / kPi, 1e-4f);
  EXPECT_EQ(camera.height, Camera{}.height);
  EXPECT_EQ(camera.width, static_cast<int>(std::lround(1.5 * Camera{}.height)));
  // The orthographic camera is skipped, with a warning.
  EXPECT_THAT(warnings, ::testing::Contains(HasSubstr("is orthographic")));

  // The file's two lights and no default one.
  ASSERT_EQ(scene->lights.size(), 2u);
  const Light& spot = scene->lights[0];
  EXPECT_EQ(spot.name, "Spot");
  EXPECT_EQ(spot.type, LightType::kSpot);
  EXPECT_THAT(spot.position, Vec3Near(Vec3f(0, 4, 0), 1e-5f));
  EXPECT_THAT(spot.direction, Vec3Near(Vec3f(0, -1, 0), 1e-5f));
  EXPECT_THAT(spot.intensity, Vec3Near(Vec3f(20, 10, 5), 1e-5f));
  EXPECT_NEAR(spot.inner_angle_deg, 0.3f * 180 / kPi, 1e-4f);
  EXPECT_NEAR(spot.outer_angle_deg, 0.6f * 180 / kPi, 1e-4f);
  EXPECT_EQ(scene->lights[1].type, LightType::kDirectional);
  EXPECT_THAT(scene->lights[1].intensity, Vec3Near(Vec3f(2, 2, 2), 1e-6f));
  // The floor is still added under the quad at y = 0.
  const Mesh* floor = ::caustica::testing::find_mesh(*scene, "floor");
  ASSERT_NE(floor, nullptr);
  EXPECT_LT(floor->positions[0].y, 0);
}

TEST(BareMesh, ThirdPartyGltfCameraWithNodeTransform) {
  // Cameras.gltf: a perspective camera (yfov 0.7, aspect 1) at node translation (0.5, 0.5, 3)
  // and an orthographic one.
  const absl::StatusOr<Scene> scene = load_mesh_scene(scene_data("thirdparty/gltf2/Cameras.gltf"));
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_THAT(scene->camera.position, Vec3Near(Vec3f(0.5f, 0.5f, 3), 1e-6f));
  EXPECT_THAT(scene->camera.look_at, Vec3Near(Vec3f(0.5f, 0.5f, 2), 1e-6f));
  EXPECT_NEAR(scene->camera.vertical_fov_deg, 0.7f * 180 / kPi, 1e-4f);
  EXPECT_EQ(scene->camera.width, scene->camera.height);
}

TEST(BareMesh, ErrorsNameTheFile) {
  const absl::Status lines =
      load_scene(scene_data("thirdparty/gltf2/Mesh_PrimitiveMode_01.gltf")).status();
  EXPECT_THAT(message_of(lines), HasSubstr("Mesh_PrimitiveMode_01.gltf: "));
  const absl::Status gltf1 = load_scene(scene_data("thirdparty/gltf1/TwoBoxes.gltf")).status();
  EXPECT_THAT(message_of(gltf1), HasSubstr("TwoBoxes.gltf: this is a glTF 1.0 file"));
  const absl::Status missing = load_scene(scene_data("meshes/nope.fbx")).status();
  EXPECT_EQ(missing.code(), absl::StatusCode::kNotFound);
}

TEST(BareMesh, ModelWithoutExtentIsANamedError) {
  MeshFile file;
  Mesh mesh;
  mesh.positions = {{1, 1, 1}, {1, 1, 1}, {1, 1, 1}};
  mesh.indices = {0, 1, 2};
  mesh.material_ids = {kNoMaterial};
  file.meshes.push_back(mesh);
  const absl::Status status = scene_around_mesh_file(file, "dot.ply", false, nullptr).status();
  EXPECT_THAT(message_of(status), HasSubstr("dot.ply: the model has no extent"));
}

}  // namespace
}  // namespace caustica
