#include "renderer/scene/mesh_obj.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tests/renderer/scene/scene_test_util.h"

namespace caustica {
namespace {

using ::caustica::testing::message_of;
using ::caustica::testing::scene_data;
using ::caustica::testing::triangle_cross;
using ::caustica::testing::Vec3Near;
using ::testing::HasSubstr;

TEST(LoadObj, MapsMtlMaterialsToOurTypes) {
  const absl::StatusOr<MeshFile> file = load_obj(scene_data("meshes/box.obj"));
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->materials.size(), 4u);
  const Material& white = file->materials[0];
  EXPECT_EQ(white.name, "white");
  EXPECT_EQ(white.type, MaterialType::kDiffuse);
  EXPECT_THAT(white.color, Vec3Near(Vec3f(0.8f, 0.7f, 0.6f), 1e-6f));
  const Material& chrome = file->materials[1];
  EXPECT_EQ(chrome.type, MaterialType::kMirror);
  EXPECT_THAT(chrome.color, Vec3Near(Vec3f(0.9f, 0.85f, 0.8f), 1e-6f));
  const Material& glass = file->materials[2];
  EXPECT_EQ(glass.type, MaterialType::kDielectric);
  EXPECT_FLOAT_EQ(glass.ior, 1.45f);
  const Material& lamp = file->materials[3];
  EXPECT_EQ(lamp.type, MaterialType::kEmissive);
  EXPECT_THAT(lamp.radiance, Vec3Near(Vec3f(5, 4, 3), 0));
}

TEST(LoadObj, SplitsVerticesWhoseCornersDiffer) {
  const absl::StatusOr<MeshFile> file = load_obj(scene_data("meshes/box.obj"));
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->meshes.size(), 1u);
  const Mesh& mesh = file->meshes[0];
  EXPECT_EQ(mesh.name, "box.obj");
  // Quad (2 triangles) + 3 triangles; 11 distinct position/normal/uv corners.
  EXPECT_EQ(mesh.triangle_count(), 5u);
  EXPECT_EQ(mesh.positions.size(), 11u);
  EXPECT_EQ(mesh.normals.size(), 11u);
  EXPECT_EQ(mesh.uvs.size(), 11u);
  EXPECT_EQ(mesh.material_ids, (std::vector<uint32_t>{0, 0, 1, 2, 3}));
  // The chrome triangle (1/1/2 2/2/2 5/1/2) carries normal 2 = +x.
  const uint32_t corner = mesh.indices[3 * 2 + 2];
  EXPECT_THAT(mesh.positions[corner], Vec3Near(Vec3f(0, 0, 1), 0));
  EXPECT_THAT(mesh.normals[corner], Vec3Near(Vec3f(1, 0, 0), 0));
  EXPECT_EQ(mesh.uvs[corner].x, 0.0f);
}

TEST(LoadObj, PlainPolygonKeepsFilePositionsAndFans) {
  const absl::StatusOr<MeshFile> file = load_obj(scene_data("meshes/plain.obj"));
  ASSERT_TRUE(file.ok()) << file.status();
  const Mesh& mesh = file->meshes[0];
  EXPECT_TRUE(file->materials.empty());
  EXPECT_EQ(mesh.positions.size(), 5u);
  EXPECT_THAT(mesh.positions[2], Vec3Near(Vec3f(3, 1, 0), 0));
  EXPECT_TRUE(mesh.normals.empty());
  EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 3, 4}));
  EXPECT_EQ(mesh.material_ids, (std::vector<uint32_t>(3, kNoMaterial)));
  for (size_t t = 0; t < 3; ++t) EXPECT_GT(triangle_cross(mesh, t).z, 0);
}

