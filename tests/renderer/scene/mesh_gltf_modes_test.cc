// glTF primitive modes beyond TRIANGLES, and glTF 1.0 files: strips and fans become triangles
// with one orientation, points and lines are skipped, 1.0 files are refused with advice.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "renderer/scene/mesh_gltf.h"
#include "tests/renderer/scene/scene_test_util.h"

namespace caustica {
namespace {

using ::caustica::testing::message_of;
using ::caustica::testing::scene_data;
using ::caustica::testing::triangle_cross;
using ::testing::HasSubstr;

// Every triangle's geometric normal along +z (sign 1) or -z (sign -1), with positive area.
void expect_all_facing(const Mesh& mesh, float sign) {
  for (size_t t = 0; t < mesh.triangle_count(); ++t) {
    const Vec3f n = triangle_cross(mesh, t);
    EXPECT_GT(sign * n.z, 0) << mesh.name << " triangle " << t;
    EXPECT_EQ(n.x, 0) << mesh.name << " triangle " << t;
    EXPECT_EQ(n.y, 0) << mesh.name << " triangle " << t;
  }
}

class StripsFansTest : public ::testing::Test {
 protected:
  void SetUp() override {
    absl::StatusOr<MeshFile> loaded = load_gltf(scene_data("meshes/strips_fans.gltf"));
    ASSERT_TRUE(loaded.ok()) << loaded.status();
    file_ = *std::move(loaded);
    // The LINES primitive is the fifth and is skipped.
    ASSERT_EQ(file_.meshes.size(), 4u);
  }
  MeshFile file_;
};

TEST_F(StripsFansTest, IndexedStripDropsStitchesAndKeepsWinding) {
  // Indices 0 2 1 3 3 4 4 6 5 7: eight strip triangles, four of them repeat an index.
  const Mesh& strip = file_.meshes[0];
  EXPECT_EQ(strip.indices, (std::vector<uint32_t>{0, 2, 1, 2, 3, 1, 4, 6, 5, 6, 7, 5}));
  expect_all_facing(strip, +1);
}

TEST_F(StripsFansTest, NonIndexedStripAlternatesWinding) {
  // Eight vertices in order: six triangles, each the same way round as the first (facing -z).
  const Mesh& strip = file_.meshes[1];
  EXPECT_EQ(strip.indices,
            (std::vector<uint32_t>{0, 1, 2, 1, 3, 2, 2, 3, 4, 3, 5, 4, 4, 5, 6, 5, 7, 6}));
  expect_all_facing(strip, -1);
}

TEST_F(StripsFansTest, NonIndexedFan) {
  const Mesh& fan = file_.meshes[2];
  EXPECT_EQ(fan.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 3, 4}));
  expect_all_facing(fan, +1);
}

TEST_F(StripsFansTest, IndexedFanDropsRepeatedCorner) {
  const Mesh& fan = file_.meshes[3];
  EXPECT_EQ(fan.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_EQ(fan.material_ids.size(), 2u);
  expect_all_facing(fan, +1);
}

TEST_F(StripsFansTest, SkippedLinesAreWarnedAbout) {
  ASSERT_EQ(file_.warnings.size(), 1u);
  EXPECT_THAT(file_.warnings[0], HasSubstr("strips_fans.gltf"));
  EXPECT_THAT(file_.warnings[0], HasSubstr("primitive 4"));
  EXPECT_THAT(file_.warnings[0], HasSubstr("skipped LINES primitive"));
}

TEST(GltfModes, StripOfTwoVerticesIsANamedError) {
  const absl::Status status = load_gltf(scene_data("bad/short_strip.gltf")).status();
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(message_of(status), HasSubstr("short_strip.gltf: mesh 'StripsFans' primitive 0"));
  EXPECT_THAT(message_of(status), HasSubstr("TRIANGLE_STRIP of 2 vertices has no triangle"));
}

// The glTF Asset Generator's Mesh_PrimitiveMode set (thirdparty/README.md): one unit quad in the
// z = 0 plane drawn with each mode. Strips and fans must give the triangles of the TRIANGLES
// version: two, facing +z, covering [-0.5, 0.5]^2.
class AssetGeneratorModeTest : public ::testing::TestWithParam<const char*> {};

TEST_P(AssetGeneratorModeTest, QuadOfTwoFrontFacingTriangles) {
  const absl::StatusOr<MeshFile> file =
      load_gltf(scene_data(std::string("thirdparty/gltf2/") + GetParam()));
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->meshes.size(), 1u);
  const Mesh& mesh = file->meshes[0];
  ASSERT_EQ(mesh.triangle_count(), 2u);
  expect_all_facing(mesh, +1);
  float area = 0;
  for (size_t t = 0; t < 2; ++t) area += 0.5f * triangle_cross(mesh, t).z;
  EXPECT_FLOAT_EQ(area, 1.0f);
}

INSTANTIATE_TEST_SUITE_P(Modes, AssetGeneratorModeTest,
                         ::testing::Values("Mesh_PrimitiveMode_04.gltf",    // strip
                                           "Mesh_PrimitiveMode_05.gltf",    // fan
                                           "Mesh_PrimitiveMode_06.gltf",    // triangles
                                           "Mesh_PrimitiveMode_11.gltf",    // indexed strip
                                           "Mesh_PrimitiveMode_12.gltf"));  // indexed fan

TEST(GltfModes, UnknownModeIsANamedError) {
  const absl::Status status = load_gltf(scene_data("bad/unknown_mode.gltf")).status();
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(message_of(status),
              HasSubstr("unknown_mode.gltf: mesh 'StripsFans' primitive 0 at node 'Strips': "
                        "unknown primitive mode 9"));
}

TEST(GltfModes, LinesOnlyFileIsANamedError) {
  const absl::Status status =
      load_gltf(scene_data("thirdparty/gltf2/Mesh_PrimitiveMode_01.gltf")).status();
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(message_of(status), HasSubstr("Mesh_PrimitiveMode_01.gltf: "));
  EXPECT_THAT(message_of(status), HasSubstr("only point and line primitives (1 of them)"));
}

class Gltf1Test : public ::testing::TestWithParam<std::pair<const char*, const char*>> {};

TEST_P(Gltf1Test, RefusedWithConversionAdvice) {
  const auto& [file, evidence] = GetParam();
  const absl::Status status = load_gltf(scene_data(file)).status();
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(message_of(status), HasSubstr(file));
  EXPECT_THAT(message_of(status), HasSubstr("this is a glTF 1.0 file"));
  EXPECT_THAT(message_of(status), HasSubstr(evidence));
  EXPECT_THAT(message_of(status), HasSubstr("gltf-pipeline -i in.gltf -o out.gltf"));
}

INSTANTIATE_TEST_SUITE_P(
    Files, Gltf1Test,
    ::testing::Values(std::pair{"thirdparty/gltf1/TwoBoxes.gltf", "asset.version \"1.0\""},
                      std::pair{"bad/gltf1_no_asset.gltf",
                                "no asset object and a top-level \"techniques\" object"},
                      std::pair{"thirdparty/gltf1/BoxTextured.glb",
                                "binary glTF (KHR_binary_glTF) container version 1"}));

}  // namespace
}  // namespace caustica
