// validate_scene on scenes built in code: the checks that no well-formed file can reach.
#include "renderer/scene/validate.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
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

TEST(ValidateScene, RoughDielectricNeedsARoughnessInTheUnitInterval) {
  Scene scene = minimal_scene();
  scene.materials.push_back(
      {.name = "frosted", .type = MaterialType::kDielectric, .ior = 1.5f, .roughness = 0.4f});
  EXPECT_TRUE(validate_scene(scene).ok());
  scene.materials[1].roughness = 1.5f;
  EXPECT_THAT(error_of(scene),
              HasSubstr("materials.frosted.roughness: 1.5 is not a number in [0, 1]"));
  scene.materials[1].roughness = NAN;
  EXPECT_THAT(error_of(scene), HasSubstr("materials.frosted.roughness: nan is not a number"));
}

TEST(ValidateScene, MetallicRoughnessFactorsAndColourAreInTheUnitInterval) {
  const Material steel{.name = "steel",
                       .type = MaterialType::kMetallicRoughness,
                       .color = {0.9f, 0.8f, 0.7f},
                       .metallic = 1,
                       .roughness = 0.3f};
  Scene scene = minimal_scene();
  scene.materials.push_back(steel);
  EXPECT_TRUE(validate_scene(scene).ok());
  scene.materials[1].metallic = -0.5f;
  EXPECT_THAT(error_of(scene),
              HasSubstr("materials.steel.metallic: -0.5 is not a number in [0, 1]"));
  scene.materials[1].metallic = INFINITY;
  EXPECT_THAT(error_of(scene), HasSubstr("materials.steel.metallic: inf is not a number"));
  scene.materials[1] = steel;
  scene.materials[1].roughness = 2;
  EXPECT_THAT(error_of(scene), HasSubstr("materials.steel.roughness: 2 is not a number in [0, 1]"));
  scene.materials[1] = steel;
  scene.materials[1].color = {0.5f, 1.5f, 0.5f};
  EXPECT_THAT(error_of(scene),
              HasSubstr("materials.steel.color: (0.5, 1.5, 0.5) has a channel above 1"));
  scene.materials[1].color = {0.5f, -0.5f, 0.5f};
  EXPECT_THAT(error_of(scene), HasSubstr("materials.steel.color: (0.5, -0.5, 0.5) has a negative"));
}

TEST(ValidateScene, PhongColoursConserveEnergyAndItsExponentIsPositive) {
  const Material plastic{.name = "plastic",
                         .type = MaterialType::kPhong,
                         .color = {0.5f, 0.4f, 0.3f},
                         .specular = {0.5f, 0.25f, 0.2f},
                         .exponent = 50};
  Scene scene = minimal_scene();
  scene.materials.push_back(plastic);
  EXPECT_TRUE(validate_scene(scene).ok());  // red sums to exactly 1
  scene.materials[1].color = {1.25f, 0.4f, 0.3f};
  EXPECT_THAT(error_of(scene), HasSubstr("materials.plastic.color: (1.25, 0.4, 0.3) has a channel "
                                         "above 1"));
  scene.materials[1] = plastic;
  scene.materials[1].specular = {0.5f, NAN, 0.2f};
  EXPECT_THAT(error_of(scene),
              HasSubstr("materials.plastic.specular: (0.5, nan, 0.2) is not finite"));
  scene.materials[1].specular = {0.5f, -0.25f, 0.2f};
  EXPECT_THAT(error_of(scene),
              HasSubstr("materials.plastic.specular: (0.5, -0.25, 0.2) has a negative"));
  scene.materials[1] = plastic;
  scene.materials[1].specular = {0.5f, 0.75f, 0.2f};
  EXPECT_THAT(error_of(scene),
              HasSubstr("materials.plastic.specular: color + specular = (1, 1.15, 0.5) has a "
                        "channel above 1"));
  scene.materials[1] = plastic;
  for (const float exponent : {0.0f, -3.0f, 2e6f, float(NAN), float(INFINITY)}) {
    scene.materials[1].exponent = exponent;
    EXPECT_THAT(error_of(scene), HasSubstr(absl::StrCat("materials.plastic.exponent: ", exponent,
                                                        " is not a number in (0, 1e+06]")));
  }
  scene.materials[1].exponent = kMaxPhongExponent;
  EXPECT_TRUE(validate_scene(scene).ok());
}

}  // namespace
}  // namespace caustica