TEST(LoadObj, ZeroIndexReportsTinyobjLine) {
  const absl::StatusOr<MeshFile> file = load_obj(scene_data("bad/zero_index.obj"));
  ASSERT_FALSE(file.ok());
  EXPECT_EQ(file.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(message_of(file.status()), HasSubstr("zero_index.obj"));
  EXPECT_THAT(message_of(file.status()), HasSubstr("line 6"));
}

TEST(LoadObj, OutOfRangeIndexReportsFaceLine) {
  const absl::StatusOr<MeshFile> file = load_obj(scene_data("bad/obj_index_out_of_range.obj"));
  ASSERT_FALSE(file.ok());
  EXPECT_THAT(message_of(file.status()), HasSubstr("obj_index_out_of_range.obj:7: face 1"));
  EXPECT_THAT(message_of(file.status()), HasSubstr("vertex index 9 is out of range"));
}

// tinyobjloader counts a face's corners in an unsigned char; a 300-corner face used to wrap to 44
// and shift every later face onto the wrong corners, silently.
TEST(LoadObj, FaceWithMoreCornersThanTheReaderCountsIsRefusedWithItsLine) {
  const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                     ("caustica-long-face-" + std::to_string(::getpid()) + ".obj");
  {
    std::ofstream obj(path);
    obj << "# one face of 300 corners, then a triangle\n";
    for (int i = 0; i < 300; ++i) {
      const double angle = 2 * 3.14159265358979 * i / 300;
      obj << "v " << std::cos(angle) << " " << std::sin(angle) << " 0\n";
    }
    obj << "f";
    for (int i = 1; i <= 300; ++i) obj << " " << i;
    obj << "\nf 1 2 3\n";
  }
  const absl::StatusOr<MeshFile> file = load_obj(path);
  std::filesystem::remove(path);
  ASSERT_FALSE(file.ok());
  EXPECT_EQ(file.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(message_of(file.status()),
              HasSubstr(path.string() + ":302: face has 300 vertices; at most 255 are supported"));
}

TEST(LoadObj, MissingFileIsNotFound) {
  const absl::StatusOr<MeshFile> file = load_obj(scene_data("meshes/nope.obj"));
  EXPECT_EQ(file.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(message_of(file.status()), HasSubstr("nope.obj"));
}

// MTL's map_Ke is the emission map, multiplying Ke, as map_Kd multiplies Kd; one image named by
// both is one texture.
TEST(LoadObj, MapKeIsTheEmissionMap) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "caustica_map_ke";
  std::filesystem::create_directories(dir);
  std::filesystem::copy_file(scene_data("thirdparty/gltf2/BoxTextured/CesiumLogoFlat.png"),
                             dir / "logo.png", std::filesystem::copy_options::overwrite_existing);
  std::ofstream(dir / "sign.mtl") << "newmtl sign\nKd 0.5 0.5 0.5\nKe 2 2 2\nmap_Kd logo.png\n"
                                     "map_Ke logo.png\n";
  std::ofstream(dir / "sign.obj") << "mtllib sign.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"
                                     "vt 0 0\nvt 1 0\nvt 0 1\nusemtl sign\nf 1/1 2/2 3/3\n";
  const absl::StatusOr<MeshFile> file = load_obj(dir / "sign.obj");
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->materials.size(), 1u);
  const Material& sign = file->materials[0];
  EXPECT_EQ(sign.type, MaterialType::kDiffuse);
  EXPECT_THAT(sign.radiance, Vec3Near(Vec3f(2, 2, 2), 0));
  EXPECT_TRUE(sign.emission_map.used());
  EXPECT_EQ(sign.emission_map.texture, sign.color_map.texture);
  EXPECT_EQ(file->textures.size(), 1u);
  std::filesystem::remove_all(dir);
}

// Writes `mtl` and an OBJ of one triangle per material it defines (their names given) into a
// fresh directory; returns the OBJ's path.
std::filesystem::path write_obj_with_mtl(const std::string& name, const std::string& mtl,
                                         const std::vector<std::string>& materials) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("caustica-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / (name + ".mtl")) << mtl;
  std::ofstream obj(dir / (name + ".obj"));
  obj << "mtllib " << name << ".mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n";
  for (const std::string& material : materials) obj << "usemtl " << material << "\nf 1 2 3\n";
  return dir / (name + ".obj");
}

// The OBJ of write_obj_with_mtl, loaded, with its directory removed.
absl::StatusOr<MeshFile> load_obj_with_mtl(const std::string& name, const std::string& mtl,
                                           const std::vector<std::string>& materials) {
  const std::filesystem::path path = write_obj_with_mtl(name, mtl, materials);
  absl::StatusOr<MeshFile> file = load_obj(path);
  std::filesystem::remove_all(path.parent_path());
  return file;
}

// Ks with a highlight's illumination model is the modified Phong lobe, Kd its diffuse one and Ns
// its exponent; illum 0 and 1 have no highlight, whatever Ks says.
TEST(LoadObj, MtlWithASpecularColourIsPhong) {
  const absl::StatusOr<MeshFile> file =
      load_obj_with_mtl("phong",
                        "newmtl glossy\nKd 0.5 0.4 0.3\nKs 0.25 0.3 0.35\nNs 64\nillum 2\n"
                        "newmtl matte\nKd 0.5 0.5 0.5\nKs 0.3 0.3 0.3\nNs 10\nillum 1\n"
                        "newmtl flat\nKd 0.2 0.2 0.2\nKs 0.1 0.1 0.1\nNs 0\nillum 2\n",
                        {"glossy", "matte", "flat"});
  ASSERT_TRUE(file.ok()) << file.status();
  EXPECT_TRUE(file->warnings.empty()) << file->warnings.front();
  ASSERT_EQ(file->materials.size(), 3u);
  const Material& glossy = file->materials[0];
  EXPECT_EQ(glossy.type, MaterialType::kPhong);
  EXPECT_THAT(glossy.color, Vec3Near(Vec3f(0.5f, 0.4f, 0.3f), 0));
  EXPECT_THAT(glossy.specular, Vec3Near(Vec3f(0.25f, 0.3f, 0.35f), 0));
  EXPECT_EQ(glossy.exponent, 64.0f);
  const Material& matte = file->materials[1];
  EXPECT_EQ(matte.type, MaterialType::kDiffuse);
  EXPECT_THAT(matte.color, Vec3Near(Vec3f(0.5f, 0.5f, 0.5f), 0));
  // Ns 0 is no exponent the model has; 1 is the broadest lobe.
  const Material& flat = file->materials[2];
  EXPECT_EQ(flat.type, MaterialType::kPhong);
  EXPECT_EQ(flat.exponent, 1.0f);
  EXPECT_THAT(flat.specular, Vec3Near(Vec3f(0.1f, 0.1f, 0.1f), 0));
}

// Kd + Ks above 1 would reflect more light than arrives: both are scaled by one factor until
// the worst channel sums to 1, and the file and material are named in a warning.
TEST(LoadObj, PhongBrighterThanItsLightIsScaledWithAWarning) {
  const absl::StatusOr<MeshFile> file = load_obj_with_mtl(
      "hot", "newmtl hot\nKd 0.8 0.6 0.2\nKs 0.5 0.2 0.1\nNs 30\nillum 2\n", {"hot"});
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->materials.size(), 1u);
  const Material& hot = file->materials[0];
  EXPECT_EQ(hot.type, MaterialType::kPhong);
  const float scale = 1 / 1.3f;  // the red channel's sum
  EXPECT_THAT(hot.color, Vec3Near(Vec3f(0.8f, 0.6f, 0.2f) * scale, 1e-6f));
  EXPECT_THAT(hot.specular, Vec3Near(Vec3f(0.5f, 0.2f, 0.1f) * scale, 1e-6f));
  const Vec3f sum = hot.color + hot.specular;
  EXPECT_LE(sum.x, 1.0f);  // as validation adds them
  EXPECT_NEAR(sum.x, 1.0f, 1e-6f);
  EXPECT_EQ(hot.exponent, 30.0f);
  ASSERT_EQ(file->warnings.size(), 1u);
  EXPECT_THAT(file->warnings[0], HasSubstr("hot.obj: material 'hot': Kd + Ks = (1.3, 0.8, 0.3) "
                                           "exceeds 1; both scaled by 0.76923"));
}

