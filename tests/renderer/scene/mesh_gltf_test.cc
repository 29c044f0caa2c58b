#include "renderer/scene/mesh_gltf.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "tests/renderer/scene/scene_test_util.h"

namespace caustica {
namespace {

using ::caustica::testing::message_of;
using ::caustica::testing::scene_data;
using ::caustica::testing::triangle_cross;
using ::caustica::testing::Vec3Near;
using ::testing::HasSubstr;

constexpr float kRadToDeg = 180.0f / 3.14159265358979f;

const Mesh* mesh_named(const MeshFile& file, const std::string& part) {
  for (const Mesh& mesh : file.meshes) {
    if (mesh.name.find(part) != std::string::npos) return &mesh;
  }
  return nullptr;
}

class LoadGltfTest : public ::testing::TestWithParam<const char*> {
 protected:
  void SetUp() override {
    absl::StatusOr<MeshFile> loaded = load_gltf(scene_data(GetParam()));
    ASSERT_TRUE(loaded.ok()) << loaded.status();
    file_ = *std::move(loaded);
  }
  MeshFile file_;
};

TEST_P(LoadGltfTest, TakesTrianglePrimitivesOfTheDefaultScene) {
  // Quad (1 primitive) and Tri (3 triangle primitives; the POINTS one and the orphan node's
  // mesh are left out).
  ASSERT_EQ(file_.meshes.size(), 4u);
  size_t triangles = 0;
  for (const Mesh& mesh : file_.meshes) triangles += mesh.triangle_count();
  EXPECT_EQ(triangles, 5u);
  EXPECT_THAT(file_.meshes[0].name, HasSubstr("mesh 'Quad' primitive 0 at node 'QuadNode'"));
}

TEST_P(LoadGltfTest, AppliesTheNodeHierarchy) {
  // Root scales by 2 and QuadNode moves up by 1: p -> 2 (p + (0, 1, 0)).
  const Mesh* quad = mesh_named(file_, "'Quad' primitive 0");
  ASSERT_NE(quad, nullptr);
  EXPECT_THAT(quad->positions[0], Vec3Near(Vec3f(-2, 2, -2), 1e-6f));
  EXPECT_THAT(quad->positions[2], Vec3Near(Vec3f(2, 2, 2), 1e-6f));
  ASSERT_EQ(quad->normals.size(), 4u);
  EXPECT_THAT(quad->normals[0], Vec3Near(Vec3f(0, 1, 0), 1e-6f));
  ASSERT_EQ(quad->uvs.size(), 4u);
  EXPECT_EQ(quad->uvs[2].x, 1.0f);
  EXPECT_EQ(quad->indices, (std::vector<uint32_t>{0, 2, 1, 0, 3, 2}));
  EXPECT_GT(triangle_cross(*quad, 0).y, 0);

  // Root (scale 2) * Spinner (90 degrees about y) * TriNode (x + 1): p -> 2 Ry(p + (1, 0, 0)).
  const Mesh* mirror = mesh_named(file_, "'Tri' primitive 0");
  ASSERT_NE(mirror, nullptr);
  EXPECT_EQ(mirror->indices, (std::vector<uint32_t>{0, 1, 2}));  // uint8 indices
  EXPECT_THAT(mirror->positions[0], Vec3Near(Vec3f(-2, 0, 0), 1e-5f));
  EXPECT_THAT(mirror->positions[1], Vec3Near(Vec3f(-2, 0, -4), 1e-5f));
  const Mesh* glass = mesh_named(file_, "'Tri' primitive 1");
  ASSERT_NE(glass, nullptr);
  EXPECT_EQ(glass->indices, (std::vector<uint32_t>{0, 2, 3}));  // uint32 indices
  const Mesh* lamp = mesh_named(file_, "'Tri' primitive 2");
  ASSERT_NE(lamp, nullptr);
  EXPECT_EQ(lamp->indices, (std::vector<uint32_t>{0, 1, 2}));  // not indexed
  EXPECT_THAT(lamp->positions[0], Vec3Near(Vec3f(0, 0, -2), 1e-5f));
}

// The file's pbrMetallicRoughness factors as they are, no longer sorted into diffuse and mirror.
TEST_P(LoadGltfTest, MapsPbrMaterials) {
  ASSERT_EQ(file_.materials.size(), 4u);
  // "Clay": baseColorFactor [0.5, 0.25, 0.125, 1], metallicFactor 0, roughnessFactor 1.
  const Material& clay = file_.materials[0];
  EXPECT_EQ(clay.name, "Clay");
  EXPECT_EQ(clay.type, MaterialType::kMetallicRoughness);
  EXPECT_THAT(clay.color, Vec3Near(Vec3f(0.5f, 0.25f, 0.125f), 0));
  EXPECT_EQ(clay.metallic, 0.0f);
  EXPECT_EQ(clay.roughness, 1.0f);
  // "Chrome": [0.9, 0.8, 0.7, 1], metallicFactor 1, roughnessFactor 0.
  const Material& chrome = file_.materials[1];
  EXPECT_EQ(chrome.type, MaterialType::kMetallicRoughness);
  EXPECT_THAT(chrome.color, Vec3Near(Vec3f(0.9f, 0.8f, 0.7f), 1e-6f));
  EXPECT_EQ(chrome.metallic, 1.0f);
  EXPECT_EQ(chrome.roughness, 0.0f);
  // "Glass": transmissionFactor 1, KHR_materials_ior 1.33, roughnessFactor 0: smooth glass.
  EXPECT_EQ(file_.materials[2].type, MaterialType::kDielectric);
  EXPECT_FLOAT_EQ(file_.materials[2].ior, 1.33f);
  EXPECT_EQ(file_.materials[2].roughness, 0.0f);
  // "Lamp" has no pbrMetallicRoughness: the specification's white base, metallic 1 and
  // roughness 1, with its emission on top.
  const Material& lamp = file_.materials[3];
  EXPECT_EQ(lamp.type, MaterialType::kMetallicRoughness);
  EXPECT_THAT(lamp.color, Vec3Near(Vec3f(1, 1, 1), 0));
  EXPECT_EQ(lamp.metallic, 1.0f);
  EXPECT_EQ(lamp.roughness, 1.0f);
  EXPECT_THAT(file_.materials[3].radiance, Vec3Near(Vec3f(4, 2, 1), 0));
  EXPECT_TRUE(is_emitter(file_.materials[3]));
  EXPECT_FALSE(is_emitter(file_.materials[0]));
  EXPECT_EQ(mesh_named(file_, "'Quad'")->material_ids, (std::vector<uint32_t>{0, 0}));
  EXPECT_EQ(mesh_named(file_, "'Tri' primitive 2")->material_ids, (std::vector<uint32_t>{3}));
}

TEST_P(LoadGltfTest, ReadsPunctualLightsWithNodeTransforms) {
  ASSERT_EQ(file_.lights.size(), 3u);
  const Light& bulb = file_.lights[0];
  EXPECT_EQ(bulb.name, "Bulb");
  EXPECT_EQ(bulb.type, LightType::kPoint);
  EXPECT_THAT(bulb.position, Vec3Near(Vec3f(0, 5, 0), 1e-6f));
  EXPECT_THAT(bulb.intensity, Vec3Near(Vec3f(100, 50, 25), 1e-4f));

  const Light& spot = file_.lights[1];
  EXPECT_EQ(spot.type, LightType::kSpot);
  EXPECT_THAT(spot.position, Vec3Near(Vec3f(1, 2, 3), 1e-6f));
  // -90 degrees about x turns the light's -z axis to -y.
  EXPECT_THAT(spot.direction, Vec3Near(Vec3f(0, -1, 0), 1e-6f));
  EXPECT_THAT(spot.intensity, Vec3Near(Vec3f(50, 50, 50), 1e-4f));
  EXPECT_NEAR(spot.inner_angle_deg, 0.2f * kRadToDeg, 1e-4f);
  EXPECT_NEAR(spot.outer_angle_deg, 0.5f * kRadToDeg, 1e-4f);

  const Light& sun = file_.lights[2];
  EXPECT_EQ(sun.type, LightType::kDirectional);
  // The node matrix turns 90 degrees about y: -z becomes -x.
  EXPECT_THAT(sun.direction, Vec3Near(Vec3f(-1, 0, 0), 1e-6f));
  EXPECT_THAT(sun.intensity, Vec3Near(Vec3f(3, 3, 3), 0));
}

INSTANTIATE_TEST_SUITE_P(TextAndBinary, LoadGltfTest,
                         ::testing::Values("meshes/lights.gltf", "meshes/lights.glb"));

// A transmitting material is glass as rough as its roughnessFactor, and an opaque one keeps
// factors between the extremes; no threshold turns either into something else.
TEST(LoadGltf, RoughGlassAndPartlyMetallicMaterialsKeepTheirFactors) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() /
      ("caustica-rough-glass-" + std::to_string(::getpid()) + ".gltf");
  // One triangle, (0, 0, 0), (1, 0, 0), (0, 1, 0), as a data URI.
  std::ofstream(path) << R"({
    "asset": {"version": "2.0"},
    "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior"],
    "buffers": [{"byteLength": 36,
                 "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
    "bufferViews": [{"buffer": 0, "byteLength": 36}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                   "min": [0, 0, 0], "max": [1, 1, 0]}],
    "materials": [
      {"name": "Frosted", "pbrMetallicRoughness": {"roughnessFactor": 0.35},
       "extensions": {"KHR_materials_transmission": {"transmissionFactor": 0.5},
                      "KHR_materials_ior": {"ior": 1.45}}},
      {"name": "Brushed", "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 1],
                                                   "metallicFactor": 0.98,
                                                   "roughnessFactor": 0.005}}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0},
                               {"attributes": {"POSITION": 0}, "material": 1}]}],
    "nodes": [{"mesh": 0}],
    "scenes": [{"nodes": [0]}]
  })";
  const absl::StatusOr<MeshFile> file = load_gltf(path);
  std::filesystem::remove(path);
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->materials.size(), 2u);
  const Material& frosted = file->materials[0];
  EXPECT_EQ(frosted.type, MaterialType::kDielectric);
  EXPECT_FLOAT_EQ(frosted.ior, 1.45f);
  EXPECT_FLOAT_EQ(frosted.roughness, 0.35f);
  // Nearly a polished metal: kept as the file states it, not rounded to a mirror.
  const Material& brushed = file->materials[1];
  EXPECT_EQ(brushed.type, MaterialType::kMetallicRoughness);
  EXPECT_THAT(brushed.color, Vec3Near(Vec3f(0.2f, 0.4f, 0.6f), 1e-6f));
  EXPECT_FLOAT_EQ(brushed.metallic, 0.98f);
  EXPECT_FLOAT_EQ(brushed.roughness, 0.005f);
}

