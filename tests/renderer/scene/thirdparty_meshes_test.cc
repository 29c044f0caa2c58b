// Files written by other tools (tests/data/scene/thirdparty, README.md there): each loads through
// load_mesh_file with the triangle count and bounds the file itself states, counted here by
// reading the file independently of the loaders, or fails with a named error.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "renderer/scene/affine.h"
#include "renderer/scene/load_scene.h"
#include "renderer/scene/mesh_assimp.h"
#include "renderer/scene/mesh_file.h"
#include "renderer/scene/mesh_scene.h"
#include "tests/renderer/scene/scene_test_util.h"

namespace caustica {
namespace {

using ::caustica::testing::message_of;
using ::caustica::testing::scene_data;
using ::caustica::testing::Vec3Near;
using ::testing::HasSubstr;

std::string file_bytes(const std::string& relative) {
  std::ifstream in(scene_data(relative), std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// What a file says about itself: triangles after fan-triangulating its polygons, and bounds.
struct Expected {
  size_t triangles = 0;
  Bounds bounds;
  void add_point(Vec3f p) {
    if (bounds.empty()) {
      bounds.lo = bounds.hi = p;
    } else {
      bounds.lo = min(bounds.lo, p);
      bounds.hi = max(bounds.hi, p);
    }
  }
};

size_t total_triangles(const MeshFile& file) {
  size_t n = 0;
  for (const Mesh& mesh : file.meshes) n += mesh.triangle_count();
  return n;
}

void expect_matches(const MeshFile& file, const Expected& expected, float tolerance) {
  EXPECT_EQ(total_triangles(file), expected.triangles);
  const Bounds bounds = mesh_bounds(file.meshes);
  ASSERT_FALSE(bounds.empty());
  EXPECT_THAT(bounds.lo, Vec3Near(expected.bounds.lo, tolerance));
  EXPECT_THAT(bounds.hi, Vec3Near(expected.bounds.hi, tolerance));
  for (const Mesh& mesh : file.meshes) {
    EXPECT_EQ(mesh.material_ids.size(), mesh.triangle_count()) << mesh.name;
    for (const uint32_t index : mesh.indices) ASSERT_LT(index, mesh.positions.size()) << mesh.name;
  }
}

// ascii STL: one "facet" per triangle, three "vertex x y z" lines each.
Expected read_ascii_stl(const std::string& relative) {
  std::istringstream in(file_bytes(relative));
  Expected e;
  std::string word;
  while (in >> word) {
    if (word == "facet") ++e.triangles;
    if (word == "vertex") {
      Vec3f p;
      in >> p.x >> p.y >> p.z;
      e.add_point(p);
    }
  }
  return e;
}

// Binary STL: an 80-byte header, a uint32 triangle count, 50 bytes per triangle.
Expected read_binary_stl(const std::string& relative) {
  const std::string bytes = file_bytes(relative);
  Expected e;
  uint32_t count = 0;
  std::memcpy(&count, bytes.data() + 80, 4);
  e.triangles = count;
  for (uint32_t t = 0; t < count; ++t) {
    for (int v = 0; v < 3; ++v) {
      float xyz[3];
      std::memcpy(xyz, bytes.data() + 84 + 50 * size_t{t} + 12 + 12 * v, 12);
      e.add_point({xyz[0], xyz[1], xyz[2]});
    }
  }
  return e;
}

// OFF, or an ascii PLY with only x y z per vertex: vertex lines, then "n i0 i1 ..." face lines.
Expected read_indexed_text(std::istream& in, size_t vertices, size_t faces) {
  Expected e;
  std::string line;
  for (size_t v = 0; v < vertices && std::getline(in, line);) {
    std::istringstream values(line);
    Vec3f p;
    if (values >> p.x >> p.y >> p.z) {
      e.add_point(p);
      ++v;
    }
  }
  for (size_t f = 0; f < faces && std::getline(in, line);) {
    std::istringstream values(line);
    size_t n = 0;
    if (values >> n) {
      e.triangles += n - 2;
      ++f;
    }
  }
  return e;
}

Expected read_off(const std::string& relative) {
  std::istringstream in(file_bytes(relative));
  std::string magic;
  size_t vertices = 0, faces = 0, edges = 0;
  in >> magic >> vertices >> faces >> edges;
  return read_indexed_text(in, vertices, faces);
}

Expected read_ascii_ply(const std::string& relative) {
  std::istringstream in(file_bytes(relative));
  std::string line;
  size_t vertices = 0, faces = 0;
  while (std::getline(in, line) && line.rfind("end_header", 0) != 0) {
    std::istringstream words(line);
    std::string keyword, element;
    size_t count = 0;
    if (words >> keyword >> element >> count && keyword == "element") {
      (element == "vertex" ? vertices : faces) = count;
    }
  }
  return read_indexed_text(in, vertices, faces);
}

absl::StatusOr<MeshFile> load(const std::string& relative) {
  return load_mesh_file(scene_data("thirdparty/" + relative));
}

TEST(ThirdPartyPly, AssimpTestCubeWithPaddedHeaderAndSizedTypes) {
  // "format ascii 1.0          ", float32 and "list uint8 int32 vertex_index".
  const absl::StatusOr<MeshFile> file = load("ply/cube.ply");
  ASSERT_TRUE(file.ok()) << file.status();
  const Expected expected = read_ascii_ply("thirdparty/ply/cube.ply");
  EXPECT_EQ(expected.triangles, 12u);
  expect_matches(*file, expected, 0);
}

TEST(ThirdPartyPly, BlenderCubeWithNormalsAndST) {
  const absl::StatusOr<MeshFile> file = load("ply/cube_uv.ply");
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->meshes.size(), 1u);
  EXPECT_EQ(file->meshes[0].positions.size(), 24u);
  EXPECT_EQ(file->meshes[0].normals.size(), 24u);
  EXPECT_EQ(file->meshes[0].uvs.size(), 24u);
  EXPECT_EQ(total_triangles(*file), 12u);  // element face 6, all quads
}

TEST(ThirdPartyPly, VcgBinaryCube) {
  const absl::StatusOr<MeshFile> file = load("ply/cube_binary.ply");
  ASSERT_TRUE(file.ok()) << file.status();
  // The header declares 8 float x y z vertices and 12 faces; read the body by hand.
  const std::string bytes = file_bytes("thirdparty/ply/cube_binary.ply");
  const size_t body = bytes.find("end_header\n") + std::strlen("end_header\n");
  Expected expected;
  for (int v = 0; v < 8; ++v) {
    float xyz[3];
    std::memcpy(xyz, bytes.data() + body + 12 * v, 12);
    expected.add_point({xyz[0], xyz[1], xyz[2]});
  }
  size_t at = body + 8 * 12;
  for (int f = 0; f < 12; ++f) {
    const uint8_t n = static_cast<uint8_t>(bytes[at]);
    expected.triangles += n - 2;
    at += 1 + 4 * size_t{n};
  }
  EXPECT_EQ(at, bytes.size());
  expect_matches(*file, expected, 0);
}

TEST(ThirdPartyPly, VcgFloatColoursAreIgnored) {
  const absl::StatusOr<MeshFile> file = load("ply/float-color.ply");
  ASSERT_TRUE(file.ok()) << file.status();
  Expected expected;
  expected.triangles = 1;
  expected.add_point({0, 0, 0});
  expected.add_point({200, 200, 0});
  expect_matches(*file, expected, 0);
}

TEST(ThirdPartyPly, PointCloudIsANamedError) {
  const absl::Status status = load("ply/points.ply").status();
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(message_of(status), HasSubstr("points.ply: PLY header: no 'face' element"));
}

TEST(ThirdPartyGltf, UnityCubeTangentsTurnWithItsNode) {
  // glTF Tools for Unity: 24 vertices with NORMAL and TANGENT, every tangent (1, 0, 0)
  // with w = 1 in the file, under a node turned 180 degrees about (0, 1, -1) and scaled 100.
  const absl::StatusOr<MeshFile> file = load("gltf2/AnimatedMorphCube.gltf");
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->meshes.size(), 1u);
  const Mesh& cube = file->meshes[0];
  ASSERT_EQ(cube.tangents.size(), 24u);
  EXPECT_EQ(cube.normals.size(), 24u);
  EXPECT_TRUE(cube.uvs.empty());
  for (const Vec4f& t : cube.tangents) {
    EXPECT_NEAR(t.x, -1.0f, 1e-6f);  // the turn takes +x to -x
    EXPECT_NEAR(t.y, 0.0f, 1e-6f);
    EXPECT_NEAR(t.z, 0.0f, 1e-6f);
    EXPECT_EQ(t.w, 1.0f);  // no mirror
  }
}

TEST(ThirdPartyGltf, CesiumBoxCarriesItsBaseColourTextureAndSampler) {
  // glTF-Sample-Models' BoxTextured: one material whose baseColorTexture is texture 0, image
  // CesiumLogoFlat.png, sampler wrapS MIRRORED_REPEAT (33648) and wrapT CLAMP_TO_EDGE (33071).
  const absl::StatusOr<MeshFile> file = load("gltf2/BoxTextured/BoxTextured.gltf");
  ASSERT_TRUE(file.ok()) << file.status();
  EXPECT_TRUE(file->warnings.empty()) << file->warnings.front();
  ASSERT_EQ(file->textures.size(), 1u);
  EXPECT_EQ(file->textures[0].name, "CesiumLogoFlat.png");
  ASSERT_NE(file->textures[0].encoded, nullptr);
  EXPECT_EQ(*file->textures[0].encoded,
            file_bytes("thirdparty/gltf2/BoxTextured/CesiumLogoFlat.png"));
  ASSERT_EQ(file->materials.size(), 1u);
  const TextureRef& map = file->materials[0].color_map;
  EXPECT_EQ(map.texture, 0u);
  EXPECT_EQ(map.wrap_u, TextureWrap::kMirroredRepeat);
  EXPECT_EQ(map.wrap_v, TextureWrap::kClampToEdge);
  EXPECT_FALSE(file->materials[0].emission_map.used());
  // "pbrMetallicRoughness": {"baseColorTexture": ..., "metallicFactor": 0.0}: the base colour
  // and roughness are the specification's defaults, white and 1.
  EXPECT_EQ(file->materials[0].type, MaterialType::kMetallicRoughness);
  EXPECT_THAT(file->materials[0].color, Vec3Near(Vec3f(1, 1, 1), 0));
  EXPECT_EQ(file->materials[0].metallic, 0.0f);
  EXPECT_EQ(file->materials[0].roughness, 1.0f);
  ASSERT_EQ(file->meshes.size(), 1u);
  EXPECT_EQ(file->meshes[0].uvs.size(), file->meshes[0].positions.size());
}

// ClearCoatTest uses KHR_materials_clearcoat, which no material model reads: the loader says so
// by name. A file whose extensions are all read (lights.gltf: lights, transmission, ior, emissive
// strength) gets no such warning.
TEST(ThirdPartyGltf, ExtensionsNotReadAreNamed) {
  const absl::StatusOr<MeshFile> coat = load("gltf2/ClearCoat/ClearCoatTest.gltf");
  ASSERT_TRUE(coat.ok()) << coat.status();
  EXPECT_THAT(coat->warnings, ::testing::Contains("ClearCoatTest.gltf: extensions not read (the "
                                                  "file is read as core glTF 2.0 states it): "
                                                  "KHR_materials_clearcoat"));
  const absl::StatusOr<MeshFile> lights = load_mesh_file(scene_data("meshes/lights.gltf"));
  ASSERT_TRUE(lights.ok()) << lights.status();
  EXPECT_THAT(lights->warnings,
              ::testing::Not(::testing::Contains(::testing::HasSubstr("extensions not read"))));
}

TEST(ThirdPartyGltf, ClearCoatTestsPartialCoatingBlendsByItsBaseColoursAlpha) {
  // ClearCoatTest's "Partial_Coating": "alphaMode": "BLEND", no alphaCutoff and no
  // baseColorFactor, its baseColorTexture texture 1, image PartialCoating_Alpha.png. Every other
  // material names no alphaMode.
  const absl::StatusOr<MeshFile> file = load("gltf2/ClearCoat/ClearCoatTest.gltf");
  ASSERT_TRUE(file.ok()) << file.status();
  int blended = 0;
  for (const Material& m : file->materials) {
    SCOPED_TRACE(m.name);
    if (m.name != "Partial_Coating") {
      EXPECT_EQ(m.alpha_mode, AlphaMode::kOpaque);
      EXPECT_FALSE(m.has_cutouts());
      continue;
    }
    ++blended;
    EXPECT_EQ(m.alpha_mode, AlphaMode::kBlend);
    EXPECT_EQ(m.opacity, 1.0f);
    EXPECT_EQ(m.alpha_cutoff, 0.5f);
    ASSERT_TRUE(m.opacity_map.used());
    EXPECT_EQ(m.opacity_map.texture, m.color_map.texture);
    EXPECT_EQ(file->textures.at(m.opacity_map.texture).name, "PartialCoating_Alpha.png");
    EXPECT_TRUE(m.has_cutouts());
  }
  EXPECT_EQ(blended, 1);
}

TEST(ThirdPartyGltf, UnityCubeMaterialKeepsItsFactors) {
  // "baseColorFactor": [0.6038274, 0.6038274, 0.6038274, 1.0], "metallicFactor": 0.0,
  // "roughnessFactor": 0.5.
  const absl::StatusOr<MeshFile> file = load("gltf2/AnimatedMorphCube.gltf");
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->materials.size(), 1u);
  const Material& m = file->materials[0];
  EXPECT_EQ(m.name, "Material");
  EXPECT_EQ(m.type, MaterialType::kMetallicRoughness);
  EXPECT_THAT(m.color, Vec3Near(Vec3f(0.6038274f), 0));
  EXPECT_EQ(m.metallic, 0.0f);
  EXPECT_EQ(m.roughness, 0.5f);
}

TEST(ThirdPartyObj, SpiderReadsItsDiffuseMapsThroughWindowsPaths) {
  // spider.mtl names its maps as ".\\SpiderTex.jpg" and so on: five materials, each with its own
  // map_Kd, read beside the model with the separator turned.
  const absl::StatusOr<MeshFile> file = load("obj/spider/spider.obj");
  ASSERT_TRUE(file.ok()) << file.status();
  EXPECT_TRUE(file->warnings.empty()) << file->warnings.front();
  ASSERT_EQ(file->textures.size(), 5u);
  for (const Material& m : file->materials) {
    ASSERT_TRUE(m.color_map.used()) << m.name;
    const TextureImage& t = file->textures.at(m.color_map.texture);
    EXPECT_EQ(*t.encoded, file_bytes("thirdparty/obj/spider/" + t.name)) << m.name;
  }
  const auto map_of = [&](const std::string& material) {
    for (const Material& m : file->materials) {
      if (m.name == material) return file->textures.at(m.color_map.texture).name;
    }
    return std::string("(none)");
  };
  EXPECT_EQ(map_of("HLeibTex"), "SpiderTex.jpg");
  EXPECT_EQ(map_of("BeinTex"), "drkwood2.jpg");
  EXPECT_EQ(map_of("Skin"), "wal67ar_small.jpg");
  ASSERT_FALSE(file->meshes.empty());
  EXPECT_EQ(file->meshes[0].uvs.size(), file->meshes[0].positions.size());
}

TEST(ThirdPartyAssimp, AsciiStl) {
  const absl::StatusOr<MeshFile> file = load("stl/triangle.stl");
  ASSERT_TRUE(file.ok()) << file.status();
  const Expected expected = read_ascii_stl("thirdparty/stl/triangle.stl");
  EXPECT_EQ(expected.triangles, 1u);
  expect_matches(*file, expected, 0);
}

TEST(ThirdPartyAssimp, BinaryStl) {
  const absl::StatusOr<MeshFile> file = load("stl/Spider_binary.stl");
  ASSERT_TRUE(file.ok()) << file.status();
  const Expected expected = read_binary_stl("thirdparty/stl/Spider_binary.stl");
  EXPECT_EQ(expected.triangles, 1368u);
  expect_matches(*file, expected, 0);
  // JoinIdenticalVertices: STL stores three corners per triangle, shared ones are merged.
  size_t vertices = 0;
  for (const Mesh& mesh : file->meshes) vertices += mesh.positions.size();
  EXPECT_LT(vertices, 3 * expected.triangles);
}

TEST(ThirdPartyAssimp, Off) {
  const absl::StatusOr<MeshFile> file = load("off/Cube.off");
  ASSERT_TRUE(file.ok()) << file.status();
  const Expected expected = read_off("thirdparty/off/Cube.off");
  EXPECT_EQ(expected.triangles, 12u);
  expect_matches(*file, expected, 0);
}

TEST(ThirdPartyAssimp, ThreeMf) {
  // 3D/3dmodel.model inside the zip: 8 vertices spanning (0, 0, 0) to (10, 20, 30), 12 triangles.
  const absl::StatusOr<MeshFile> file = load("3mf/box.3mf");
  ASSERT_TRUE(file.ok()) << file.status();
  Expected expected;
  expected.triangles = 12;
  expected.add_point({0, 0, 0});
  expected.add_point({10, 20, 30});
  expect_matches(*file, expected, 1e-5f);
}

TEST(ThirdPartyAssimp, ColladaTriangleStripsAndMaterial) {
  // Six <tristrips> <p> runs of four vertices: two triangles each; positions are +-50.
  const absl::StatusOr<MeshFile> file = load("collada/cube_tristrips.dae");
  ASSERT_TRUE(file.ok()) << file.status();
  Expected expected;
  expected.triangles = 12;
  expected.add_point({-50, -50, -50});
  expected.add_point({50, 50, 50});
  expect_matches(*file, expected, 1e-3f);
  // The <phong> effect: diffuse (0.137255, 0.403922, 0.870588), specular 0.5 and shininess 16.
  // Blue sums to 1.370588, so both colours are scaled by 1 / 1.370588 to conserve energy.
  ASSERT_FALSE(file->meshes.empty());
  const uint32_t id = file->meshes[0].material_ids[0];
  ASSERT_LT(id, file->materials.size());
  const Material& m = file->materials[id];
  EXPECT_EQ(m.type, MaterialType::kPhong);
  const float scale = 1 / 1.370588f;
  EXPECT_THAT(m.color, Vec3Near(Vec3f(0.137255f, 0.403922f, 0.870588f) * scale, 1e-5f));
  EXPECT_THAT(m.specular, Vec3Near(Vec3f(0.5f) * scale, 1e-5f));
  EXPECT_LE(m.color.z + m.specular.z, 1.0f);
  EXPECT_EQ(m.exponent, 16.0f);
  EXPECT_THAT(file->warnings,
              ::testing::Contains(HasSubstr(
                  "cube_tristrips.dae: material 'material': diffuse + specular colour (0.637255, "
                  "0.903922, 1.37059) exceeds 1; both scaled by 0.7296")));
}

// The same file's two cameras and two point lights, placed by their nodes. The file is Z_UP and
// its nodes sit in a group turned 90 degrees about x, which Assimp's turn of Z_UP to Y_UP undoes:
// each stands where its own matrix puts it. A COLLADA camera looks down its -z axis with y up.
// Assimp loses the yfov of 37.85 degrees (it reports 0.79), which is replaced by 40 degrees with
// a warning. A light of constant attenuation 1 keeps its colour as the irradiance at the model's
// centre, so its intensity is the squared distance from there (the box is centred on the origin).
TEST(ThirdPartyAssimp, ColladaCamerasAndLightsArePlacedByTheirNodes) {
  const absl::StatusOr<MeshFile> file = load("collada/cube_tristrips.dae");
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->cameras.size(), 2u);
  for (const Camera& camera : file->cameras) {
    EXPECT_THAT(camera.position, Vec3Near(Vec3f(-427.749f, 333.855f, 655.017f), 1e-2f));
    EXPECT_THAT(camera.look_at - camera.position,
                Vec3Near(Vec3f(0.504282f, -0.377766f, -0.776526f), 1e-4f));
    EXPECT_THAT(camera.up, Vec3Near(Vec3f(0.205746f, 0.925901f, -0.316822f), 1e-4f));
    EXPECT_EQ(camera.vertical_fov_deg, 40.0f);
    EXPECT_EQ(camera.width, camera.height);
  }
  EXPECT_THAT(file->warnings, ::testing::Contains(HasSubstr("Assimp reports a field of view of")));
  ASSERT_EQ(file->lights.size(), 2u);
  std::map<std::string, Vec3f> where;
  for (const Light& light : file->lights) {
    EXPECT_EQ(light.type, LightType::kPoint) << light.name;
    where[light.name] = light.position;
    const float d2 = length_squared(light.position);
    EXPECT_THAT(light.intensity, Vec3Near(Vec3f(d2), 1e-3f * d2)) << light.name;
  }
  EXPECT_THAT(where["Light"], Vec3Near(Vec3f(-500, 1000, 400), 1e-2f));
  EXPECT_THAT(where["pointLight1"], Vec3Near(Vec3f(3, 4, 10), 1e-4f));
}

