// validate_scene on scenes built in code: the checks that no well-formed file can reach.
#include "renderer/scene/validate.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "renderer/scene/scene_limits.h"
#include "renderer/scene/shapes.h"
#include "tests/renderer/scene/scene_test_util.h"

namespace caustica {
namespace {

using ::caustica::testing::message_of;
using ::testing::HasSubstr;

Scene minimal_scene() {
  Scene scene;
  scene.camera.position = {0, 1, -5};
  scene.camera.look_at = {0, 1, 0};
  scene.materials.push_back({.name = "white"});
  Mesh floor = make_quad({Vec3f{-1, 0, -1}, Vec3f{-1, 0, 1}, Vec3f{1, 0, 1}, Vec3f{1, 0, -1}});
  floor.name = "floor";
  floor.material_ids = {0, 0};
  scene.meshes.push_back(floor);
  scene.lights.push_back(Light{.name = "bulb", .position = {0, 3, 0}});
  return scene;
}

std::string error_of(const Scene& scene) { return message_of(validate_scene(scene)); }

TEST(ValidateScene, MinimalSceneIsValid) { EXPECT_TRUE(validate_scene(minimal_scene()).ok()); }

TEST(ValidateScene, TriangleAndMaterialCountsMustMatch) {
  Scene scene = minimal_scene();
  scene.meshes[0].material_ids.pop_back();
  EXPECT_THAT(error_of(scene), HasSubstr("mesh floor: 2 triangles but 1 material ids"));
}

TEST(ValidateScene, UnnamedMeshIsNamedByIndex) {
  Scene scene = minimal_scene();
  scene.meshes[0].name.clear();
  scene.meshes[0].material_ids.clear();
  EXPECT_THAT(error_of(scene), HasSubstr("meshes[0]: 2 triangles but 0 material ids"));
}

TEST(ValidateScene, IndexCountMustBeTriples) {
  Scene scene = minimal_scene();
  scene.meshes[0].indices.push_back(0);
  EXPECT_THAT(error_of(scene), HasSubstr("mesh floor: index count 7 is not a multiple of 3"));
}

TEST(ValidateScene, IndicesMustBeInRange) {
  Scene scene = minimal_scene();
  scene.meshes[0].indices[4] = 4;
  EXPECT_THAT(error_of(scene),
              HasSubstr("mesh floor: triangle 1 refers to vertex 4, but the mesh has 4"));
}

TEST(ValidateScene, MaterialIdsMustBeInRange) {
  Scene scene = minimal_scene();
  scene.meshes[0].material_ids[1] = 3;
  EXPECT_THAT(error_of(scene), HasSubstr("triangle 1 refers to material 3"));
}

TEST(ValidateScene, AttributeArraysMatchPositions) {
  Scene scene = minimal_scene();
  scene.meshes[0].normals.resize(3);
  EXPECT_THAT(error_of(scene), HasSubstr("4 vertices but 3 normals"));
  scene = minimal_scene();
  scene.meshes[0].uvs.resize(5);
  EXPECT_THAT(error_of(scene), HasSubstr("4 vertices but 5 texture coordinates"));
  scene = minimal_scene();
  scene.meshes[0].normals.assign(4, Vec3f(0, 1, 0));
  scene.meshes[0].tangents.assign(2, Vec4f{1, 0, 0, 1});
  EXPECT_THAT(error_of(scene), HasSubstr("4 vertices but 2 tangents"));
}

TEST(ValidateScene, TangentsNeedNormalsAndASign) {
  Scene scene = minimal_scene();
  scene.meshes[0].tangents.assign(4, Vec4f{1, 0, 0, 1});
  EXPECT_THAT(error_of(scene), HasSubstr("mesh floor: has tangents but no normals"));
  scene.meshes[0].normals.assign(4, Vec3f(0, 1, 0));
  EXPECT_TRUE(validate_scene(scene).ok());
  scene.meshes[0].tangents[2].w = 0;
  EXPECT_THAT(error_of(scene),
              HasSubstr("mesh floor: vertex 2 tangent (1, 0, 0, 0) has w = 0, not 1 or -1"));
  scene.meshes[0].tangents[2] = {NAN, 0, 0, -1};
  EXPECT_THAT(error_of(scene), HasSubstr("vertex 2 tangent (nan, 0, 0, -1) is not finite"));
}

TEST(ValidateScene, TextureCoordinatesMustBeFinite) {
  Scene scene = minimal_scene();
  scene.meshes[0].uvs.assign(4, Vec2f{0.5f, 0.5f});
  scene.meshes[0].uvs[3].y = INFINITY;
  EXPECT_THAT(error_of(scene), HasSubstr("mesh floor: vertex 3 texture coordinates (0.5, inf)"));
}

TEST(ValidateScene, VerticesAndNormalsMustBeFinite) {
  Scene scene = minimal_scene();
  scene.meshes[0].positions[3].z = INFINITY;
  EXPECT_THAT(error_of(scene), HasSubstr("mesh floor: vertex 3 position (1, 0, inf)"));
  scene = minimal_scene();
  scene.meshes[0].normals.assign(4, Vec3f(0, 1, 0));
  scene.meshes[0].normals[1].x = NAN;
  EXPECT_THAT(error_of(scene), HasSubstr("vertex 1 normal (nan, 1, 0) is not finite"));
}

TEST(ValidateScene, UnknownEnumValuesAreRejected) {
  Scene scene = minimal_scene();
  scene.materials[0].type = static_cast<MaterialType>(9);
  EXPECT_THAT(error_of(scene), HasSubstr("materials.white: has an unknown type"));
  scene = minimal_scene();
  scene.lights[0].type = static_cast<LightType>(7);
  EXPECT_THAT(error_of(scene), HasSubstr("lights[0] ('bulb'): has an unknown type"));
  scene = minimal_scene();
  scene.settings.kernel = static_cast<DensityKernel>(5);
  EXPECT_THAT(error_of(scene), HasSubstr("settings.kernel"));
  scene = minimal_scene();
  scene.settings.structure = static_cast<StructureKind>(9);
  EXPECT_THAT(error_of(scene), HasSubstr("settings.structure: is not a known structure"));
}

TEST(ValidateScene, EmissiveTriangleCountsAsLight) {
  Scene scene = minimal_scene();
  scene.lights.clear();
  EXPECT_THAT(error_of(scene), HasSubstr("scene has no light"));
  scene.materials.push_back(
      {.name = "lamp", .type = MaterialType::kEmissive, .radiance = {1, 1, 1}});
  scene.meshes[0].material_ids[1] = 1;
  EXPECT_TRUE(validate_scene(scene).ok());
  // Black emitters give no light.
  scene.materials[1].radiance = Vec3f(0);
  EXPECT_THAT(error_of(scene), HasSubstr("scene has no light"));
}

// The total is checked on a count: a scene over the limit would take gigabytes to build here.
TEST(ValidateScene, TriangleTotalMustFitTheTriangleStructure) {
  EXPECT_TRUE(validate_triangle_total(kMaxSceneTriangles).ok());
  const absl::Status over = validate_triangle_total(kMaxSceneTriangles + 1);
  EXPECT_EQ(over.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(message_of(over),
              HasSubstr("scene has 268435457 triangles in all meshes, more than the limit of "
                        "268435456 per scene"));
}

TEST(ValidateScene, DielectricNeedsPositiveIor) {
  Scene scene = minimal_scene();
  scene.materials.push_back({.name = "glass", .type = MaterialType::kDielectric, .ior = 0});
  EXPECT_THAT(error_of(scene), HasSubstr("materials.glass.ior: 0 is not a positive number"));
}

}  // namespace
}  // namespace caustica
