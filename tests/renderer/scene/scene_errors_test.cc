// Every class of bad input fails with an error that names the file and the line or field.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "renderer/accel/structure_kind.h"
#include "renderer/scene/load_scene.h"
#include "tests/renderer/scene/scene_test_util.h"

namespace caustica {
namespace {

using ::caustica::testing::message_of;
using ::caustica::testing::scene_data;
using ::testing::HasSubstr;

// ------------------------------------------------------------------------------------------
// Bad files, through load_scene.

struct BadFile {
  const char* file;
  absl::StatusCode code;
  std::vector<std::string> expected;  // substrings besides the scene file's name
};

class BadSceneFileTest : public ::testing::TestWithParam<BadFile> {};

TEST_P(BadSceneFileTest, FailsNamingFileAndPlace) {
  const BadFile& bad = GetParam();
  const absl::StatusOr<Scene> scene = load_scene(scene_data(bad.file));
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.status().code(), bad.code) << scene.status();
  EXPECT_THAT(message_of(scene.status()), HasSubstr(bad.file));
  for (const std::string& part : bad.expected) {
    EXPECT_THAT(message_of(scene.status()), HasSubstr(part));
  }
}

constexpr absl::StatusCode kInvalid = absl::StatusCode::kInvalidArgument;
constexpr absl::StatusCode kNotFound = absl::StatusCode::kNotFound;

INSTANTIATE_TEST_SUITE_P(
    ErrorClasses, BadSceneFileTest,
    ::testing::Values(
        BadFile{"bad/does_not_exist.json", kNotFound, {"file not found"}},
        BadFile{"bad/syntax.json", kInvalid, {"syntax.json:4:52: JSON syntax error"}},
        BadFile{"bad/unknown_key.json", kInvalid, {"materials.white.roughness: unknown key"}},
        BadFile{"bad/missing_mesh.json", kNotFound, {"shapes[1].file", "nope.ply"}},
        BadFile{"bad/nan_mesh.json",
                kInvalid,
                {"shapes[0] (nan_vertex.ply)", "vertex 2", "not finite"}},
        BadFile{"bad/ply_index.json",
                kInvalid,
                {"shapes[1].file", "bad_index_ascii.ply:22: face 1: vertex index 9"}},
        BadFile{"bad/truncated_ply.json", kInvalid, {"shapes[0].file", "truncated.ply: at byte"}},
        BadFile{"bad/too_many_faces.json",
                kInvalid,
                {"shapes[0].file", "too_many_faces.ply:13", "exceed the limit"}},
        BadFile{"bad/obj_material.json",
                kInvalid,
                {"materials.negative_albedo.obj:dark.albedo", "negative"}},
        BadFile{"bad/zero_area_light.json",
                kInvalid,
                {"shapes[1] 'sliver'", "triangle 0 has zero area"}},
        BadFile{"bad/degenerate_camera.json", kInvalid, {"camera.look_at", "equals"}},
        BadFile{"bad/huge_image.json", kInvalid, {"camera.height", "20000"}},
        BadFile{"bad/empty.json", kInvalid, {"no triangles"}},
        BadFile{"bad/no_light.json", kInvalid, {"no light"}}));

// ------------------------------------------------------------------------------------------
// One edit each to a valid scene, through parse_scene.

constexpr char kFloor[] =
    R"({"type": "quad", "material": "white", "vertices": [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]})";
constexpr char kLamp[] =
    R"({"type": "quad", "material": "lamp", "vertices": [[-0.1, 2, -0.1], [0.1, 2, -0.1], [0.1, 2, 0.1], [-0.1, 2, 0.1]]})";
constexpr char kPointLight[] =
    R"({"type": "point", "position": [0, 3, 0], "intensity": [10, 10, 10]})";

std::string base_scene() {
  return absl::StrCat(R"({
  "camera": {"position": [0, 1, -5], "look_at": [0, 1, 0], "up": [0, 1, 0], "fov": 45, "width": 64, "height": 48},
  "settings": {"photons": 1000, "k": 16, "max_depth": 6, "passes": 1},
  "materials": {
    "white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]},
    "lamp": {"type": "emissive", "radiance": [1, 1, 1]}
  },
  "lights": [)",
                      kPointLight, R"(],
  "shapes": [
    )",
                      kFloor, ",\n    ", kLamp, R"(
  ]
})");
}