// The shading model decides whether a specular colour is a lobe: the same effect as <lambert>
// (Assimp's Gouraud, diffuse only) is diffuse with the file's colour, and as <phong> with a black
// specular colour too.
TEST(ThirdPartyAssimp, ColladaEffectsWithoutAHighlightAreDiffuse) {
  const std::string text = file_bytes("thirdparty/collada/cube_tristrips.dae");
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("caustica-dae-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto replaced = [](std::string s, const std::string& from, const std::string& to) {
    for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) {
      s.replace(at, from.size(), to);
    }
    return s;
  };
  std::ofstream(dir / "lambert.dae")
      << replaced(replaced(text, "<phong>", "<lambert>"), "</phong>", "</lambert>");
  std::ofstream(dir / "black.dae")
      << replaced(text, "<specular>\n\t\t\t\t\t\t\t<color>0.5 0.5 0.5 1</color>",
                  "<specular>\n\t\t\t\t\t\t\t<color>0 0 0 1</color>");
  for (const char* name : {"lambert.dae", "black.dae"}) {
    SCOPED_TRACE(name);
    const absl::StatusOr<MeshFile> file = load_mesh_file(dir / name);
    ASSERT_TRUE(file.ok()) << file.status();
    ASSERT_EQ(file->materials.size(), 1u);
    EXPECT_EQ(file->materials[0].type, MaterialType::kDiffuse);
    EXPECT_THAT(file->materials[0].color, Vec3Near(Vec3f(0.137255f, 0.403922f, 0.870588f), 1e-5f));
  }
  std::filesystem::remove_all(dir);
}

