// Good scene files load into the values they spell out.
#include "renderer/scene/scene_json.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "absl/strings/str_cat.h"
#include "renderer/accel/structure_kind.h"
#include "renderer/scene/load_scene.h"
#include "renderer/scene/mesh_file.h"
#include "tests/renderer/scene/scene_test_util.h"

namespace caustica {
namespace {

using ::caustica::testing::find_material;
using ::caustica::testing::find_mesh;
using ::caustica::testing::message_of;
using ::caustica::testing::scene_data;
using ::caustica::testing::triangle_cross;
using ::caustica::testing::Vec3Near;
using ::testing::AllOf;
using ::testing::HasSubstr;

class ShapesSceneTest : public ::testing::Test {
 protected:
  void SetUp() override {
    absl::StatusOr<Scene> loaded = load_scene(scene_data("good/shapes.json"));
    ASSERT_TRUE(loaded.ok()) << loaded.status();
    scene_ = *std::move(loaded);
  }
  Scene scene_;
};

TEST_F(ShapesSceneTest, CameraAndSettings) {
  EXPECT_THAT(scene_.camera.position, Vec3Near(Vec3f(0, 1, -5), 0));
  EXPECT_THAT(scene_.camera.look_at, Vec3Near(Vec3f(0, 1, 0), 0));
  EXPECT_THAT(scene_.camera.up, Vec3Near(Vec3f(0, 1, 0), 0));  // default
  EXPECT_EQ(scene_.camera.vertical_fov_deg, 50);
  EXPECT_EQ(scene_.camera.width, 320);
  EXPECT_EQ(scene_.camera.height, 240);
  const RenderSettings& s = scene_.settings;
  EXPECT_EQ(s.photons_per_pass, 100000u);  // written 1e5
  EXPECT_EQ(s.k_nearest, 32u);
  EXPECT_EQ(s.max_radius, 0.5f);
  EXPECT_EQ(s.kernel, DensityKernel::kCone);
  EXPECT_EQ(s.max_depth, 10u);
  EXPECT_EQ(s.max_photon_bounces, 12u);
  EXPECT_EQ(s.area_light_samples, 8u);
  EXPECT_EQ(s.passes, 4u);
  EXPECT_EQ(s.seed, 7u);
}

TEST_F(ShapesSceneTest, Materials) {
  ASSERT_EQ(scene_.materials.size(), 5u);
  const Material* white = find_material(scene_, "white");
  ASSERT_NE(white, nullptr);
  EXPECT_EQ(white->type, MaterialType::kDiffuse);
  EXPECT_THAT(white->color, Vec3Near(Vec3f(0.8f, 0.7f, 0.6f), 0));
  EXPECT_EQ(find_material(scene_, "chrome")->type, MaterialType::kMirror);
  EXPECT_EQ(find_material(scene_, "glass")->type, MaterialType::kDielectric);
  EXPECT_EQ(find_material(scene_, "glass")->ior, 1.33f);
  EXPECT_EQ(find_material(scene_, "default glass")->ior, 1.5f);
  const Material* lamp = find_material(scene_, "lamp");
  EXPECT_EQ(lamp->type, MaterialType::kEmissive);
  EXPECT_THAT(lamp->radiance, Vec3Near(Vec3f(10, 9, 8), 0));
}

TEST_F(ShapesSceneTest, Lights) {
  ASSERT_EQ(scene_.lights.size(), 3u);
  const Light& point = scene_.lights[0];
  EXPECT_EQ(point.name, "bulb");
  EXPECT_EQ(point.type, LightType::kPoint);
  EXPECT_THAT(point.position, Vec3Near(Vec3f(0, 3, 0), 0));
  EXPECT_THAT(point.intensity, Vec3Near(Vec3f(5, 5, 5), 0));
  const Light& spot = scene_.lights[1];
  EXPECT_EQ(spot.type, LightType::kSpot);
  EXPECT_THAT(spot.direction, Vec3Near(Vec3f(0, -1, 0), 0));  // normalised
  EXPECT_THAT(spot.intensity, Vec3Near(Vec3f(1, 2, 3), 0));
  EXPECT_EQ(spot.inner_angle_deg, 10);
  EXPECT_EQ(spot.outer_angle_deg, 20);
  const Light& sun = scene_.lights[2];
  EXPECT_EQ(sun.type, LightType::kDirectional);
  EXPECT_THAT(sun.direction, Vec3Near(Vec3f(0, 0, 1), 0));
  EXPECT_THAT(sun.intensity, Vec3Near(Vec3f(0.5f, 0.5f, 0.5f), 0));
}

TEST_F(ShapesSceneTest, Shapes) {
  ASSERT_EQ(scene_.meshes.size(), 5u);
  const Mesh& lamp = scene_.meshes[0];
  EXPECT_EQ(lamp.name, "shapes[0] 'lamp'");
  EXPECT_EQ(lamp.triangle_count(), 2u);
  EXPECT_EQ(scene_.materials[lamp.material_ids[0]].name, "lamp");
  EXPECT_LT(triangle_cross(lamp, 0).y, 0);  // faces down into the room

  const Mesh& triangles = scene_.meshes[1];
  EXPECT_EQ(triangles.name, "shapes[1]");
  EXPECT_EQ(triangles.indices, (std::vector<uint32_t>{0, 2, 1, 0, 3, 2}));
  EXPECT_THAT(triangles.positions[2], Vec3Near(Vec3f(1, 0, 1), 0));

  EXPECT_EQ(scene_.meshes[2].triangle_count(), 2u * 16u * 7u);  // rings 8, segments 16
  EXPECT_EQ(scene_.meshes[3].triangle_count(), 3968u);          // defaults 32 x 64
  EXPECT_EQ(scene_.meshes[3].positions.size(), 2u + 31u * 64u);
  EXPECT_EQ(scene_.meshes[4].triangle_count(), 8u * 32u);
  for (const Mesh& mesh : scene_.meshes) {
    EXPECT_EQ(mesh.material_ids.size(), mesh.triangle_count()) << mesh.name;
  }
}

class MeshesSceneTest : public ::testing::Test {
 protected:
  void SetUp() override {
    absl::StatusOr<Scene> loaded = load_scene(scene_data("good/meshes.json"));
    ASSERT_TRUE(loaded.ok()) << loaded.status();
    scene_ = *std::move(loaded);
  }
  Scene scene_;
};

// Mesh names read back into the shape's path and its own name, for every form shape_label
// writes, and nothing for names it did not write.
TEST(ShapeLabel, ReadsBackWhatItWrites) {
  const struct {
    const char* scene_name;
    const char* file_part;
  } cases[] = {{"", ""},     {"dragon", ""},      {"dragon", "body"},
               {"", "body"}, {"it's", "o'clock"}, {"a (b)", "c"}};
  for (const auto& [scene_name, file_part] : cases) {
    const std::string label = shape_label("shapes[12]", scene_name, file_part);
    const ShapeLabel read = parse_shape_label(label);
    EXPECT_EQ(read.path, "shapes[12]") << label;
    EXPECT_EQ(read.name, scene_name) << label;
  }
  for (const char* other : {"dragon", "Mesh 3", "shapes[", "shape[1] 'x'"}) {
    EXPECT_TRUE(parse_shape_label(other).path.empty()) << other;
    EXPECT_TRUE(parse_shape_label(other).name.empty()) << other;
  }
}

TEST_F(MeshesSceneTest, TransformScalesThenRotatesThenTranslates) {
  const Mesh* moved = find_mesh(scene_, "'moved'");
  ASSERT_NE(moved, nullptr);
  EXPECT_THAT(moved->name, HasSubstr("quad_tri_le.ply"));
  // (1, 0, 0) -> scale 2 -> (2, 0, 0) -> 90 degrees about y -> (0, 0, -2) -> (10, 0, -2).
  EXPECT_THAT(moved->positions[1], Vec3Near(Vec3f(10, 0, -2), 1e-5f));
  // Normals turn with the mesh: +z -> +x.
  EXPECT_THAT(moved->normals[1], Vec3Near(Vec3f(1, 0, 0), 1e-6f));
}

TEST_F(MeshesSceneTest, RotationsApplyXThenYThenZ) {
  const Mesh* ordered = find_mesh(scene_, "'ordered'");
  ASSERT_NE(ordered, nullptr);
  // (0.5, 2, 0.25) -> scale (1, 2, 3) -> (0.5, 4, 0.75) -> x 90 -> (0.5, -0.75, 4)
  // -> z 90 -> (0.75, 0.5, 4) -> translate (1, 2, 3) -> (1.75, 2.5, 7).
  EXPECT_THAT(ordered->positions[4], Vec3Near(Vec3f(1.75f, 2.5f, 7), 1e-5f));
}

TEST_F(MeshesSceneTest, MirroringTransformKeepsTrianglesFacingTheSameSide) {
  const Mesh* mirrored = find_mesh(scene_, "'mirrored'");
  ASSERT_NE(mirrored, nullptr);
  EXPECT_THAT(mirrored->positions[1], Vec3Near(Vec3f(-1, 0, 0), 0));
  // The original faces +z; a mirror in x must not turn it round.
  EXPECT_GT(triangle_cross(*mirrored, 0).z, 0);
  EXPECT_THAT(mirrored->normals[0], Vec3Near(Vec3f(0, 0, 1), 1e-6f));
}

TEST_F(MeshesSceneTest, FileMaterialsAreMergedUnlessOverridden) {
  // grey, then box.obj's four, then lights.glb's four; the overridden box adds none.
  ASSERT_EQ(scene_.materials.size(), 9u);
  const Material* chrome = find_material(scene_, "box.obj:chrome");
  ASSERT_NE(chrome, nullptr);
  EXPECT_EQ(chrome->type, MaterialType::kMirror);
  ASSERT_NE(find_material(scene_, "lights.glb:Lamp"), nullptr);

  const Mesh* own = find_mesh(scene_, "'own materials'");
  ASSERT_NE(own, nullptr);
  std::vector<std::string> names;
  for (uint32_t id : own->material_ids) names.push_back(scene_.materials[id].name);
  EXPECT_THAT(names, ::testing::ElementsAre("box.obj:white", "box.obj:white", "box.obj:chrome",
                                            "box.obj:glass", "box.obj:lamp"));
  const Mesh* overridden = find_mesh(scene_, "'overridden'");
  ASSERT_NE(overridden, nullptr);
  for (uint32_t id : overridden->material_ids) EXPECT_EQ(scene_.materials[id].name, "grey");
}

TEST_F(MeshesSceneTest, MeshFileLightsFollowSceneLightsAndTheTransform) {
  ASSERT_EQ(scene_.lights.size(), 4u);
  EXPECT_THAT(scene_.lights[0].position, Vec3Near(Vec3f(0, 10, 0), 0));
  EXPECT_EQ(scene_.lights[1].name, "Bulb");
  EXPECT_THAT(scene_.lights[1].position, Vec3Near(Vec3f(0, 5, 100), 1e-5f));
  const Mesh* gltf_lamp = find_mesh(scene_, "'Tri' primitive 2");
  ASSERT_NE(gltf_lamp, nullptr);
  EXPECT_THAT(gltf_lamp->name, HasSubstr("shapes[5] 'gltf' (lights.glb: mesh 'Tri'"));
  EXPECT_THAT(gltf_lamp->positions[0], Vec3Near(Vec3f(0, 0, 98), 1e-5f));
}

// A scene with one light and one triangle, its settings `settings`.
absl::StatusOr<Scene> scene_with_settings(const std::string& settings) {
  const std::string text = absl::StrCat(R"({
    "camera": {"position": [0, 1, -5], "look_at": [0, 1, 0], "fov": 45, "width": 8, "height": 8},
    "settings": )",
                                        settings, R"(,
    "materials": {"grey": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]}},
    "lights": [{"type": "point", "position": [0, 3, 0], "intensity": [1, 1, 1]}],
    "shapes": [{"type": "triangles", "material": "grey",
                "vertices": [[0, 0, 0], [1, 0, 0], [0, 0, 1]], "indices": [0, 2, 1]}]
  })");
  return parse_scene(text, scene_data("good"), "inline.json");
}

