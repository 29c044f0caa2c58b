#include "renderer/scene/mesh_ply.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "renderer/scene/mesh_file.h"
#include "tests/renderer/scene/scene_test_util.h"

namespace caustica {
namespace {

using ::caustica::testing::expect_same_mesh;
using ::caustica::testing::message_of;
using ::caustica::testing::scene_data;
using ::caustica::testing::Vec3Near;
using ::testing::AllOf;
using ::testing::HasSubstr;

TEST(LoadPly, AsciiMeshHasItsValuesAndFanTriangulatedFaces) {
  const absl::StatusOr<Mesh> mesh = load_ply(scene_data("meshes/quad_tri_ascii.ply"));
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->name, "quad_tri_ascii.ply");
  ASSERT_EQ(mesh->positions.size(), 5u);
  EXPECT_THAT(mesh->positions[4], Vec3Near(Vec3f(0.5f, 2, 0.25f), 0));
  ASSERT_EQ(mesh->normals.size(), 5u);
  EXPECT_THAT(mesh->normals[2], Vec3Near(Vec3f(0, 0, 1), 0));
  ASSERT_EQ(mesh->uvs.size(), 5u);
  EXPECT_EQ(mesh->uvs[4].x, 0.5f);
  EXPECT_EQ(mesh->uvs[4].y, 0.0f);  // the file's v = 1, turned to v down the image
  // The quad 0 1 2 3 becomes (0 1 2) (0 2 3); the triangle stays.
  EXPECT_EQ(mesh->indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 3, 2, 4}));
  EXPECT_EQ(mesh->material_ids, (std::vector<uint32_t>(3, kNoMaterial)));
}

TEST(LoadPly, BinaryEncodingsLoadEqualToAscii) {
  const absl::StatusOr<Mesh> ascii = load_ply(scene_data("meshes/quad_tri_ascii.ply"));
  ASSERT_TRUE(ascii.ok()) << ascii.status();
  for (const char* file :
       {"meshes/quad_tri_le.ply", "meshes/quad_tri_be.ply", "meshes/quad_tri.ply.gz"}) {
    SCOPED_TRACE(file);
    const absl::StatusOr<Mesh> binary = load_ply(scene_data(file));
    ASSERT_TRUE(binary.ok()) << binary.status();
    expect_same_mesh(*ascii, *binary);
  }
}

TEST(LoadPly, GzipFileLoadsThroughTheMeshFileDispatch) {
  const absl::StatusOr<MeshFile> file = load_mesh_file(scene_data("meshes/quad_tri.ply.gz"));
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->meshes.size(), 1u);
  EXPECT_EQ(file->meshes[0].triangle_count(), 3u);
  EXPECT_TRUE(file->materials.empty());
}

TEST(ParsePly, AcceptsMeshesWithoutOptionalAttributes) {
  const std::string text =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
      "property double z\nelement face 1\nproperty list uchar uint vertex_index\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  const absl::StatusOr<Mesh> mesh = parse_ply(text, "inline.ply");
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->positions.size(), 3u);
  EXPECT_TRUE(mesh->normals.empty());
  EXPECT_TRUE(mesh->uvs.empty());
  EXPECT_EQ(mesh->triangle_count(), 1u);
}

struct BadPly {
  const char* file;
  std::vector<std::string> expected;  // substrings of the message, besides the file name
};

class BadPlyTest : public ::testing::TestWithParam<BadPly> {};