TEST(ThirdPartyAssimp, ColladaConcavePolygonIsTriangulated) {
  // One <polylist> polygon of 66 corners (<vcount>): a concave outline with a bridged hole, so
  // 64 triangles; the bounds are those of the positions float_array.
  const absl::StatusOr<MeshFile> file = load("collada/ConcavePolygon.dae");
  ASSERT_TRUE(file.ok()) << file.status();
  const std::string text = file_bytes("thirdparty/collada/ConcavePolygon.dae");
  const size_t array = text.find("<float_array id=\"Mesh_Object_positions_array\" count=\"192\">");
  ASSERT_NE(array, std::string::npos);
  std::istringstream values(text.substr(text.find('>', array) + 1));
  Expected expected;
  expected.triangles = 64;
  for (int v = 0; v < 64; ++v) {
    Vec3f p;
    values >> p.x >> p.y >> p.z;
    expected.add_point(p);
  }
  expect_matches(*file, expected, 1e-6f);
  // Its <blinn> effect names only a diffuse colour; Assimp's COLLADA reader gives every effect a
  // specular colour of 0.4 and a shininess of 10 the file does not override, which is what the
  // file says through it. The sum stays within 1, so nothing is scaled.
  ASSERT_EQ(file->materials.size(), 1u);
  const Material& m = file->materials[0];
  EXPECT_EQ(m.type, MaterialType::kPhong);
  EXPECT_THAT(m.color, Vec3Near(Vec3f(0.141176f, 0.184314f, 0.411765f), 1e-6f));
  EXPECT_THAT(m.specular, Vec3Near(Vec3f(0.4f), 1e-6f));
  EXPECT_EQ(m.exponent, 10.0f);
  EXPECT_TRUE(file->warnings.empty()) << file->warnings.front();
}