TEST(ParseScene, StructureByName) {
  const absl::StatusOr<Scene> lbvh4 = scene_with_settings(R"({"structure": "lbvh4"})");
  ASSERT_TRUE(lbvh4.ok()) << lbvh4.status();
  EXPECT_EQ(lbvh4->settings.structure, StructureKind::kLbvh4);
  const absl::StatusOr<Scene> binned = scene_with_settings(R"({"structure": "binned-sah"})");
  ASSERT_TRUE(binned.ok()) << binned.status();
  EXPECT_EQ(binned->settings.structure, StructureKind::kBinnedSah);
}

TEST(ParseScene, StructureDefaultsToLbvh4) {
  const absl::StatusOr<Scene> scene = scene_with_settings(R"({"k": 8})");
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_EQ(scene->settings.structure, StructureKind::kLbvh4);
  EXPECT_EQ(kDefaultStructure, StructureKind::kLbvh4);
}

TEST(ParseScene, UnknownStructureNamesTheFieldAndTheValidNames) {
  const absl::StatusOr<Scene> scene = scene_with_settings(R"({"structure": "bvh2"})");
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(message_of(scene.status()), HasSubstr("settings.structure"));
  EXPECT_THAT(message_of(scene.status()), HasSubstr("'bvh2'"));
  EXPECT_THAT(message_of(scene.status()), HasSubstr(structure_kind_list()));
}

