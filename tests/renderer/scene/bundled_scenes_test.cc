// The scenes shipped in scenes/ load, validate and are what they claim to be.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <set>
#include <vector>

#include "renderer/scene/load_scene.h"
#include "renderer/scene/validate.h"
#include "tests/renderer/scene/scene_test_util.h"

namespace caustica {
namespace {

using ::caustica::testing::find_mesh;
using ::caustica::testing::triangle_cross;
using ::caustica::testing::Vec3Near;
using ::testing::HasSubstr;

std::vector<std::filesystem::path> bundled_scene_files() {
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(CAUSTICA_SCENES_DIR)) {
    if (entry.is_regular_file() && entry.path().filename() == "scene.json") {
      files.push_back(entry.path());
    }
  }
  return files;
}

TEST(BundledScenes, EveryOneLoadsAndValidates) {
  const std::vector<std::filesystem::path> files = bundled_scene_files();
  EXPECT_GE(files.size(), 3u);
  for (const std::filesystem::path& file : files) {
    SCOPED_TRACE(file.string());
    const absl::StatusOr<Scene> scene = load_scene(file);
    ASSERT_TRUE(scene.ok()) << scene.status();
    EXPECT_TRUE(validate_scene(*scene).ok());
    EXPECT_GT(scene->triangle_count(), 0u);
  }
}

Scene load(const char* relative) {
  absl::StatusOr<Scene> scene = load_scene(std::filesystem::path(CAUSTICA_SCENES_DIR) / relative);
  EXPECT_TRUE(scene.ok()) << scene.status();
  return scene.ok() ? *std::move(scene) : Scene();
}

TEST(BundledScenes, CornellBoxMatchesTheReference) {
  const Scene scene = load("cornell-box/scene.json");
  EXPECT_EQ(scene.meshes.size(), 16u);  // 5 walls, light, 2 blocks of 5 faces
  EXPECT_EQ(scene.triangle_count(), 32u);
  EXPECT_THAT(scene.camera.position, Vec3Near(Vec3f(278, 273, -800), 0));
  EXPECT_FLOAT_EQ(scene.camera.vertical_fov_deg, 39.3077f);
  EXPECT_EQ(scene.settings.photons_per_pass, 200000u);
  EXPECT_EQ(scene.settings.k_nearest, 64u);
  EXPECT_TRUE(scene.lights.empty());

  const Mesh* light = find_mesh(scene, "'light'");
  ASSERT_NE(light, nullptr);
  const Material& emitter = scene.materials[light->material_ids[0]];
  EXPECT_EQ(emitter.type, MaterialType::kEmissive);
  EXPECT_THAT(emitter.radiance, Vec3Near(Vec3f(17, 12, 4), 0));
  double area = 0;
  for (size_t t = 0; t < light->triangle_count(); ++t) {
    const Vec3f n = triangle_cross(*light, t);
    EXPECT_LT(n.y, 0) << "the light must face down";
    EXPECT_THAT(normalize(n), Vec3Near(Vec3f(0, -1, 0), 1e-6f));
    area += 0.5 * length(n);
  }
  EXPECT_NEAR(area, 130.0 * 105.0, 1e-2);

  const Mesh* red = find_mesh(scene, "'left wall'");
  ASSERT_NE(red, nullptr);
  EXPECT_THAT(scene.materials[red->material_ids[0]].color,
              Vec3Near(Vec3f(0.63f, 0.065f, 0.05f), 0));
  const Mesh* green = find_mesh(scene, "'right wall'");
  ASSERT_NE(green, nullptr);
  EXPECT_THAT(scene.materials[green->material_ids[0]].color,
              Vec3Near(Vec3f(0.14f, 0.45f, 0.091f), 0));
}

TEST(BundledScenes, CornellCausticsHasTheTwoSpheres) {
  const Scene scene = load("cornell-caustics/scene.json");
  const Mesh* glass = find_mesh(scene, "'glass sphere'");
  const Mesh* mirror = find_mesh(scene, "'mirror sphere'");
  ASSERT_NE(glass, nullptr);
  ASSERT_NE(mirror, nullptr);
  EXPECT_EQ(glass->triangle_count(), 3968u);
  EXPECT_EQ(scene.materials[glass->material_ids[0]].type, MaterialType::kDielectric);
  EXPECT_EQ(scene.materials[glass->material_ids[0]].ior, 1.5f);
  EXPECT_EQ(scene.materials[mirror->material_ids[0]].type, MaterialType::kMirror);
  for (const Vec3f& p : glass->positions) EXPECT_NEAR(length(p - Vec3f(370, 100, 350)), 100, 1e-2);
  for (const Vec3f& p : mirror->positions) EXPECT_NEAR(length(p - Vec3f(180, 100, 200)), 100, 1e-2);
  EXPECT_EQ(find_mesh(scene, "block"), nullptr);
}

TEST(BundledScenes, RingSceneHasAMirrorRingAndAPointLight) {
  const Scene scene = load("ring/scene.json");
  const Mesh* ring = find_mesh(scene, "'ring'");
  ASSERT_NE(ring, nullptr);
  EXPECT_EQ(ring->triangle_count(), 8u * 256u);
  EXPECT_EQ(scene.materials[ring->material_ids[0]].type, MaterialType::kMirror);
  ASSERT_EQ(scene.lights.size(), 1u);
  EXPECT_EQ(scene.lights[0].type, LightType::kPoint);
  // 45 degrees above the horizon, 600 mm from the ring's base.
  EXPECT_NEAR(length(scene.lights[0].position), 600, 0.01);
  EXPECT_NEAR(scene.lights[0].position.y, 600 / std::sqrt(2.0), 0.01);
  EXPECT_EQ(scene.settings.photons_per_pass, 500000u);
}

}  // namespace
}  // namespace caustica