// KHR_materials_volume: a transmitting material's attenuation colour c over its distance d is an
// absorbing medium of -ln(c) / d per unit, in world units, so the scaled node's cube encloses the
// same one; a material that absorbs nothing encloses none; an open primitive cannot enclose one,
// and a warning says its attenuation is left out.
TEST(LoadGltf, VolumeAttenuationIsTheMediumInsideClosedPrimitives) {
  const absl::StatusOr<MeshFile> file = load_gltf(scene_data("meshes/volume.gltf"));
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->media.size(), 1u);
  const Medium& inside = file->media[0];
  EXPECT_EQ(inside.name, "tinted (volume)");
  EXPECT_EQ(inside.type, MediumType::kHomogeneous);
  EXPECT_THAT(inside.absorption,
              Vec3Near(Vec3f(-std::log(0.1f), -std::log(0.5f), -std::log(0.9f)) / 2.0f, 1e-6f));
  EXPECT_THAT(inside.scattering, Vec3Near(Vec3f(0.0f), 0.0f));
  const Mesh* cube = mesh_named(*file, "node 'tinted cube'");
  const Mesh* big = mesh_named(*file, "node 'big tinted cube'");
  const Mesh* clear = mesh_named(*file, "node 'clear cube'");
  const Mesh* sheet = mesh_named(*file, "node 'tinted sheet'");
  ASSERT_TRUE(cube && big && clear && sheet);
  EXPECT_EQ(cube->interior_medium, 0u);
  EXPECT_EQ(big->interior_medium, 0u);
  EXPECT_EQ(clear->interior_medium, kNoMedium);
  EXPECT_EQ(sheet->interior_medium, kNoMedium);
  EXPECT_THAT(file->warnings,
              ::testing::ElementsAre(
                  HasSubstr("node 'tinted sheet': encloses medium 'tinted (volume)' but is not "
                            "closed: the edge from")));
  EXPECT_THAT(file->warnings[0], HasSubstr("its KHR_materials_volume attenuation is left out"));
}