TEST(ParseScene, ResolvesMeshPathsAgainstBaseDir) {
  const std::string text = R"({
    "camera": {"position": [0, 1, -5], "look_at": [0, 1, 0], "fov": 45, "width": 8, "height": 8},
    "materials": {"grey": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]}},
    "lights": [{"type": "directional", "direction": [0, -1, 0], "irradiance": [1, 1, 1]}],
    "shapes": [{"type": "mesh", "file": "quad_tri_be.ply", "material": "grey"}]
  })";
  const absl::StatusOr<Scene> scene = parse_scene(text, scene_data("meshes"), "inline.json");
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_EQ(scene->triangle_count(), 3u);
}

// A model file's volumes join the scene's media under the file's name, their coefficients over
// the shape's scale (twice the size absorbs as much over twice the distance); a shape that names
// its own material keeps the file's out.
TEST(ParseScene, AModelFilesVolumesJoinTheScenesMedia) {
  const auto with_shape = [](const std::string& extra) {
    return parse_scene(R"({
      "camera": {"position": [0, 1, -9], "look_at": [0, 0, 0], "fov": 45, "width": 8, "height": 8},
      "materials": {"grey": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]}},
      "media": {"fog": {"type": "homogeneous", "absorption": [0.1, 0.1, 0.1],
                        "scattering": [0, 0, 0]}},
      "lights": [{"type": "point", "position": [0, 4, 0], "intensity": [1, 1, 1]}],
      "shapes": [{"type": "mesh", "file": "volume.gltf",
                  "transform": {"scale": 2})" +
                           extra + R"(}]
    })",
                       scene_data("meshes"), "inline.json");
  };
  const absl::StatusOr<Scene> scene = with_shape("");
  ASSERT_TRUE(scene.ok()) << scene.status();
  ASSERT_EQ(scene->media.size(), 2u);
  EXPECT_EQ(scene->media[1].name, "volume.gltf:tinted (volume)");
  EXPECT_NEAR(scene->media[1].absorption.x, -std::log(0.1f) / 4.0f, 1e-6f);
  size_t enclosing = 0;
  for (const Mesh& mesh : scene->meshes) {
    if (mesh.interior_medium == kNoMedium) continue;
    EXPECT_EQ(mesh.interior_medium, 1u);
    ++enclosing;
  }
  EXPECT_EQ(enclosing, 2u);
  // (The file's open sheet could not enclose a medium the shape named.)
  const absl::StatusOr<Scene> own = with_shape(R"(, "material": "grey")");
  ASSERT_TRUE(own.ok()) << own.status();
  EXPECT_EQ(own->media.size(), 1u);
  for (const Mesh& mesh : own->meshes) EXPECT_EQ(mesh.interior_medium, kNoMedium);
}

