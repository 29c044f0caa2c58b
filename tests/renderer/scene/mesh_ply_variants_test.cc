// PLY headers as other exporters write them (make_test_meshes.py, "PLY header variants"): every
// variant must load exactly like the plain ascii file of the same mesh.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "renderer/scene/mesh_file.h"
#include "renderer/scene/mesh_ply.h"
#include "tests/renderer/scene/scene_test_util.h"

namespace caustica {
namespace {

using ::caustica::testing::expect_same_mesh;
using ::caustica::testing::message_of;
using ::caustica::testing::scene_data;
using ::testing::HasSubstr;

class PlyHeaderVariantTest : public ::testing::TestWithParam<const char*> {};

TEST_P(PlyHeaderVariantTest, LoadsLikeThePlainFile) {
  const absl::StatusOr<Mesh> plain = load_ply(scene_data("meshes/quad_tri_ascii.ply"));
  ASSERT_TRUE(plain.ok()) << plain.status();
  const absl::StatusOr<Mesh> variant = load_ply(scene_data(GetParam()));
  ASSERT_TRUE(variant.ok()) << variant.status();
  // The variants name their texture coordinates texture_u/texture_v and carry colours.
  expect_same_mesh(*variant, *plain);
  EXPECT_EQ(variant->triangle_count(), 3u);
}

INSTANTIATE_TEST_SUITE_P(Exporters, PlyHeaderVariantTest,
                         ::testing::Values("meshes/ply_variants/extras_ascii.ply",
                                           "meshes/ply_variants/extras_le.ply"));

// Header lines one at a time on a minimal triangle, so that a failure names the feature.
std::string triangle_ply(const std::string& extra_header, const std::string& line_end = "\n") {
  std::string text = "ply" + line_end + "format ascii 1.0" + line_end + extra_header +
                     "element vertex 3" + line_end + "property float x" + line_end +
                     "property float y" + line_end + "property float z" + line_end +
                     "element face 1" + line_end + "property list uchar int vertex_indices" +
                     line_end + "end_header" + line_end;
  text += "0 0 0" + line_end + "1 0 0" + line_end + "0 1 0" + line_end + "3 0 1 2" + line_end;
  return text;
}

TEST(PlyHeaderLines, ObjInfoBlankLinesAndCommentsAreSkipped) {
  const absl::StatusOr<Mesh> mesh =
      parse_ply(triangle_ply("obj_info scanner 7\n\n   \ncomment hello\n"), "t.ply");
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->indices, (std::vector<uint32_t>{0, 1, 2}));
}

TEST(PlyHeaderLines, CrlfLineEndsEverywhere) {
  const absl::StatusOr<Mesh> mesh = parse_ply(triangle_ply("", "\r\n"), "t.ply");
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->positions.size(), 3u);
  EXPECT_EQ(mesh->positions[1], Vec3f(1, 0, 0));
}

TEST(PlyHeaderLines, PaddedMagicLine) {
  std::string text = triangle_ply("");
  text.replace(0, 3, "ply \t");
  const absl::StatusOr<Mesh> mesh = parse_ply(text, "t.ply");
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->triangle_count(), 1u);
}

// Blender's exporter once wrote a line of free text into the header (Wuson.ply of Assimp's test
// models: "Created by Blender3D 249 - www.blender.org, source file: ..."); MeshLab and Assimp skip
// such lines, and so does the reader, saying so.
TEST(PlyHeaderLines, AFreeTextLineIsSkippedWithAWarning) {
  std::vector<std::string> warnings;
  const absl::StatusOr<Mesh> mesh = parse_ply(
      triangle_ply("Created by Blender3D 249 - www.blender.org, source file: 'wuson.blend'\n"),
      "t.ply", &warnings);
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->indices, (std::vector<uint32_t>{0, 1, 2}));
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_THAT(warnings[0], HasSubstr("t.ply:3: header line 'Created by Blender3D 249"));
  EXPECT_THAT(warnings[0], HasSubstr("skipped as a comment"));
}

TEST(PlyHeaderLines, AllSizedTypeAliasesAndListTypes) {
  const std::string text =
      "ply\nformat ascii 1.0\nelement vertex 3\n"
      "property float64 x\nproperty float32 y\nproperty float z\n"
      "property int8 a\nproperty uint8 b\nproperty int16 c\nproperty uint16 d\n"
      "property int32 e\nproperty uint32 f\nproperty char g\nproperty uchar h\n"
      "property short i\nproperty ushort j\nproperty int k\nproperty uint l\nproperty double m\n"
      "element face 2\nproperty list uint8 uint32 vertex_indices\n"
      "element extra 1\nproperty list uint16 int8 values\n"
      "end_header\n"
      "0 0 0 -1 2 -3 4 -5 6 -7 8 -9 10 -11 12 1.5\n"
      "1 0 0 -1 2 -3 4 -5 6 -7 8 -9 10 -11 12 1.5\n"
      "0 1 0 -1 2 -3 4 -5 6 -7 8 -9 10 -11 12 1.5\n"
      "3 0 1 2\n4 0 1 2 0\n3 -1 -2 -3\n";
  const absl::StatusOr<Mesh> mesh = parse_ply(text, "t.ply");
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->indices, (std::vector<uint32_t>{0, 1, 2, 0, 1, 2, 0, 2, 0}));
}

TEST(PlyHeaderLines, PointCloudGetsANamedError) {
  const std::string text =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n0 0 0\n";
  const absl::Status status = parse_ply(text, "cloud.ply").status();
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(message_of(status), HasSubstr("cloud.ply: PLY header: no 'face' element"));
  EXPECT_THAT(message_of(status), HasSubstr("point cloud"));
}

}  // namespace
}  // namespace caustica