namespace caustica {
namespace {

// The DamagedHelmet's one material is glTF's metallic-roughness model of the file's default
// factors, its base colour, emission, metallic-roughness and normal textures four maps of their
// own, the normal map at glTF's default scale.
TEST(BundledScenes, TheHelmetIsAMetallicRoughnessMaterialWithItsMaps) {
  const Scene scene = load("damaged-helmet/scene.json");
  ASSERT_EQ(scene.materials.size(), 1u);
  const Material& m = scene.materials[0];
  EXPECT_EQ(m.type, MaterialType::kMetallicRoughness);
  EXPECT_EQ(m.metallic, 1.0f);
  EXPECT_EQ(m.roughness, 1.0f);
  ASSERT_TRUE(m.color_map.used());
  ASSERT_TRUE(m.emission_map.used());
  ASSERT_TRUE(m.metallic_roughness_map.used());
  EXPECT_EQ(scene.textures.at(m.metallic_roughness_map.texture).name.find("metalRoughness") !=
                std::string::npos,
            true)
      << scene.textures.at(m.metallic_roughness_map.texture).name;
  EXPECT_NE(m.metallic_roughness_map.texture, m.color_map.texture);
  EXPECT_NE(m.metallic_roughness_map.texture, m.emission_map.texture);
  ASSERT_TRUE(m.normal_map.used());
  EXPECT_NE(scene.textures.at(m.normal_map.texture).name.find("normal"), std::string::npos)
      << scene.textures.at(m.normal_map.texture).name;
  EXPECT_EQ(m.normal_scale, 1.0f);
}

}  // namespace
}  // namespace caustica

namespace caustica {
namespace {

// Sibenik's 3DS file self-illuminates its window glass 100% ('glas', 1,719 triangles), which
// Assimp reports as an emissive colour of 1: read as light, it was the cathedral's only light,
// too faint to see by, and it kept the bare file from getting a light of its own. It emits
// nothing, the loader says why, and the bare file is seen and lit from inside.
TEST(BundledScenes, SibeniksSelfIlluminatedGlassEmitsNothing) {
  std::vector<std::string> warnings;
  const absl::StatusOr<Scene> bare =
      load_scene(std::filesystem::path(CAUSTICA_SCENES_DIR) / "sibenik" / "sibenik.3ds", &warnings);
  ASSERT_TRUE(bare.ok()) << bare.status();
  for (const Material& m : bare->materials) EXPECT_TRUE(is_black(m.radiance)) << m.name;
  EXPECT_THAT(warnings, ::testing::Contains(::testing::HasSubstr(
                            "material 'glas': 3DS self-illumination 100% shades the surface")));
  EXPECT_THAT(warnings, ::testing::Contains(::testing::HasSubstr("with a light above it")));
  ASSERT_EQ(bare->lights.size(), 1u);
  EXPECT_EQ(bare->lights[0].name, "default light");
  EXPECT_EQ(bare->textures.size(), 3u);
}

// Sponza's 3DS file names a bump map for most of its materials, the stone's own height maps and,
// for the rest, their colour maps: each becomes the material's bump map with the file's bump
// amount, and no warning calls them unread.
TEST(BundledScenes, SponzasBumpMapsAreRead) {
  std::vector<std::string> warnings;
  const absl::StatusOr<Scene> bare =
      load_scene(std::filesystem::path(CAUSTICA_SCENES_DIR) / "sponza" / "sponza.3ds", &warnings);
  ASSERT_TRUE(bare.ok()) << bare.status();
  EXPECT_THAT(warnings, ::testing::Not(::testing::Contains(HasSubstr("bump"))));
  std::map<std::string, std::set<float>> scales_of_map;
  size_t bumped = 0;
  for (const Material& m : bare->materials) {
    if (!m.bump_map.used()) continue;
    ++bumped;
    scales_of_map[bare->textures.at(m.bump_map.texture).name].insert(m.bump_scale);
  }
  // Assimp reports the file's bump amounts as 1.
  for (const auto& [name, scales] : scales_of_map) EXPECT_EQ(scales, std::set<float>{1.0f}) << name;
  EXPECT_EQ(scales_of_map.size(), 10u);
  EXPECT_EQ(bumped, 17u);
  for (const char* height : {"KAMEN-BU.JPG", "RELJEF-B.JPG", "SP_LUK-B.JPG", "01_STUB-.JPG"})
    EXPECT_TRUE(scales_of_map.count(height)) << height;
}

// A scene file passes on what its mesh files' loaders warn of, each after the shape that names
// the file: the same warning about Sibenik's glass, through the bundled scene.json.
TEST(BundledScenes, AScenesMeshWarningsReachItsReader) {
  std::vector<std::string> warnings;
  const std::filesystem::path file =
      std::filesystem::path(CAUSTICA_SCENES_DIR) / "sibenik" / "scene.json";
  const absl::StatusOr<Scene> scene = load_scene(file, &warnings);
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_THAT(warnings,
              ::testing::Contains(::testing::AllOf(
                  ::testing::StartsWith(file.string() + ": shapes[0].file: sibenik.3ds: "),
                  ::testing::HasSubstr("material 'glas': 3DS self-illumination 100%"))));
  // Without a list to fill, the same file loads the same.
  const absl::StatusOr<Scene> quiet = load_scene(file);
  ASSERT_TRUE(quiet.ok()) << quiet.status();
  EXPECT_EQ(quiet->materials.size(), scene->materials.size());
}

}  // namespace
}  // namespace caustica