// Any kind of material may also emit; its radiance is checked as an emissive material's.
TEST(ParseScene, ADiffuseMaterialMayEmit) {
  auto scene_with = [](const std::string& material) {
    return parse_scene(R"({
      "camera": {"position": [0, 1, -5], "look_at": [0, 1, 0], "fov": 45, "width": 8, "height": 8},
      "materials": {"glow": )" +
                           material + R"(},
      "shapes": [{"type": "quad", "material": "glow",
                  "vertices": [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]}]
    })",
                       scene_data("good"), "inline.json");
  };
  const absl::StatusOr<Scene> glowing =
      scene_with(R"({"type": "diffuse", "albedo": [0.5, 0.5, 0.5], "radiance": [2, 1, 0]})");
  ASSERT_TRUE(glowing.ok()) << glowing.status();
  const Material& m = glowing->materials.at(0);
  EXPECT_EQ(m.type, MaterialType::kDiffuse);
  EXPECT_THAT(m.radiance, Vec3Near(Vec3f(2, 1, 0), 0));
  EXPECT_TRUE(is_emitter(m));
  EXPECT_THAT(emitted_radiance(m), Vec3Near(Vec3f(2, 1, 0), 0));
  // Without it, the scene has no light at all.
  const absl::StatusOr<Scene> dark =
      scene_with(R"({"type": "diffuse", "albedo": [0.5, 0.5, 0.5]})");
  ASSERT_FALSE(dark.ok());
  EXPECT_THAT(message_of(dark.status()), HasSubstr("no light"));
  const absl::StatusOr<Scene> negative =
      scene_with(R"({"type": "mirror", "reflectance": [1, 1, 1], "radiance": [1, -1, 1]})");
  ASSERT_FALSE(negative.ok());
  EXPECT_THAT(message_of(negative.status()), HasSubstr("materials.glow.radiance"));
}