TEST(LoadGltf, AccessorPastItsBufferIsRejected) {
  const absl::StatusOr<MeshFile> file = load_gltf(scene_data("bad/overflowing_accessor.gltf"));
  ASSERT_FALSE(file.ok());
  EXPECT_EQ(file.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(message_of(file.status()), HasSubstr("overflowing_accessor.gltf"));
  EXPECT_THAT(message_of(file.status()), HasSubstr("POSITION (accessor 0)"));
}

TEST(LoadGltf, IndexOutOfRangeIsRejected) {
  const absl::StatusOr<MeshFile> file = load_gltf(scene_data("bad/bad_index.gltf"));
  ASSERT_FALSE(file.ok());
  EXPECT_THAT(message_of(file.status()), HasSubstr("bad_index.gltf"));
  EXPECT_THAT(message_of(file.status()), HasSubstr("index 1 is 7, out of range (4 vertices)"));
}

// A light index of 1e10 used to reach tinygltf's GetNumberAsInt, whose unchecked conversion to
// int is undefined behaviour (UBSan's float-cast-overflow).
TEST(LoadGltf, LightIndexBeyondIntIsAMissingLight) {
  const absl::StatusOr<MeshFile> file = load_gltf(scene_data("bad/light_index_overflow.gltf"));
  ASSERT_FALSE(file.ok());
  EXPECT_EQ(file.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(message_of(file.status()), HasSubstr("light_index_overflow.gltf"));
  EXPECT_THAT(message_of(file.status()), HasSubstr("node 'Lamp' refers to missing light 1e+10"));
}

TEST(LoadGltf, MissingFileIsNotFound) {
  const absl::StatusOr<MeshFile> file = load_gltf(scene_data("meshes/nope.glb"));
  EXPECT_EQ(file.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(message_of(file.status()), HasSubstr("nope.glb"));
}

}  // namespace
}  // namespace caustica