TEST_P(BadPlyTest, FailsNamingFileAndPlace) {
  const BadPly& bad = GetParam();
  const absl::StatusOr<Mesh> mesh = load_ply(scene_data(bad.file));
  ASSERT_FALSE(mesh.ok());
  EXPECT_EQ(mesh.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(message_of(mesh.status()), HasSubstr(bad.file));
  for (const std::string& part : bad.expected) {
    EXPECT_THAT(message_of(mesh.status()), HasSubstr(part));
  }
}

INSTANTIATE_TEST_SUITE_P(
    ErrorClasses, BadPlyTest,
    ::testing::Values(BadPly{"bad/truncated.ply", {"at byte 590", "face 0", "truncated"}},
                      BadPly{"bad/bad_index_binary.ply",
                             {"at byte 616", "face 1", "vertex index 9", "out of range"}},
                      BadPly{"bad/bad_index_ascii.ply", {":22:", "face 1", "vertex index 9"}},
                      BadPly{"bad/bad_number.ply", {":18:", "vertex 2", "property 'y'", "'1.2.3'"}},
                      BadPly{"bad/too_many_faces.ply",
                             {":13:", "100000001 faces exceed the limit"}},
                      BadPly{"bad/corrupt.ply.gz", {"gzip"}}));

TEST(LoadPly, MissingFileIsNotFound) {
  const absl::StatusOr<Mesh> mesh = load_ply(scene_data("meshes/does_not_exist.ply"));
  EXPECT_EQ(mesh.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(message_of(mesh.status()), HasSubstr("does_not_exist.ply"));
}

TEST(ParsePly, RejectsBrokenHeadersWithTheirLine) {
  const struct {
    std::string text;
    std::string expected;
  } cases[] = {
      {"not a ply\n", "inline.ply:1: not a PLY file"},
      {"ply\nformat ascii 1.0\nelement vertex 3\n", "no end_header"},
      {"ply\nformat ascii 2.0\nend_header\n", "inline.ply:2:"},
      {"ply\nformat ascii 1.0\nproperty float x\nend_header\n", "inline.ply:3: property before"},
      {"ply\nformat ascii 1.0\nelement vertex -1\nend_header\n", "inline.ply:3: element count"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n",
       "inline.ply:4: unknown property type"},
      {"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nend_header\n",
       "no 'face' element"},
      {"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nelement face 0\n"
       "property list uchar int vertex_indices\nend_header\n",
       "inline.ply:3: element 'vertex' lacks"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
       "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
       "0 0 0 7\n3 0 0 0\n",
       "inline.ply:10: vertex 0: line has more values"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
       "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
       "0 0 0\n2 0 0\n",
       "inline.ply:11: face 0 has 2 vertices"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
       "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
       "0 0 0\n300 0 0 0\n",
       "'300' is not an integer in [0, 255]"},
      {"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
       "property float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n"
       "0 0 0\n",
       "inline.ply:11: vertex 1: data ends early"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.text);
    const absl::StatusOr<Mesh> mesh = parse_ply(c.text, "inline.ply");
    ASSERT_FALSE(mesh.ok());
    EXPECT_THAT(message_of(mesh.status()), HasSubstr(c.expected));
  }
}

TEST(ParsePly, HugeBinaryListCountFailsWithoutReadingPastTheEnd) {
  std::string text =
      "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list uint int vertex_indices\nend_header\n";
  text += std::string("\xff\xff\xff\x7f", 4);  // 2^31 - 1 items announced, none present
  const absl::StatusOr<Mesh> mesh = parse_ply(text, "inline.ply");
  ASSERT_FALSE(mesh.ok());
  EXPECT_THAT(message_of(mesh.status()), AllOf(HasSubstr("at byte"), HasSubstr("truncated")));
}

TEST(ParsePly, ElementsWithoutPropertiesTakeNoTimeWhateverTheirCount) {
  std::string text =
      "ply\nformat binary_big_endian 1.0\nelement marker 1000000000000000\nelement vertex 3\n"
      "property float x\nproperty float y\nproperty float z\nelement face 1\n"
      "property list uchar uchar vertex_indices\nend_header\n";
  text += std::string(36, '\0');
  text += std::string("\x03\x00\x01\x02", 4);
  const absl::StatusOr<Mesh> mesh = parse_ply(text, "inline.ply");
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  EXPECT_EQ(mesh->triangle_count(), 1u);
}

}  // namespace
}  // namespace caustica