TEST(ThirdPartyAssimp, BinaryFbxBoxWithGeometricPivot) {
  // The file's own values, read from its binary records: Vertices is a +-100 cube of 24
  // corners, PolygonVertexIndex twelve 3-corner polygons, and the Model's Properties70 give
  // GeometricTranslation, GeometricRotation (Euler XYZ, degrees) and GeometricScaling.
  const absl::StatusOr<MeshFile> file = load("fbx/box.fbx");
  ASSERT_TRUE(file.ok()) << file.status();
  const Affine pivot =
      translation({0.02918294258415699f, 0.041242070496082306f, 0.2000068873167038f}) *
      rotation_y_deg(-30.398331095399516) * rotation_x_deg(19.52863768959518) *
      scaling({0.0017681174642734368f, 0.0015908040794570112f, 0.0015908040167168886f});
  Expected expected;
  expected.triangles = 12;
  for (int i = 0; i < 8; ++i) {
    expected.add_point(pivot.apply_to_point(
        {(i & 1) ? 100.0f : -100.0f, (i & 2) ? 100.0f : -100.0f, (i & 4) ? 100.0f : -100.0f}));
  }
  expect_matches(*file, expected, 1e-5f);
  size_t vertices = 0;
  for (const Mesh& mesh : file->meshes) vertices += mesh.positions.size();
  EXPECT_EQ(vertices, 24u);
}