// A scene file's own materials may name image files as maps; a file named twice is one texture,
// and a missing one or an unknown wrap is refused naming the field.
TEST(ParseScene, MaterialsNameImageFilesAsMaps) {
  auto scene_with = [](const std::string& maps) {
    return parse_scene(R"({
      "camera": {"position": [0, 1, -5], "look_at": [0, 1, 0], "fov": 45, "width": 8, "height": 8},
      "materials": {"logo": {"type": "diffuse", "albedo": [1, 1, 1], "radiance": [1, 1, 1], )" +
                           maps + R"(}},
      "shapes": [{"type": "quad", "material": "logo",
                  "vertices": [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]}]
    })",
                       scene_data("thirdparty/gltf2/BoxTextured"), "inline.json");
  };
  const absl::StatusOr<Scene> scene = scene_with(
      R"("color_map": "CesiumLogoFlat.png",
         "emission_map": {"file": "./CesiumLogoFlat.png", "wrap": "clamp"})");
  ASSERT_TRUE(scene.ok()) << scene.status();
  ASSERT_EQ(scene->textures.size(), 1u);
  EXPECT_EQ(scene->textures[0].name, "CesiumLogoFlat.png");
  ASSERT_NE(scene->textures[0].encoded, nullptr);
  EXPECT_EQ(scene->textures[0].encoded->substr(1, 3), "PNG");
  const Material& m = scene->materials.at(0);
  EXPECT_EQ(m.color_map.texture, 0u);
  EXPECT_EQ(m.color_map.wrap_u, TextureWrap::kRepeat);
  EXPECT_EQ(m.emission_map.texture, 0u);
  EXPECT_EQ(m.emission_map.wrap_u, TextureWrap::kClampToEdge);
  EXPECT_EQ(m.emission_map.wrap_v, TextureWrap::kClampToEdge);

  const absl::StatusOr<Scene> missing = scene_with(R"("color_map": "nope.png")");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(message_of(missing.status()), HasSubstr("materials.logo.color_map"));
  EXPECT_THAT(message_of(missing.status()), HasSubstr("nope.png"));
  const absl::StatusOr<Scene> wrap =
      scene_with(R"("color_map": {"file": "CesiumLogoFlat.png", "wrap": "tile"})");
  ASSERT_FALSE(wrap.ok());
  EXPECT_THAT(message_of(wrap.status()),
              HasSubstr("materials.logo.color_map.wrap: unknown wrap 'tile'"));
}

// A scene of one quad of material `name`, whose JSON is `material`, beside the Cesium box's
// texture (CesiumLogoFlat.png), lit by a point light.
absl::StatusOr<Scene> scene_beside_logo(const std::string& name, const std::string& material) {
  return parse_scene(R"({
    "camera": {"position": [0, 1, -5], "look_at": [0, 1, 0], "fov": 45, "width": 8, "height": 8},
    "materials": {")" + name + R"(": )" + material + R"(},
    "lights": [{"type": "point", "position": [0, 3, 0], "intensity": [1, 1, 1]}],
    "shapes": [{"type": "quad", "material": ")" + name + R"(",
                "vertices": [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]}]
  })",
                     scene_data("thirdparty/gltf2/BoxTextured"), "inline.json");
}

// A metallic-roughness material names its metalness and roughness map as the others name theirs;
// another kind has no such key.
TEST(ParseScene, AMetallicRoughnessMaterialNamesItsMap) {
  auto scene_with = [](const std::string& material) { return scene_beside_logo("steel", material); };
  const absl::StatusOr<Scene> scene = scene_with(
      R"({"type": "metallic_roughness", "metallic_roughness_map": "CesiumLogoFlat.png"})");
  ASSERT_TRUE(scene.ok()) << scene.status();
  ASSERT_EQ(scene->textures.size(), 1u);
  EXPECT_EQ(scene->materials.at(0).metallic_roughness_map.texture, 0u);
  const absl::StatusOr<Scene> diffuse = scene_with(
      R"({"type": "diffuse", "albedo": [1, 1, 1], "metallic_roughness_map": "CesiumLogoFlat.png"})");
  ASSERT_FALSE(diffuse.ok());
  EXPECT_THAT(message_of(diffuse.status()), HasSubstr("metallic_roughness_map"));
}

// Any material names a normal map and its scale; a scale that is no number of reason is refused
// by name.
TEST(ParseScene, AnyMaterialNamesANormalMap) {
  auto scene_with = [](const std::string& material) { return scene_beside_logo("bumpy", material); };
  const absl::StatusOr<Scene> scene = scene_with(
      R"({"type": "diffuse", "albedo": [1, 1, 1], "normal_map": "CesiumLogoFlat.png",
          "normal_scale": 0.5})");
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_EQ(scene->materials.at(0).normal_map.texture, 0u);
  EXPECT_EQ(scene->materials.at(0).normal_scale, 0.5f);
  const absl::StatusOr<Scene> huge = scene_with(
      R"({"type": "diffuse", "albedo": [1, 1, 1], "normal_map": "CesiumLogoFlat.png",
          "normal_scale": 1e9})");
  ASSERT_FALSE(huge.ok());
  EXPECT_THAT(message_of(huge.status()), HasSubstr("materials.bumpy.normal_scale"));
}