// MTL's PBR extension (Pr, Pm, as Blender writes them) is glTF's metallic-roughness material: Kd
// the base colour; a glass's Pr is its roughness; factors outside [0, 1] are clamped, saying so.
TEST(LoadObj, PbrExtensionIsMetallicRoughness) {
  const absl::StatusOr<MeshFile> file = load_obj_with_mtl(
      "pbr",
      "newmtl steel\nKd 0.9 0.6 0.2\nKs 0.5 0.5 0.5\nNs 100\nPr 0.3\nPm 1\nillum 2\n"
      "newmtl plastic\nKd 0.2 0.4 0.8\nPr 0.7\nillum 2\n"
      "newmtl frosted\nKd 1 1 1\nNi 1.45\nPr 0.2\nillum 7\n"
      "newmtl wild\nKd 0.5 0.5 0.5\nPr 1.5\nPm -0.5\nillum 2\n"
      "newmtl classic\nKd 0.5 0.4 0.3\nKs 0.25 0.3 0.35\nNs 64\nillum 2\n",
      {"steel", "plastic", "frosted", "wild", "classic"});
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->materials.size(), 5u);
  const Material& steel = file->materials[0];
  EXPECT_EQ(steel.type, MaterialType::kMetallicRoughness);
  EXPECT_THAT(steel.color, Vec3Near(Vec3f(0.9f, 0.6f, 0.2f), 0));
  EXPECT_EQ(steel.metallic, 1.0f);
  EXPECT_EQ(steel.roughness, 0.3f);
  const Material& plastic = file->materials[1];
  EXPECT_EQ(plastic.type, MaterialType::kMetallicRoughness);
  EXPECT_EQ(plastic.metallic, 0.0f);
  EXPECT_EQ(plastic.roughness, 0.7f);
  const Material& frosted = file->materials[2];
  EXPECT_EQ(frosted.type, MaterialType::kDielectric);
  EXPECT_EQ(frosted.ior, 1.45f);
  EXPECT_EQ(frosted.roughness, 0.2f);
  const Material& wild = file->materials[3];
  EXPECT_EQ(wild.roughness, 1.0f);
  EXPECT_EQ(wild.metallic, 0.0f);
  EXPECT_EQ(file->materials[4].type, MaterialType::kPhong);  // no Pr or Pm: as before
  ASSERT_EQ(file->warnings.size(), 2u);
  EXPECT_THAT(file->warnings[0], HasSubstr("pbr.obj: material 'wild': Pm -0.5 is outside [0, 1]; "
                                           "read as 0"));
  EXPECT_THAT(file->warnings[1], HasSubstr("material 'wild': Pr 1.5 is outside [0, 1]; read as 1"));
}