// The same file's material, from its Properties70: ShadingModel "Phong", DiffuseColor (253, 236,
// 166) / 255, SpecularColor 9 / 255 with SpecularFactor 1 and ShininessExponent 62.869449615. A
// Phong material, though Assimp also reports a roughness factor it derives from the exponent; red
// sums to 262 / 255, so both colours are scaled by 255 / 262.
TEST(ThirdPartyAssimp, BinaryFbxPhongMaterialConservesEnergy) {
  const absl::StatusOr<MeshFile> file = load("fbx/box.fbx");
  ASSERT_TRUE(file.ok()) << file.status();
  ASSERT_EQ(file->materials.size(), 1u);
  const Material& m = file->materials[0];
  EXPECT_EQ(m.type, MaterialType::kPhong);
  const float scale = 255.0f / 262.0f;
  EXPECT_THAT(m.color, Vec3Near(Vec3f(253, 236, 166) * (scale / 255), 1e-6f));
  EXPECT_THAT(m.specular, Vec3Near(Vec3f(9) * (scale / 255), 1e-6f));
  EXPECT_LE(m.color.x + m.specular.x, 1.0f);
  EXPECT_NEAR(m.color.x + m.specular.x, 1.0f, 1e-6f);
  EXPECT_FLOAT_EQ(m.exponent, 62.869449615f);
  EXPECT_THAT(file->warnings,
              ::testing::Contains(HasSubstr("box.fbx: material 'Material_50': diffuse + specular "
                                            "colour (1.02745, 0.960784, 0.686275) exceeds 1")));
}

