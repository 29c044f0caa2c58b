// A bare model file as a scene (mesh_scene.h): the generated camera sees the whole model, the
// floor lies under it and the light above it; a glTF's own camera and lights are used instead.
#include "renderer/scene/mesh_scene.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
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
                                           "thirdparty/fbx/box.fbx", "thirdparty/off/Cube.off",
                                           "thirdparty/3mf/box.3mf"));

// A COLLADA file's own camera and lights (read through Assimp) replace the framing and the
// default light, as a glTF file's do.
TEST(BareMesh, AFilesCameraAndLightsReplaceTheFramingAndTheDefaultLight) {
  std::vector<std::string> warnings;
  const absl::StatusOr<Scene> scene =
      load_scene(scene_data("thirdparty/collada/cube_tristrips.dae"), &warnings);
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_THAT(scene->camera.position, Vec3Near(Vec3f(-427.749f, 333.855f, 655.017f), 1e-2f));
  EXPECT_EQ(scene->lights.size(), 2u);
  EXPECT_THAT(warnings, ::testing::Contains(HasSubstr("2 cameras; rendering through the first")));
}

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

// A 10 x 4 x 6 box as an OBJ file, its faces turned in (a room) or out (a solid block).
std::filesystem::path write_box(const std::string& name, bool inward) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / "caustica_interior_test";
  std::filesystem::create_directories(dir);
  const std::filesystem::path path = dir / name;
  std::ofstream out(path);
  for (const char* v : {"0 0 0", "10 0 0", "10 4 0", "0 4 0", "0 0 6", "10 0 6", "10 4 6", "0 4 6"})
    out << "v " << v << "\n";
  // Counter-clockwise seen from outside.
  const std::array<std::array<int, 4>, 6> faces = {
      {{1, 4, 3, 2}, {5, 6, 7, 8}, {1, 2, 6, 5}, {4, 8, 7, 3}, {1, 5, 8, 4}, {2, 3, 7, 6}}};
  for (const std::array<int, 4>& f : faces) {
    if (inward) {
      out << "f " << f[3] << " " << f[2] << " " << f[1] << " " << f[0] << "\n";
    } else {
      out << "f " << f[0] << " " << f[1] << " " << f[2] << " " << f[3] << "\n";
    }
  }
  return path;
}

// docs/scene-format.md, "Bare mesh files": a room is seen from its centre along its longer
// horizontal side and lit from above the camera, with no floor outside it; a solid block of the
// same shape, whose inside faces away, is framed from outside as any model.
TEST(BareMesh, AnInteriorIsSeenAndLitFromInside) {
  std::vector<std::string> warnings;
  const absl::StatusOr<Scene> room = load_mesh_scene(write_box("room.obj", true), &warnings);
  ASSERT_TRUE(room.ok()) << room.status();
  EXPECT_THAT(room->camera.position, Vec3Near(Vec3f(5, 2, 3), 1e-5f));
  EXPECT_THAT(room->camera.look_at - room->camera.position, Vec3Near(Vec3f(1, 0, 0), 1e-6f));
  EXPECT_EQ(room->camera.vertical_fov_deg, 60.0f);
  EXPECT_EQ(room->meshes.size(), 1u) << "no floor under a room";
  ASSERT_EQ(room->lights.size(), 1u);
  // Halfway to the ceiling, 2 above the centre.
  EXPECT_THAT(room->lights[0].position, Vec3Near(Vec3f(5, 3, 3), 1e-4f));
  EXPECT_GT(room->lights[0].intensity.x, 2 * 2 * 2);
  EXPECT_THAT(warnings, ::testing::Contains(HasSubstr("encloses its centre")));

  const absl::StatusOr<Scene> block = load_mesh_scene(write_box("block.obj", false));
  ASSERT_TRUE(block.ok()) << block.status();
  EXPECT_GT(length(block->camera.position - Vec3f(5, 2, 3)), 10.0f);
  EXPECT_EQ(block->meshes.size(), 2u) << "the block stands on a floor";
  std::filesystem::remove_all(std::filesystem::temp_directory_path() / "caustica_interior_test");
}

// A room whose walls emit gets no light of its own, and its warning does not promise one.
TEST(BareMesh, AnEmittingInteriorIsLitByItsOwnSurfaces) {
  absl::StatusOr<MeshFile> file = load_mesh_file(write_box("glowing_room.obj", true));
  ASSERT_TRUE(file.ok()) << file.status();
  Material glow;
  glow.name = "glow";
  glow.radiance = Vec3f(1);
  file->materials.push_back(glow);
  for (Mesh& mesh : file->meshes) mesh.material_ids.assign(mesh.triangle_count(), 0);
  std::vector<std::string> warnings;
  const absl::StatusOr<Scene> room =
      scene_around_mesh_file(*std::move(file), "glowing_room.obj", false, &warnings);
  ASSERT_TRUE(room.ok()) << room.status();
  EXPECT_TRUE(room->lights.empty());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_THAT(warnings[0], HasSubstr("encloses its centre; seen from there, lit by the file's "
                                     "emitting surfaces alone"));
  std::filesystem::remove_all(std::filesystem::temp_directory_path() / "caustica_interior_test");
}

}  // namespace
}  // namespace caustica