// Its maps: map_Pr and map_Pm naming one image are packed as glTF's (roughness green, metalness
// blue); two images are the separate maps, unless they are read at different coordinates, which
// one map cannot be, and then the warning says which is left out and what is used instead. A
// bump map is read with its -bm.
TEST(LoadObj, PbrExtensionAndBumpMapsAreRead) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "caustica_map_pr";
  std::filesystem::create_directories(dir);
  for (const char* name : {"orm.png", "rough.png", "metal.png", "bump.png"})
    std::filesystem::copy_file(scene_data("thirdparty/gltf2/BoxTextured/CesiumLogoFlat.png"),
                               dir / name, std::filesystem::copy_options::overwrite_existing);
  std::ofstream(dir / "m.mtl") << "newmtl packed\nKd 1 1 1\nPr 1\nPm 1\nmap_Pr orm.png\n"
                                  "map_Pm orm.png\n"
                                  "newmtl apart\nKd 1 1 1\nPr 0.5\nPm 1\nmap_Pr rough.png\n"
                                  "map_Pm metal.png\nbump -bm 0.25 bump.png\n"
                                  "newmtl shifted\nKd 1 1 1\nPr 0.5\nPm 1\nmap_Pr rough.png\n"
                                  "map_Pm -o 0.5 0 0 metal.png\n";
  std::ofstream(dir / "m.obj") << "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"
                                  "vt 0 0\nvt 1 0\nvt 0 1\nusemtl packed\nf 1/1 2/2 3/3\n"
                                  "usemtl apart\nf 1/1 2/2 3/3\nusemtl shifted\nf 1/1 2/2 3/3\n";
  const absl::StatusOr<MeshFile> file = load_obj(dir / "m.obj");
  std::filesystem::remove_all(dir);
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->materials.size(), 3u);
  const Material &packed = file->materials[0], &apart = file->materials[1],
                 &shifted = file->materials[2];
  EXPECT_TRUE(packed.metallic_roughness_map.used());
  EXPECT_FALSE(packed.roughness_map.used() || packed.metallic_map.used());
  EXPECT_FALSE(apart.metallic_roughness_map.used());
  ASSERT_TRUE(apart.roughness_map.used() && apart.metallic_map.used());
  EXPECT_NE(apart.roughness_map.texture, apart.metallic_map.texture);
  ASSERT_TRUE(apart.bump_map.used());
  EXPECT_EQ(apart.bump_scale, 0.25f);
  EXPECT_FALSE(packed.bump_map.used());
  EXPECT_TRUE(shifted.roughness_map.used());
  EXPECT_FALSE(shifted.metallic_map.used());
  EXPECT_THAT(file->warnings,
              ::testing::ElementsAre(HasSubstr(
                  "material 'shifted': map_Pm 'metal.png' is not read: its -o, -s or -clamp "
                  "differ from map_Pr's")));
  EXPECT_EQ(file->textures.size(), 4u);
}

// The MTL maps no model reads are named, one warning per kind with its files.
TEST(LoadObj, UnreadMapsAreNamedByKind) {
  const absl::StatusOr<MeshFile> file =
      load_obj_with_mtl("unread",
                        "newmtl a\nKd 0.5 0.5 0.5\ndisp stone_disp.png\nmap_Ks shine.png\n"
                        "newmtl b\nKd 0.5 0.5 0.5\ndisp stone_disp.png\n"
                        "newmtl c\nKd 0.5 0.5 0.5\ndisp wood_disp.png\n",
                        {"a", "b", "c"});
  ASSERT_TRUE(file.ok()) << file.status();
  EXPECT_THAT(file->warnings,
              ::testing::ElementsAre(
                  "unread.obj: its map_Ks maps are not read (1 material): shine.png",
                  "unread.obj: its disp maps are not read (3 materials): stone_disp.png, "
                  "wood_disp.png"));
}

}  // namespace
}  // namespace caustica
