// Meshes moved and reshaped on a loaded scene (Engine::set_geometry): the image is bit for bit the
// one of the scene uploaded that way, for a rigid transform, replaced vertices and both; a
// transform places the mesh as uploaded, not where the last one left it; a refused change names
// its field and changes nothing.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "renderer/scene/emitters.h"
#include "renderer/scene/scene_json.h"
#include "renderer/scene/transform.h"
#include "tests/renderer/render/analytic_scenes.h"

namespace caustica {
namespace {

// The bundled caustics box, small: its glass sphere focuses the light, so that moving it moves
// the caustic as well as the sphere (photons and structure both follow).
Scene caustics_box() {
  absl::StatusOr<Scene> scene =
      load_scene(std::filesystem::path(CAUSTICA_SCENES_DIR) / "cornell-caustics" / "scene.json");
  EXPECT_TRUE(scene.ok()) << scene.status();
  scene->camera.width = scene->camera.height = 48;
  scene->settings.photons_per_pass = 20000;
  return *scene;
}

const std::string kSphere = "shapes[6] 'glass sphere'";

size_t mesh_index(const Scene& scene, const std::string& name) {
  for (size_t i = 0; i < scene.meshes.size(); ++i)
    if (scene.meshes[i].name == name) return i;
  ADD_FAILURE() << "no mesh " << name;
  return 0;
}

std::vector<float> rendered(Engine& engine, uint32_t passes = 2) {
  EXPECT_TRUE(engine.render(passes).ok());
  const std::span<const float> image = engine.image_linear();
  return {image.begin(), image.end()};
}

// The same scene uploaded with `change` applied by the scene's own transform_mesh.
std::vector<float> uploaded_moved(Scene scene, const std::string& name, const Affine* transform,
                                  const std::vector<Vec3f>* positions) {
  Mesh& mesh = scene.meshes[mesh_index(scene, name)];
  if (positions != nullptr) {
    mesh.positions = *positions;
    mesh.normals.clear();
    mesh.tangents.clear();
  }
  if (transform != nullptr) transform_mesh(*transform, &mesh);
  auto engine = engine_with(scene);
  return rendered(*engine);
}

TEST(MovingGeometry, ATransformedMeshRendersAsTheSceneUploadedMoved) {
  const Scene scene = caustics_box();
  const Affine moved =
      translation(Vec3f(-60, 20, 40)) * rotation_y_deg(30) * scaling(Vec3f(0.8f, 0.8f, 0.8f));
  auto engine = engine_with(scene);
  const std::vector<float> before = rendered(*engine);
  const MeshChange change{kSphere, moved, std::nullopt, std::nullopt};
  absl::StatusOr<RebuildReport> report = engine->set_geometry({&change, 1});
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_EQ(report->rebuilt, (std::vector<std::string>{"geometry", "structure_refit", "lights",
                                                       "film", "photon_maps"}));
  EXPECT_EQ(report->epochs.geometry, 2u);
  EXPECT_EQ(report->epochs.lights, 2u);
  EXPECT_GT(report->photons_emitted, 0u);
  const std::vector<float> after = rendered(*engine);
  EXPECT_EQ(after, uploaded_moved(scene, kSphere, &moved, nullptr));
  EXPECT_NE(after, before);
}

// A second transform replaces the first: it places the mesh as uploaded.
TEST(MovingGeometry, ATransformPlacesTheMeshAsUploaded) {
  const Scene scene = caustics_box();
  const Affine first = translation(Vec3f(100, 0, 0)), second = translation(Vec3f(-50, 30, 0));
  auto engine = engine_with(scene);
  for (const Affine& t : {first, second}) {
    const MeshChange change{kSphere, t, std::nullopt, std::nullopt};
    ASSERT_TRUE(engine->set_geometry({&change, 1}).ok());
  }
  EXPECT_EQ(rendered(*engine), uploaded_moved(scene, kSphere, &second, nullptr));
}

// New vertices (the sphere squashed) under a transform: as uploading the squashed sphere moved.
TEST(MovingGeometry, ReplacedVerticesRenderAsTheSceneUploadedWithThem) {
  const Scene scene = caustics_box();
  const Mesh& sphere = scene.meshes[mesh_index(scene, kSphere)];
  std::vector<Vec3f> squashed = sphere.positions;
  const Vec3f centre = [&] {
    Vec3f sum(0.0f);
    for (const Vec3f& p : squashed) sum += p;
    return sum / float(squashed.size());
  }();
  for (Vec3f& p : squashed) p.y = centre.y + 0.5f * (p.y - centre.y);
  const Affine moved = translation(Vec3f(0, -40, 0));
  auto engine = engine_with(scene);
  const MeshChange change{kSphere, moved, squashed, std::nullopt};
  ASSERT_TRUE(engine->set_geometry({&change, 1}).ok());
  EXPECT_EQ(rendered(*engine), uploaded_moved(scene, kSphere, &moved, &squashed));
}

// Each refused change names its field, and the engine renders as it did.
TEST(MovingGeometry, ARefusedChangeNamesItsFieldAndChangesNothing) {
  const Scene scene = caustics_box();
  auto engine = engine_with(scene);
  const std::vector<float> before = rendered(*engine);
  const Epochs epochs = engine->epochs();
  const size_t vertices = scene.meshes[mesh_index(scene, kSphere)].positions.size();
  std::vector<Vec3f> nan_vertex(vertices, Vec3f(1.0f));
  nan_vertex[7].y = std::numeric_limits<float>::quiet_NaN();
  const struct {
    MeshChange change;
    absl::StatusCode code;
    const char* message;
  } refused[] = {
      {{"shapes[6] 'no such sphere'", Affine(), std::nullopt, std::nullopt},
       absl::StatusCode::kNotFound,
       "meshes[1].mesh: the scene has no mesh named"},
      {{kSphere, scaling(Vec3f(1, 0, 1)), std::nullopt, std::nullopt},
       absl::StatusCode::kInvalidArgument,
       "meshes[1].transform: is not an invertible map of finite numbers"},
      {{kSphere, std::nullopt, std::vector<Vec3f>(3, Vec3f(0.0f)), std::nullopt},
       absl::StatusCode::kInvalidArgument,
       "meshes[1].positions: 3 vertices, but the mesh has"},
      {{kSphere, std::nullopt, nan_vertex, std::nullopt},
       absl::StatusCode::kInvalidArgument,
       "meshes[1].positions[7]: (1, nan, 1) is not finite"},
      {{kSphere, std::nullopt, std::nullopt, std::vector<Vec3f>(vertices + 1, Vec3f(0, 1, 0))},
       absl::StatusCode::kInvalidArgument,
       "meshes[1].normals:"},
  };
  for (const auto& [change, code, message] : refused) {
    // A valid change first: all or nothing, it must not be applied either.
    const MeshChange both[] = {{kSphere, translation(Vec3f(10, 0, 0)), std::nullopt, std::nullopt},
                               change};
    const absl::StatusOr<RebuildReport> report = engine->set_geometry(both);
    ASSERT_FALSE(report.ok()) << message;
    EXPECT_EQ(report.status().code(), code) << report.status();
    EXPECT_THAT(std::string(report.status().message()), ::testing::HasSubstr(message));
  }
  EXPECT_EQ(engine->epochs().geometry, epochs.geometry);
  EXPECT_EQ(engine->epochs().lights, epochs.lights);
  auto fresh = engine_with(scene);
  EXPECT_EQ(rendered(*fresh), before);
  ASSERT_TRUE(engine->set_camera(scene.camera).ok());  // restarts the film
  EXPECT_EQ(rendered(*engine), before);
}

// Moving the light's own quad moves the area light: the image is the scene uploaded with it
// moved, and the light's triangles are still its lights.
TEST(MovingGeometry, AnAreaLightFollowsItsTriangles) {
  const Scene scene = caustics_box();
  const Affine lowered = translation(Vec3f(0, -100, 0));
  const std::string light = "shapes[5] 'light'";
  auto engine = engine_with(scene);
  const MeshChange change{light, lowered, std::nullopt, std::nullopt};
  ASSERT_TRUE(engine->set_geometry({&change, 1}).ok());
  EXPECT_EQ(rendered(*engine), uploaded_moved(scene, light, &lowered, nullptr));
}

// A shape is named by the name the scene file gives it as well; a shape of several meshes (a
// model file's parts) moves as one.
TEST(MovingGeometry, AShapeMovesByItsOwnNameWithAllItsParts) {
  Scene scene = caustics_box();
  scene.meshes[mesh_index(scene, kSphere)].name = "shapes[6] 'orbs' (glass)";
  scene.meshes[mesh_index(scene, "shapes[7] 'mirror sphere'")].name = "shapes[6] 'orbs' (mirror)";
  const Affine lifted = translation(Vec3f(0, 50, 0));
  auto engine = engine_with(scene);
  const MeshChange change{"orbs", lifted, std::nullopt, std::nullopt};
  absl::StatusOr<RebuildReport> report = engine->set_geometry({&change, 1});
  ASSERT_TRUE(report.ok()) << report.status();
  Scene moved = scene;
  for (Mesh& mesh : moved.meshes) {
    if (parse_shape_label(mesh.name).name == "orbs") transform_mesh(lifted, &mesh);
  }
  auto fresh = engine_with(moved);
  EXPECT_EQ(rendered(*engine), rendered(*fresh));
  // New vertices go to one mesh, named whole.
  const MeshChange reshaped{"orbs", std::nullopt, moved.meshes[0].positions, std::nullopt};
  report = engine->set_geometry({&reshaped, 1});
  ASSERT_FALSE(report.ok());
  EXPECT_THAT(std::string(report.status().message()),
              ::testing::HasSubstr("meshes[0].positions: 'orbs' is a shape of 2 meshes"));
  // Two shapes of one name are refused rather than guessed between.
  scene.meshes[mesh_index(scene, "shapes[6] 'orbs' (mirror)")].name = "shapes[7] 'orbs'";
  auto two = engine_with(scene);
  report = two->set_geometry({&change, 1});
  ASSERT_FALSE(report.ok());
  EXPECT_THAT(std::string(report.status().message()),
              ::testing::HasSubstr("meshes[0].mesh: 'orbs' names two shapes (shapes[6] and "
                                   "shapes[7])"));
}

// What a geometry change does to the structure, by kind and refit policy (settings.build.refit):
// the 4-wide BVHs refit under "auto" and "always" and build anew under "never", bvh8 builds
// anew, dacrt keeps nothing; the report and the scene's stats say which, and every way renders
// the scene uploaded moved, bit for bit. A bound of 1 with a change that grows the cost makes
// "auto" build anew.
TEST(MovingGeometry, TheRefitPolicyDecidesBetweenARefitAndABuild) {
  struct Case {
    StructureKind kind;
    RefitPolicy policy;
    float bound;
    const char* structure;  // what the report names, or null for nothing
  };
  const Case cases[] = {
      {StructureKind::kLbvh4, RefitPolicy::kAuto, kDefaultRefitSahBound, "structure_refit"},
      {StructureKind::kBinnedSah, RefitPolicy::kAlways, 1.0f, "structure_refit"},
      {StructureKind::kHybrid, RefitPolicy::kNever, kDefaultRefitSahBound, "structure"},
      {StructureKind::kLbvh4, RefitPolicy::kAuto, 1.0f, "structure"},
      {StructureKind::kBvh8, RefitPolicy::kAlways, kDefaultRefitSahBound, "structure"},
      {StructureKind::kDacrt, RefitPolicy::kAuto, kDefaultRefitSahBound, nullptr},
  };
  // The sphere's vertices in reverse order: its triangles then span it, and their boxes overlap
  // far beyond the bound of 1.
  const Scene base = caustics_box();
  std::vector<Vec3f> scrambled = base.meshes[mesh_index(base, kSphere)].positions;
  std::reverse(scrambled.begin(), scrambled.end());
  for (const Case& c : cases) {
    SCOPED_TRACE(std::string(structure_kind_name(c.kind)) + " " + kind_name(c.policy) + " " +
                 std::to_string(c.bound));
    Scene scene = caustics_box();
    scene.settings.structure = c.kind;
    scene.settings.build.refit = c.policy;
    scene.settings.build.refit_sah_bound = c.bound;
    auto engine = engine_with(scene);
    const double built_cost = engine->scene_stats().structure_sah_cost;
    const MeshChange change{kSphere, std::nullopt, scrambled, std::nullopt};
    absl::StatusOr<RebuildReport> report = engine->set_geometry({&change, 1});
    ASSERT_TRUE(report.ok()) << report.status();
    std::vector<std::string> expected = {"geometry", "lights", "film", "photon_maps"};
    if (c.structure != nullptr) expected.insert(expected.begin() + 1, c.structure);
    EXPECT_EQ(report->rebuilt, expected);
    const SceneStats stats = engine->scene_stats();
    const bool refitted = c.structure != nullptr && std::string(c.structure) == "structure_refit";
    EXPECT_EQ(stats.structure_refits, refitted ? 1u : 0u);
    if (refitted) {
      EXPECT_EQ(stats.structure_built_sah_cost, built_cost);
      EXPECT_GT(stats.structure_sah_cost, built_cost);
    } else {
      EXPECT_EQ(stats.structure_built_sah_cost, stats.structure_sah_cost);
    }
    EXPECT_EQ(rendered(*engine), uploaded_moved(scene, kSphere, nullptr, &scrambled));
  }
}

// A keyframe's changes together (Engine::apply): an area light dimmed and the sphere moved in one
// rebuild render as the scene uploaded that way; check() refuses what apply() would, as it would
// say it, and changes nothing.
TEST(MovingGeometry, LightsAndMeshesChangeTogether) {
  const Scene scene = caustics_box();
  const Affine moved = translation(Vec3f(-80, 0, -60));
  auto engine = engine_with(scene);
  SceneChange change;
  change.emitters = {{"light", Vec3f(4, 3, 2), std::nullopt}};
  change.meshes = {{"glass sphere", moved, std::nullopt, std::nullopt}};
  ASSERT_TRUE(engine->check(change).ok());
  absl::StatusOr<RebuildReport> report = engine->apply(change);
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_EQ(report->rebuilt, (std::vector<std::string>{"geometry", "structure_refit", "lights",
                                                       "film", "photon_maps"}));
  EXPECT_EQ(report->epochs.geometry, 2u);
  EXPECT_EQ(report->epochs.lights, 2u);
  Scene expected = scene;
  absl::StatusOr<std::vector<Material>> materials =
      apply_emitter_changes(expected.materials, change.emitters);
  ASSERT_TRUE(materials.ok()) << materials.status();
  expected.materials = *materials;
  transform_mesh(moved, &expected.meshes[mesh_index(expected, kSphere)]);
  auto fresh = engine_with(expected);
  EXPECT_EQ(rendered(*engine), rendered(*fresh));

  const Epochs epochs = engine->epochs();
  SceneChange bad = change;
  bad.meshes.push_back({"no such mesh", Affine(), std::nullopt, std::nullopt});
  for (const absl::Status& status : {engine->check(bad), engine->apply(bad).status()}) {
    EXPECT_EQ(status.code(), absl::StatusCode::kNotFound) << status;
    EXPECT_THAT(std::string(status.message()),
                ::testing::HasSubstr("meshes[1].mesh: the scene has no mesh named 'no such "
                                     "mesh'"));
  }
  bad = SceneChange{};
  bad.emitters = {{"no such material", Vec3f(1), std::nullopt}};
  EXPECT_FALSE(engine->check(bad).ok());
  EXPECT_EQ(engine->check(bad).message(), engine->apply(bad).status().message());
  EXPECT_EQ(engine->epochs().geometry, epochs.geometry);
  EXPECT_EQ(engine->epochs().lights, epochs.lights);
}

// The helmet: colour, normal, metallic-roughness and emission maps under an HDR sky, its
// glowing parts area lights weighed by their emission map. Moved, and with new vertices, it
// renders as the scene uploaded that way: a geometry change keeps the textures and the area
// lights' map means, and rebuilds the corners, tangents and area lights the new triangles need.
TEST(MovingGeometry, ATexturedEmissiveModelMovesAsUploadedMoved) {
  absl::StatusOr<Scene> loaded =
      load_scene(std::filesystem::path(CAUSTICA_SCENES_DIR) / "damaged-helmet" / "scene.json");
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  Scene scene = *loaded;
  scene.camera.width = scene.camera.height = 24;
  scene.settings.photons_per_pass = 5000;
  ASSERT_EQ(scene.meshes.size(), 1u);
  const std::string helmet = scene.meshes[0].name;
  const Affine turned = translation(Vec3f(0.1f, 0, 0)) * rotation_y_deg(40);
  auto engine = engine_with(scene);
  ASSERT_GT(engine->scene_stats().lights, 1u);  // the sky and the glowing parts
  MeshChange change{"helmet", turned, std::nullopt, std::nullopt};
  ASSERT_TRUE(engine->set_geometry({&change, 1}).ok());
  EXPECT_EQ(rendered(*engine), uploaded_moved(scene, helmet, &turned, nullptr));
  std::vector<Vec3f> swollen = scene.meshes[0].positions;
  for (Vec3f& p : swollen) p = p * 1.05f;
  change = {"helmet", turned, swollen, std::nullopt};
  ASSERT_TRUE(engine->set_geometry({&change, 1}).ok());
  EXPECT_EQ(rendered(*engine), uploaded_moved(scene, helmet, &turned, &swollen));
}

}  // namespace
}  // namespace caustica