// Separate roughness and metalness maps, which are packed at upload, and a bump map with its
// scale; the packed map and the separate ones exclude each other, maps packed together must be
// read at the same coordinates, and a scale of no reason is refused, each by name.
TEST(ParseScene, SeparateMetallicRoughnessMapsAndBumpMaps) {
  auto scene_with = [](const std::string& material) { return scene_beside_logo("worn", material); };
  const absl::StatusOr<Scene> scene = scene_with(
      R"({"type": "metallic_roughness", "roughness_map": "CesiumLogoFlat.png",
          "metallic_map": "CesiumLogoFlat.png", "bump_map": "CesiumLogoFlat.png",
          "bump_scale": 4})");
  ASSERT_TRUE(scene.ok()) << scene.status();
  const Material& m = scene->materials.at(0);
  EXPECT_EQ(m.roughness_map.texture, 0u);
  EXPECT_EQ(m.metallic_map.texture, 0u);
  EXPECT_EQ(m.bump_map.texture, 0u);
  EXPECT_EQ(m.bump_scale, 4.0f);
  const std::pair<const char*, const char*> refused[] = {
      {R"({"type": "metallic_roughness", "roughness_map": "CesiumLogoFlat.png",
           "metallic_roughness_map": "CesiumLogoFlat.png"})",
       "materials.worn.roughness_map: excludes metallic_roughness_map"},
      {R"({"type": "metallic_roughness", "roughness_map": "CesiumLogoFlat.png",
           "metallic_map": {"file": "CesiumLogoFlat.png", "wrap": "clamp"}})",
       "materials.worn.metallic_map: wraps or transforms its coordinates unlike roughness_map"},
      {R"({"type": "diffuse", "albedo": [1, 1, 1], "bump_map": "CesiumLogoFlat.png",
           "bump_scale": 1e6})",
       "materials.worn.bump_scale"},
      {R"({"type": "diffuse", "albedo": [1, 1, 1], "roughness_map": "CesiumLogoFlat.png"})",
       "roughness_map"},
  };
  for (const auto& [material, message] : refused) {
    const absl::StatusOr<Scene> bad = scene_with(material);
    ASSERT_FALSE(bad.ok()) << material;
    EXPECT_THAT(message_of(bad.status()), HasSubstr(message));
  }
}

TEST(ParseScene, AnyMaterialMayBeCutOutOrBlended) {
  auto scene_with = [](const std::string& material) { return scene_beside_logo("leaf", material); };
  const absl::StatusOr<Scene> masked = scene_with(
      R"({"type": "diffuse", "albedo": [1, 1, 1], "alpha_mode": "mask", "alpha_cutoff": 0.25,
          "opacity_map": "CesiumLogoFlat.png"})");
  ASSERT_TRUE(masked.ok()) << masked.status();
  const Material& m = masked->materials.at(0);
  EXPECT_EQ(m.alpha_mode, AlphaMode::kMask);
  EXPECT_EQ(m.alpha_cutoff, 0.25f);
  EXPECT_EQ(m.opacity, 1.0f);
  EXPECT_EQ(m.opacity_map.texture, 0u);
  EXPECT_TRUE(m.has_cutouts());
  const absl::StatusOr<Scene> blended =
      scene_with(R"({"type": "mirror", "reflectance": [1, 1, 1], "alpha_mode": "blend",
                     "opacity": 0.3})");
  ASSERT_TRUE(blended.ok()) << blended.status();
  EXPECT_EQ(blended->materials.at(0).alpha_mode, AlphaMode::kBlend);
  EXPECT_EQ(blended->materials.at(0).opacity, 0.3f);
  // Opacity without a mode that applies it cuts nothing out.
  const absl::StatusOr<Scene> opaque =
      scene_with(R"({"type": "diffuse", "albedo": [1, 1, 1], "opacity": 0.3})");
  ASSERT_TRUE(opaque.ok()) << opaque.status();
  EXPECT_FALSE(opaque->materials.at(0).has_cutouts());
  for (const auto& [material, field] :
       {std::pair{R"({"type": "diffuse", "albedo": [1, 1, 1], "alpha_mode": "dither"})",
                  "materials.leaf.alpha_mode"},
        {R"({"type": "diffuse", "albedo": [1, 1, 1], "alpha_mode": "blend", "opacity": 1.5})",
         "materials.leaf.opacity"},
        {R"({"type": "diffuse", "albedo": [1, 1, 1], "alpha_mode": "mask", "alpha_cutoff": -1})",
         "materials.leaf.alpha_cutoff"},
        {R"({"type": "diffuse", "albedo": [1, 1, 1], "opacity_map": "missing.png"})",
         "materials.leaf.opacity_map"}}) {
    const absl::StatusOr<Scene> bad = scene_with(material);
    ASSERT_FALSE(bad.ok()) << material;
    EXPECT_THAT(message_of(bad.status()), HasSubstr(field));
  }
}