struct Edit {
  std::string name;
  std::vector<std::pair<std::string, std::string>> replacements;
  std::vector<std::string> expected;  // substrings besides the source name
};

void PrintTo(const Edit& edit, std::ostream* os) { *os << edit.name; }

std::vector<Edit> edits() {
  const std::string floor = kFloor, lamp = kLamp, point = kPointLight;
  const std::string shapes =
      absl::StrCat(R"("shapes": [)", "\n    ", floor, ",\n    ", lamp, "\n  ]");
  auto add_shape = [&](const std::string& shape) {
    return std::pair<std::string, std::string>{lamp, absl::StrCat(lamp, ",\n    ", shape)};
  };
  auto set_light = [&](const std::string& light) {
    return std::pair<std::string, std::string>{point, light};
  };
  auto set_settings = [](const std::string& settings) {
    return std::pair<std::string, std::string>{
        R"("settings": {"photons": 1000, "k": 16, "max_depth": 6, "passes": 1})",
        absl::StrCat(R"("settings": )", settings)};
  };
  const std::string mesh_dir = "../meshes/";
  // Media go before the lights; `fog` is a valid one.
  const std::string fog =
      R"("fog": {"type": "homogeneous", "absorption": [0.1, 0.1, 0.1], "scattering": [0.2, 0.2, 0.2], "g": 0.3})";
  auto add_media = [](const std::string& media) {
    return std::pair<std::string, std::string>{
        R"("lights": [)", absl::StrCat(R"("media": {)", media, "},\n  ", R"("lights": [)")};
  };
  // A closed tetrahedron (faces wound outwards) around the given fourth face.
  auto tetrahedron = [](const std::string& last_face) {
    return absl::StrCat(
        R"({"type": "triangles", "material": "white", "medium": "fog", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], "indices": [0, 2, 1, 0, 1, 3, 0, 3, 2, )",
        last_face, "]}");
  };
  return {
      // Syntax and types.
      {"MissingComma", {{R"("fov": 45,)", R"("fov": 45)"}}, {"inline.json:2:", "syntax error"}},
      {"MalformedNumber", {{R"("fov": 45)", R"("fov": 4.5.1)"}}, {"inline.json:2:"}},
      {"TrailingGarbage", {{"\n}", "\n}}"}}, {"inline.json:13:2:"}},
      {"EmptyText", {{base_scene(), ""}}, {"inline.json:1:1:"}},
      {"TopLevelNotObject", {{base_scene(), "[1, 2]"}}, {"top level: expected an object"}},
      {"StringForInteger",
       {{R"("width": 64)", R"("width": "64")"}},
       {"camera.width: expected an integer", "string \"64\""}},
      {"FractionalInteger", {{R"("width": 64)", R"("width": 64.5)"}}, {"camera.width"}},
      {"NegativeCount",
       {{R"("photons": 1000)", R"("photons": -1)"}},
       {"settings.photons: expected an integer in [0, 4294967295]"}},
      {"FloatOverflow",
       {{"[0, 3, 0]", "[0, 3e39, 0]"}},
       {"lights[0].position[1]: 3e+39 does not fit a 32-bit float"}},
      {"ShortVector", {{"[0, 3, 0]", "[0, 3]"}}, {"lights[0].position: expected [x, y, z]"}},
      {"StringInVector",
       {{"[0, 3, 0]", R"([0, "3", 0])"}},
       {"lights[0].position[1]: expected a number"}},
      {"ShapesNotArray", {{shapes, R"("shapes": 5)"}}, {"shapes: expected an array"}},
      {"MissingCamera", {{R"("camera")", R"("kamera")"}}, {"camera: is required but missing"}},
      {"MissingRequiredField", {{R"(, "fov": 45)", ""}}, {"camera.fov: is required"}},
      // Unknown keys and names.
      {"UnknownTopLevelKey", {{R"("settings")", R"("setings")"}}, {"setings: unknown key"}},
      {"UnknownCameraKey", {{R"("up")", R"("upp")"}}, {"camera.upp: unknown key"}},
      {"UnknownMaterialKey",
       {{R"("albedo": [0.5, 0.5, 0.5]})", R"("albedo": [0.5, 0.5, 0.5], "ior": 1.5})"}},
       {"materials.white.ior: unknown key", "known keys here: type, albedo"}},
      {"UnknownShapeKey",
       {{R"("material": "lamp")", R"("material": "lamp", "colour": 1)"}},
       {"shapes[1].colour: unknown key"}},
      {"UnknownMaterialName",
       {{R"("material": "white")", R"("material": "whte")"}},
       {"shapes[0].material: unknown material 'whte'"}},
      {"UnknownMaterialType",
       {{R"("type": "diffuse")", R"("type": "plastic")"}},
       {"materials.white.type: unknown material type 'plastic'"}},
      {"UnknownShapeType",
       {{R"("type": "quad", "material": "white")", R"("type": "cube", "material": "white")"}},
       {"shapes[0].type: unknown shape type 'cube'"}},
      {"UnknownLightType",
       {{R"("type": "point")", R"("type": "area")"}},
       {"lights[0].type: unknown light type 'area'"}},
      {"UnknownKernel",
       {set_settings(R"({"kernel": "gauss"})")},
       {"settings.kernel: unknown kernel"}},
      {"UnknownIntegrator",
       {set_settings(R"({"integrator": "bdpt"})")},
       {"settings.integrator: unknown integrator 'bdpt' (expected photon or path)"}},
      {"UnknownEstimator",
       {set_settings(R"({"estimator": "vcm"})")},
       {"settings.estimator: unknown estimator 'vcm' (expected knn, sppm or vkde)"}},
      {"UnknownSppmRadius",
       {set_settings(R"({"sppm_radius": "local"})")},
       {"settings.sppm_radius: unknown radius rule 'local' (expected pixel or global)"}},
      {"VkdeSpreadOutOfRange",
       {set_settings(R"({"vkde_spread": -1})")},
       {"settings.vkde_spread: -1 is not a spread factor in [0, 100] (0: automatic)"}},
      {"FinalGatherNotABool",
       {set_settings(R"({"final_gather": 1})")},
       {"settings.final_gather: expected true or false, got"}},
      {"FinalGatherRaysOutOfRange",
       {set_settings(R"({"final_gather_rays": 0})")},
       {"settings.final_gather_rays: 0 is outside [1, 4096]"}},
      {"SppmAlphaOutOfRange",
       {set_settings(R"({"sppm_alpha": 1.0})")},
       {"settings.sppm_alpha: 1 is not a number between 0 and 1 (exclusive)"}},
      {"UnknownStructure",
       {set_settings(R"({"structure": "kd-tree"})")},
       {"settings.structure: unknown structure 'kd-tree'",
        "(expected " + structure_kind_list() + ")"}},
      {"StructureNotString",
       {set_settings(R"({"structure": 1})")},
       {"settings.structure: expected a string"}},
      {"BuildStagesOutOfOrder",
       {set_settings(R"({"build": {"binned_sah_stages": "256:16,4096:32"}})")},
       {"settings.build.binned_sah_stages: stage 2 ('4096:32'): ABOVE must be below the previous "
        "stage's 256"}},
      {"BuildStagesTooManyBins",
       {set_settings(R"({"build": {"binned_sah_stages": "4096:256"}})")},
       {"settings.build.binned_sah_stages: stage 1 ('4096:256'): BINS must be within [2, 128]"}},
      {"BuildUnknownReorder",
       {set_settings(R"({"build": {"binned_sah_reorder": "bucket"}})")},
       {"settings.build.binned_sah_reorder: unknown binned-sah reorder 'bucket' (expected sort or "
        "split)"}},
      {"BuildUnknownTraversal",
       {set_settings(R"({"build": {"kd_traversal": "rope"}})")},
       {"settings.build.kd_traversal: unknown kd-tree traversal 'rope' (expected stack or "
        "stackless)"}},
      {"BuildUnknownRefit",
       {set_settings(R"({"build": {"refit": "sometimes"}})")},
       {"settings.build.refit: unknown refit policy 'sometimes' (expected auto, always or "
        "never)"}},
      {"BuildRefitBoundBelowOne",
       {set_settings(R"({"build": {"refit_sah_bound": 0.9}})")},
       {"settings.build.refit_sah_bound: must be within [1, 1000]"}},
      {"BuildUnknownKey",
       {set_settings(R"({"build": {"stages": "64:16"}})")},
       {"settings.build", "stages"}},
      {"BuildNotAnObject",
       {set_settings(R"({"build": "64:16"})")},
       {"settings.build: expected an object"}},
      // Geometry.
      {"IndexOutOfRange",
       {{floor,
         R"({"type": "triangles", "material": "white", "vertices": [[0, 0, 0], [1, 0, 0], [0, 0, 1]], "indices": [0, 1, 3]})"}},
       {"shapes[0].indices[2]: vertex index 3 is out of range (there are 3 vertices)"}},
      {"NegativeIndex",
       {{floor,
         R"({"type": "triangles", "material": "white", "vertices": [[0, 0, 0], [1, 0, 0], [0, 0, 1]], "indices": [0, -1, 2]})"}},
       {"shapes[0].indices[1]"}},
      {"IndicesNotTriples",
       {{floor,
         R"({"type": "triangles", "material": "white", "vertices": [[0, 0, 0], [1, 0, 0], [0, 0, 1]], "indices": [0, 1]})"}},
       {"shapes[0].indices: 2 indices is not a multiple of 3"}},
      {"QuadWithThreeVertices", {{", [1, 0, -1]]}", "]}"}}, {"shapes[0].vertices: a quad needs 4"}},
      {"ZeroRadiusSphere",
       {add_shape(R"({"type": "sphere", "material": "white", "center": [0, 0, 0], "radius": 0})")},
       {"shapes[2].radius: must be > 0"}},
      {"TooFewRings",
       {add_shape(
           R"({"type": "sphere", "material": "white", "center": [0, 0, 0], "radius": 1, "rings": 1})")},
       {"shapes[2].rings: expected an integer in [2, "}},
      {"AbsurdTessellation",
       {add_shape(
           R"({"type": "sphere", "material": "white", "center": [0, 0, 0], "radius": 1, "rings": 1000000, "segments": 1000000})")},
       {"shapes[2]: tessellation gives", "more than the limit"}},
      {"NegativeRingThickness",
       {add_shape(
           R"({"type": "ring", "material": "white", "center": [0, 0, 0], "radius": 1, "thickness": -1, "height": 1})")},
       {"shapes[2].thickness: must be > 0"}},
      // Mesh files.
      {"MeshWithoutMaterial",
       {add_shape(R"({"type": "mesh", "file": "../meshes/quad_tri_le.ply"})")},
       {"shapes[2].material: is required", "quad_tri_le.ply has triangles without a material"}},
      {"UnsupportedMeshFormat",
       {add_shape(R"({"type": "mesh", "file": "model.notamesh", "material": "white"})")},
       {"shapes[2].file", "model.notamesh", "unsupported mesh format '.notamesh'"}},
      // .stl goes to Assimp, which is not asked to open a file that is not there.
      {"MissingAssimpFile",
       {add_shape(R"({"type": "mesh", "file": "model.stl", "material": "white"})")},
       {"shapes[2].file", "model.stl: file not found"}},
      // A name longer than the file system takes: an error, where it used to throw
      // std::filesystem's exception out of the OBJ and glTF loaders (found by fuzzing).
      {"ObjNameTooLong",
       {add_shape(R"({"type": "mesh", "file": ")" + std::string(300, 'n') +
                  R"(.obj", "material": "white"})")},
       {"shapes[2].file", "File name too long"}},
      {"GltfNameTooLong",
       {add_shape(R"({"type": "mesh", "file": ")" + std::string(300, 'n') +
                  R"(.gltf", "material": "white"})")},
       {"shapes[2].file", "File name too long"}},
      {"PlyNameTooLong",
       {add_shape(R"({"type": "mesh", "file": ")" + std::string(300, 'n') +
                  R"(.ply", "material": "white"})")},
       {"shapes[2].file", "File name too long"}},
      {"ZeroScale",
       {add_shape(
           R"({"type": "mesh", "file": "../meshes/quad_tri_le.ply", "material": "white", "transform": {"scale": [1, 0, 1]}})")},
       {"shapes[2].transform.scale: must not be zero"}},
      {"UnknownTransformKey",
       {add_shape(
           R"({"type": "mesh", "file": "../meshes/quad_tri_le.ply", "material": "white", "transform": {"rotation": [0, 1, 0]}})")},
       {"shapes[2].transform.rotation: unknown key"}},
      {"NanInMeshFile",
       {add_shape(R"({"type": "mesh", "file": "../bad/nan_vertex.ply", "material": "white"})")},
       {"mesh shapes[2] (nan_vertex.ply): vertex 2 position (nan, 1, 0) is not finite"}},
      {"GltfAccessorOverflow",
       {add_shape(R"({"type": "mesh", "file": "../bad/overflowing_accessor.gltf"})")},
       {"shapes[2].file", "overflowing_accessor.gltf", "run past the end"}},
      {"CorruptGzip",
       {add_shape(R"({"type": "mesh", "file": "../bad/corrupt.ply.gz", "material": "white"})")},
       {"shapes[2].file", "corrupt.ply.gz", "gzip"}},
      // Colours and lights.
      {"NegativeAlbedo",
       {{"[0.5, 0.5, 0.5]}", "[0.5, -0.5, 0.5]}"}},
       {"materials.white.albedo: (0.5, -0.5, 0.5) has a negative channel"}},
      {"AlbedoAboveOne",
       {{"[0.5, 0.5, 0.5]}", "[0.5, 1.5, 0.5]}"}},
       {"materials.white.albedo", "above 1"}},
      {"MetallicAboveOne",
       {{R"({"type": "diffuse", "albedo": [0.5, 0.5, 0.5]})",
         R"({"type": "metallic_roughness", "metallic": 1.5})"}},
       {"materials.white.metallic: 1.5 is not a number in [0, 1]"}},
      {"NegativeGlassRoughness",
       {{R"({"type": "diffuse", "albedo": [0.5, 0.5, 0.5]})",
         R"({"type": "dielectric", "roughness": -0.25})"}},
       {"materials.white.roughness: -0.25 is not a number in [0, 1]"}},
      {"PhongReflectingMoreThanArrives",
       {{R"({"type": "diffuse", "albedo": [0.5, 0.5, 0.5]})",
         R"({"type": "phong", "color": [0.5, 0.75, 0.5], "specular": [0.5, 0.5, 0.25]})"}},
       {"materials.white.specular: color + specular = (1, 1.25, 0.75) has a channel above 1"}},
      {"PhongExponentZero",
       {{R"({"type": "diffuse", "albedo": [0.5, 0.5, 0.5]})",
         R"({"type": "phong", "exponent": 0})"}},
       {"materials.white.exponent: 0 is not a number in (0, 1e+06]"}},
      {"NegativeRadiance",
       {{"[1, 1, 1]}", "[1, -1, 1]}"}},
       {"materials.lamp.radiance", "negative"}},
      {"NegativeIntensity",
       {{"[10, 10, 10]", "[10, -10, 10]"}},
       {"lights[0].intensity: (10, -10, 10) has a negative channel"}},
      {"NegativeIrradiance",
       {set_light(R"({"type": "directional", "direction": [0, -1, 0], "irradiance": [-1, 0, 0]})")},
       {"lights[0].irradiance"}},
      {"ZeroAreaEmitter",
       {{lamp,
         R"({"type": "quad", "material": "lamp", "vertices": [[0, 2, 0], [1, 2, 0], [2, 2, 0], [3, 2, 0]]})"}},
       {"mesh shapes[1]: triangle 0 has zero area but emits light"}},
      {"NegativeSpotAngle",
       {set_light(
           R"({"type": "spot", "position": [0, 3, 0], "direction": [0, -1, 0], "intensity": [1, 1, 1], "inner_angle": -10, "outer_angle": -5})")},
       {"lights[0].outer_angle: -5 degrees is outside (0, 180]"}},
      {"InnerWiderThanOuter",
       {set_light(
           R"({"type": "spot", "position": [0, 3, 0], "direction": [0, -1, 0], "intensity": [1, 1, 1], "inner_angle": 40, "outer_angle": 30})")},
       {"lights[0].inner_angle"}},
      {"ZeroDirection",
       {set_light(
           R"({"type": "directional", "name": "sun", "direction": [0, 0, 0], "irradiance": [1, 1, 1]})")},
       {"lights[0] ('sun').direction"}},
      // Camera.
      {"LookAtEqualsPosition",
       {{R"("look_at": [0, 1, 0])", R"("look_at": [0, 1, -5])"}},
       {"camera.look_at: equals camera.position"}},
      {"UpAlongView",
       {{R"("up": [0, 1, 0])", R"("up": [0, 0, 2])"}},
       {"camera.up: (0, 0, 2) is parallel to the view direction"}},
      {"ZeroUp", {{R"("up": [0, 1, 0])", R"("up": [0, 0, 0])"}}, {"camera.up: is the zero vector"}},
      {"FovZero", {{R"("fov": 45)", R"("fov": 0)"}}, {"camera.fov: 0 degrees is outside (0, 180)"}},
      {"Fov180", {{R"("fov": 45)", R"("fov": 180)"}}, {"camera.fov"}},
      {"WidthZero",
       {{R"("width": 64)", R"("width": 0)"}},
       {"camera.width: 0 is outside [1, 16384]"}},
      {"WidthHuge", {{R"("width": 64)", R"("width": 16385)"}}, {"camera.width: 16385"}},
      {"HeightZero", {{R"("height": 48)", R"("height": 0)"}}, {"camera.height"}},
      // Settings.
      {"PhotonsZero",
       {{R"("photons": 1000)", R"("photons": 0)"}},
       {"settings.photons: 0 is outside"}},
      {"PhotonsHuge", {{R"("photons": 1000)", R"("photons": 100000001)"}}, {"settings.photons"}},
      {"KZero", {{R"("k": 16)", R"("k": 0)"}}, {"settings.k: 0 is outside [1, 1024]"}},
      {"KHuge", {{R"("k": 16)", R"("k": 1025)"}}, {"settings.k"}},
      {"DepthHuge", {{R"("max_depth": 6)", R"("max_depth": 65)"}}, {"settings.max_depth: 65"}},
      {"PassesZero", {{R"("passes": 1)", R"("passes": 0)"}}, {"settings.passes"}},
      {"PassesHuge", {{R"("passes": 1)", R"("passes": 100001)"}}, {"settings.passes: 100001"}},
      {"NegativeRadius", {set_settings(R"({"max_radius": -1})")}, {"settings.max_radius"}},
      {"BouncesHuge",
       {set_settings(R"({"max_photon_bounces": 1000})")},
       {"settings.max_photon_bounces"}},
      // Media.
      {"NegativeAbsorption",
       {add_media(
           R"("fog": {"type": "homogeneous", "absorption": [0.1, -0.1, 0.1], "scattering": [0.2, 0.2, 0.2]})")},
       {"media.fog.absorption: (0.1, -0.1, 0.1) has a negative channel"}},
      {"NegativeScattering",
       {add_media(
           R"("fog": {"type": "homogeneous", "absorption": [0, 0, 0], "scattering": [0.2, 0.2, -1]})")},
       {"media.fog.scattering: (0.2, 0.2, -1) has a negative channel"}},
      {"NanScattering",
       {add_media(
           R"("fog": {"type": "homogeneous", "absorption": [0, 0, 0], "scattering": [0.2, 3e39, 0]})")},
       {"media.fog.scattering[1]: 3e+39 does not fit a 32-bit float"}},
      {"AsymmetryOfOne",
       {add_media(
           R"("fog": {"type": "homogeneous", "absorption": [0, 0, 0], "scattering": [1, 1, 1], "g": 1})")},
       {"media.fog.g: 1 is outside (-1, 1)"}},
      {"AsymmetryBelowMinusOne",
       {add_media(
           R"("fog": {"type": "homogeneous", "absorption": [0, 0, 0], "scattering": [1, 1, 1], "g": -1.5})")},
       {"media.fog.g: -1.5 is outside (-1, 1)"}},
      {"MissingScattering",
       {add_media(R"("fog": {"type": "homogeneous", "absorption": [0, 0, 0]})")},
       {"media.fog.scattering: is required"}},
      {"UnknownMediumType",
       {add_media(R"("fog": {"type": "smoke", "absorption": [0, 0, 0], "scattering": [1, 1, 1]})")},
       {"media.fog.type: unknown medium type 'smoke' (expected homogeneous or grid)"}},
      {"GridWithoutFile",
       {add_media(R"("fog": {"type": "grid", "absorption": [0, 0, 0], "scattering": [1, 1, 1]})")},
       {"media.fog.file: is required"}},
      {"MissingGridFile",
       {add_media(
           R"("fog": {"type": "grid", "file": "no-such.nvdb", "absorption": [0, 0, 0], "scattering": [1, 1, 1]})")},
       {"media.fog.file (", "no-such.nvdb): file not found"}},
      {"GridKeyOnAHomogeneousMedium",
       {add_media(
           R"("fog": {"type": "homogeneous", "file": "a.nvdb", "absorption": [0, 0, 0], "scattering": [1, 1, 1]})")},
       {"media.fog.file: unknown key"}},
      {"UnknownMediumKey",
       {add_media(
           R"("fog": {"type": "homogeneous", "absorption": [0, 0, 0], "scattering": [1, 1, 1], "density": 2})")},
       {"media.fog.density: unknown key"}},
      {"UnknownSceneMedium",
       {add_media(fog), {R"("lights": [)", R"("medium": "smoke", "lights": [)"}},
       {"medium: unknown medium 'smoke' (not in media)"}},
      {"UnknownShapeMedium",
       {add_media(fog), {R"("material": "white")", R"("material": "white", "medium": "smoke")"}},
       {"shapes[0].medium: unknown medium 'smoke' (not in media)"}},
      {"OpenMediumMesh",
       {add_media(fog), {R"("material": "white")", R"("material": "white", "medium": "fog")"}},
       {"mesh shapes[0]: encloses medium 'fog' but is not closed: the edge from",
        "borders one triangle"}},
      {"MediumMeshWoundBothWays",
       {add_media(fog), add_shape(tetrahedron("1, 3, 2"))},
       {"mesh shapes[2]: encloses medium 'fog' but the edge from",
        "joins two triangles facing opposite ways"}},
      {"MediumMeshWithAFin",
       {add_media(fog), add_shape(tetrahedron("1, 2, 3, 1, 2, 3"))},
       {"mesh shapes[2]: encloses medium 'fog' but the edge from", "borders 3 triangles, not two"}},
      // Whole scene.
      {"NoTriangles", {{absl::StrCat(floor, ",\n    ", lamp), ""}}, {"scene has no triangles"}},
      {"NoLight", {{point, ""}, {absl::StrCat(",\n    ", lamp), ""}}, {"scene has no light"}},
  };
}