// A scene JSON's "mesh" shape reads the same files, with the file's materials or an override.
TEST(ThirdPartyInJsonScene, AssimpFilesAsMeshShapes) {
  const std::string json = R"({
    "camera": {"position": [0, 0, 500], "look_at": [0, 0, 0], "fov": 40, "width": 64,
               "height": 64},
    "materials": {"grey": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]}},
    "lights": [{"type": "point", "position": [0, 300, 300], "intensity": [1e5, 1e5, 1e5]}],
    "shapes": [
      {"type": "mesh", "file": "collada/cube_tristrips.dae"},
      {"type": "mesh", "file": "stl/triangle.stl", "material": "grey",
       "transform": {"translate": [0, 0, 100]}}
    ]})";
  const absl::StatusOr<Scene> scene =
      parse_scene(json, scene_data("thirdparty"), "thirdparty.json");
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_EQ(scene->triangle_count(), 12u + 1u);
  // The COLLADA material, named after its file; the STL triangle moved and overridden.
  bool found = false;
  for (const Material& m : scene->materials) {
    if (m.name.rfind("cube_tristrips.dae:", 0) == 0) {
      found = true;
      EXPECT_EQ(m.type, MaterialType::kPhong);
      EXPECT_THAT(m.color,
                  Vec3Near(Vec3f(0.137255f, 0.403922f, 0.870588f) * (1 / 1.370588f), 1e-5f));
    }
  }
  EXPECT_TRUE(found);
  const Mesh& triangle = scene->meshes.back();
  EXPECT_EQ(triangle.material_ids, (std::vector<uint32_t>{0}));
  EXPECT_EQ(triangle.positions[0].z, 100);
}