// A scene whose materials are `materials` (the text of the "materials" object), one quad of the
// first, lit by a point light.
absl::StatusOr<Scene> scene_with_materials(const std::string& materials, const std::string& first) {
  return parse_scene(absl::StrCat(R"({
    "camera": {"position": [0, 1, -5], "look_at": [0, 1, 0], "fov": 45, "width": 8, "height": 8},
    "materials": {)",
                                  materials, R"(},
    "lights": [{"type": "point", "position": [0, 3, 0], "intensity": [1, 1, 1]}],
    "shapes": [{"type": "quad", "material": ")",
                                  first, R"(",
                "vertices": [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]}]
  })"),
                     scene_data("good"), "inline.json");
}

TEST(ParseScene, MetallicRoughnessPhongAndRoughGlassKeepTheirValues) {
  const absl::StatusOr<Scene> scene = scene_with_materials(
      R"("steel": {"type": "metallic_roughness", "color": [0.9, 0.8, 0.7], "metallic": 1,
                   "roughness": 0.25},
         "plastic": {"type": "phong", "color": [0.5, 0.4, 0.3], "specular": [0.3, 0.25, 0.2],
                     "exponent": 50},
         "frosted": {"type": "dielectric", "ior": 1.4, "roughness": 0.3})",
      "steel");
  ASSERT_TRUE(scene.ok()) << scene.status();
  const Material* steel = find_material(*scene, "steel");
  ASSERT_NE(steel, nullptr);
  EXPECT_EQ(steel->type, MaterialType::kMetallicRoughness);
  EXPECT_THAT(steel->color, Vec3Near(Vec3f(0.9f, 0.8f, 0.7f), 0));
  EXPECT_EQ(steel->metallic, 1.0f);
  EXPECT_EQ(steel->roughness, 0.25f);
  const Material* plastic = find_material(*scene, "plastic");
  ASSERT_NE(plastic, nullptr);
  EXPECT_EQ(plastic->type, MaterialType::kPhong);
  EXPECT_THAT(plastic->color, Vec3Near(Vec3f(0.5f, 0.4f, 0.3f), 0));
  EXPECT_THAT(plastic->specular, Vec3Near(Vec3f(0.3f, 0.25f, 0.2f), 0));
  EXPECT_EQ(plastic->exponent, 50.0f);
  const Material* frosted = find_material(*scene, "frosted");
  ASSERT_NE(frosted, nullptr);
  EXPECT_EQ(frosted->type, MaterialType::kDielectric);
  EXPECT_EQ(frosted->ior, 1.4f);
  EXPECT_EQ(frosted->roughness, 0.3f);
}

TEST(ParseScene, MetallicRoughnessPhongAndGlassDefaults) {
  const absl::StatusOr<Scene> scene = scene_with_materials(
      R"("plain": {"type": "metallic_roughness"}, "phong": {"type": "phong"},
         "glass": {"type": "dielectric"})",
      "plain");
  ASSERT_TRUE(scene.ok()) << scene.status();
  const Material* plain = find_material(*scene, "plain");
  ASSERT_NE(plain, nullptr);
  EXPECT_EQ(plain->type, MaterialType::kMetallicRoughness);
  EXPECT_THAT(plain->color, Vec3Near(Vec3f(0.8f, 0.8f, 0.8f), 0));
  EXPECT_EQ(plain->metallic, 0.0f);
  EXPECT_EQ(plain->roughness, 0.5f);
  const Material* phong = find_material(*scene, "phong");
  ASSERT_NE(phong, nullptr);
  EXPECT_EQ(phong->type, MaterialType::kPhong);
  EXPECT_THAT(phong->color, Vec3Near(Vec3f(0.8f, 0.8f, 0.8f), 0));
  EXPECT_THAT(phong->specular, Vec3Near(Vec3f(0.2f, 0.2f, 0.2f), 0));
  EXPECT_EQ(phong->exponent, 20.0f);
  const Material* glass = find_material(*scene, "glass");
  ASSERT_NE(glass, nullptr);
  EXPECT_EQ(glass->roughness, 0.0f);  // smooth, as before roughness existed
}