class BadSceneEditTest : public ::testing::TestWithParam<Edit> {};

TEST_P(BadSceneEditTest, FailsNamingSourceAndField) {
  const Edit& edit = GetParam();
  std::string text = base_scene();
  for (const auto& [from, to] : edit.replacements) {
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << "edit does not apply: " << from;
    text.replace(at, from.size(), to);
  }
  const absl::StatusOr<Scene> scene = parse_scene(text, scene_data("good"), "inline.json");
  ASSERT_FALSE(scene.ok()) << text;
  EXPECT_THAT(message_of(scene.status()), HasSubstr("inline.json"));
  for (const std::string& part : edit.expected) {
    EXPECT_THAT(message_of(scene.status()), HasSubstr(part));
  }
}

INSTANTIATE_TEST_SUITE_P(ErrorClasses, BadSceneEditTest, ::testing::ValuesIn(edits()),
                         [](const ::testing::TestParamInfo<Edit>& info) {
                           return info.param.name;
                         });

// A closed mesh may enclose a medium, and the scene may be filled with one: both are read.
TEST(SceneMedia, AreReadIntoTheScene) {
  std::string text = base_scene();
  text.replace(
      text.find(R"("lights": [)"), 11,
      R"("media": {"fog": {"type": "homogeneous", "absorption": [0.1, 0.2, 0.3], "scattering": [0.4, 0.5, 0.6], "g": -0.25},
             "mist": {"type": "homogeneous", "absorption": [0, 0, 0], "scattering": [0.01, 0.01, 0.01]}},
  "medium": "mist",
  "lights": [)");
  text.replace(
      text.find(kLamp), std::string(kLamp).size(),
      absl::StrCat(
          kLamp,
          R"(, {"type": "sphere", "material": "white", "medium": "fog", "center": [0, 1, 0], "radius": 0.5})"));
  const absl::StatusOr<Scene> scene = parse_scene(text, scene_data("good"), "inline.json");
  ASSERT_TRUE(scene.ok()) << scene.status();
  ASSERT_EQ(scene->media.size(), 2u);
  EXPECT_EQ(scene->media[0].name, "fog");
  EXPECT_EQ(scene->media[0].type, MediumType::kHomogeneous);
  EXPECT_EQ(scene->media[0].absorption, Vec3f(0.1f, 0.2f, 0.3f));
  EXPECT_EQ(scene->media[0].scattering, Vec3f(0.4f, 0.5f, 0.6f));
  EXPECT_EQ(scene->media[0].asymmetry, -0.25f);
  EXPECT_EQ(scene->media[1].asymmetry, 0.0f);
  EXPECT_EQ(scene->medium, 1u);
  ASSERT_EQ(scene->meshes.size(), 3u);
  EXPECT_EQ(scene->meshes[0].interior_medium, kNoMedium);
  EXPECT_EQ(scene->meshes[2].interior_medium, 0u);
}

TEST(BadSceneEdit, BaseSceneIsValid) {
  const absl::StatusOr<Scene> scene = parse_scene(base_scene(), scene_data("good"), "inline.json");
  EXPECT_TRUE(scene.ok()) << scene.status();
}

}  // namespace
}  // namespace caustica