TEST(AssimpErrors, GarbageIsWrappedWithTheFileName) {
  const absl::Status status = load_mesh_file(scene_data("bad/garbage.fbx")).status();
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(message_of(status), HasSubstr("garbage.fbx: Assimp could not read it: "));
}

TEST(AssimpErrors, TruncatedBinaryStl) {
  const absl::Status status = load_mesh_file(scene_data("bad/truncated.stl")).status();
  ASSERT_FALSE(status.ok());
  EXPECT_THAT(message_of(status), HasSubstr("truncated.stl: Assimp could not read it: "));
}

TEST(AssimpErrors, MissingFileIsNotFound) {
  const absl::Status status = load_mesh_file(scene_data("bad/nope.fbx")).status();
  EXPECT_EQ(status.code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(message_of(status), HasSubstr("nope.fbx: file not found"));
}

TEST(AssimpErrors, ExtensionsReadThroughAssimp) {
  for (const char* extension : {".fbx", ".FBX", ".dae", ".stl", ".3mf", ".off", ".3ds"}) {
    EXPECT_TRUE(assimp_reads_extension(extension)) << extension;
  }
  EXPECT_FALSE(assimp_reads_extension(".notamesh"));
  EXPECT_TRUE(is_mesh_file_name("a/b/model.STL"));
  EXPECT_TRUE(is_mesh_file_name("scan.ply.gz"));
  EXPECT_FALSE(is_mesh_file_name("scene.json"));
}

}  // namespace
}  // namespace caustica