// Each type takes its own keys only, typed as documented; the file and the field are named.
TEST(ParseScene, NewMaterialKeysAreCheckedPerType) {
  const auto error_of = [](const std::string& material) {
    const absl::StatusOr<Scene> scene = scene_with_materials(material, "m");
    EXPECT_FALSE(scene.ok()) << material;
    return scene.ok() ? std::string() : message_of(scene.status());
  };
  EXPECT_THAT(error_of(R"("m": {"type": "metallic_roughness", "exponent": 20})"),
              HasSubstr("inline.json: materials.m.exponent: unknown key"));
  EXPECT_THAT(error_of(R"("m": {"type": "phong", "metallic": 0.5})"),
              HasSubstr("materials.m.metallic: unknown key"));
  EXPECT_THAT(error_of(R"("m": {"type": "diffuse", "albedo": [1, 1, 1], "specular": [0, 0, 0]})"),
              HasSubstr("materials.m.specular: unknown key"));
  EXPECT_THAT(error_of(R"("m": {"type": "mirror", "reflectance": [1, 1, 1], "roughness": 0})"),
              HasSubstr("materials.m.roughness: unknown key"));
  EXPECT_THAT(error_of(R"("m": {"type": "metallic_roughness", "metallic": "high"})"),
              HasSubstr("materials.m.metallic: expected a number"));
  EXPECT_THAT(error_of(R"("m": {"type": "phong", "specular": 0.5})"),
              HasSubstr("materials.m.specular: expected [x, y, z]"));
  EXPECT_THAT(error_of(R"("m": {"type": "dielectric", "roughness": [0.1]})"),
              HasSubstr("materials.m.roughness: expected a number"));
  EXPECT_THAT(error_of(R"("m": {"type": "phong", "exponent": true})"),
              HasSubstr("materials.m.exponent: expected a number"));
  EXPECT_THAT(error_of(R"("m": {"type": "plastic"})"),
              HasSubstr("(expected diffuse, mirror, dielectric, emissive, metallic_roughness or "
                        "phong)"));
}

// An environment with an HDR map is a scene's light enough; its keys are checked and a map that
// cannot be read is named.
TEST(ParseScene, AnEnvironmentLightsTheScene) {
  const auto scene_with = [](const std::string& environment) {
    return parse_scene(R"({
      "camera": {"position": [0, 1, -5], "look_at": [0, 1, 0], "fov": 45, "width": 8, "height": 8},
      "materials": {"grey": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]}},
      "environment": )" + environment +
                           R"(,
      "shapes": [{"type": "quad", "material": "grey",
                  "vertices": [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]}]
    })",
                       std::filesystem::path(CAUSTICA_SCENES_DIR) / "damaged-helmet",
                       "inline.json");
  };
  const absl::StatusOr<Scene> scene =
      scene_with(R"({"map": "sunset.hdr", "intensity": 0.5, "rotation": 90})");
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_TRUE(scene->lights.empty());
  EXPECT_TRUE(scene->environment.present);
  ASSERT_EQ(scene->textures.size(), 1u);
  EXPECT_EQ(scene->textures[0].name, "sunset.hdr");
  EXPECT_EQ(scene->environment.texture, 0u);
  EXPECT_EQ(scene->environment.intensity, 0.5f);
  EXPECT_EQ(scene->environment.rotation_deg, 90.0f);
  EXPECT_EQ(scene->environment.color, Vec3f(1.0f));
  const absl::StatusOr<Scene> sky = scene_with(R"({"color": [0.2, 0.3, 0.5]})");
  ASSERT_TRUE(sky.ok()) << sky.status();
  EXPECT_EQ(sky->environment.texture, kNoTexture);
  EXPECT_EQ(sky->environment.color, Vec3f(0.2f, 0.3f, 0.5f));

  const auto error_of = [&](const std::string& environment) {
    const absl::StatusOr<Scene> refused = scene_with(environment);
    EXPECT_FALSE(refused.ok()) << environment;
    return refused.ok() ? std::string() : message_of(refused.status());
  };
  EXPECT_THAT(error_of(R"({"map": "sunset.hdr", "strength": 2})"),
              HasSubstr("environment.strength: unknown key"));
  EXPECT_THAT(error_of(R"({"intensity": -1})"), HasSubstr("environment.intensity"));
  EXPECT_THAT(error_of(R"({"color": [1, -1, 1]})"), HasSubstr("environment.color"));
  EXPECT_THAT(error_of(R"({"map": "no-such-sky.hdr"})"),
              AllOf(HasSubstr("environment.map"), HasSubstr("no-such-sky.hdr")));
  EXPECT_THAT(error_of(R"({"map": 7})"), HasSubstr("environment.map"));
}

}  // namespace
}  // namespace caustica
