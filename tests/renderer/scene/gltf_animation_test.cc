// glTF animations sampled: the interpolation modes against the keys of the Khronos
// InterpolationTest file worked by hand, morph targets and skins against positions computed by
// an independent Python reading of the files (tests/data/scene/thirdparty/gltf2/animation/
// reference_poses.py), names as the mesh loader gives them, and errors that name the part.
#include "renderer/scene/gltf_animation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "absl/strings/str_cat.h"
#include "renderer/scene/mesh_file.h"
#include "renderer/scene/scene_json.h"
#include "renderer/scene/transform.h"

namespace caustica {
namespace {

namespace fs = std::filesystem;

const fs::path kDir = fs::path(CAUSTICA_TEST_DATA) / "scene" / "thirdparty" / "gltf2" / "animation";
constexpr double kPi = 3.14159265358979323846;

GltfAnimation load(const fs::path& path, const std::string& name) {
  absl::StatusOr<GltfAnimation> animation = GltfAnimation::load(path, name);
  EXPECT_TRUE(animation.ok()) << animation.status();
  return *std::move(animation);
}

// The change of the mesh whose name ends in `suffix`.
MeshChange change_of(const std::vector<MeshChange>& changes, const std::string& suffix) {
  for (const MeshChange& c : changes) {
    if (c.mesh.size() >= suffix.size() &&
        c.mesh.compare(c.mesh.size() - suffix.size(), suffix.size(), suffix) == 0)
      return c;
  }
  ADD_FAILURE() << "no change for " << suffix;
  return {};
}

void expect_near(Vec3f got, Vec3f want, float tolerance, const std::string& what) {
  EXPECT_NEAR(got.x, want.x, tolerance) << what;
  EXPECT_NEAR(got.y, want.y, tolerance) << what;
  EXPECT_NEAR(got.z, want.z, tolerance) << what;
}

// InterpolationTest's keys (seconds), as the file stores them in float.
constexpr float kKey1 = 0.4166666567325592f, kKey2 = 0.875f;
// Hermite weights at a quarter of the way from one key to the next.
constexpr double kH00 = 0.84375, kH01 = 0.15625;

// Every animation of the file moves one cube; what it does at a time between two keys, worked
// from the keys by hand, is where the transform takes the cube's rest placement.
TEST(GltfAnimation, InterpolationModesFollowTheKeys) {
  const fs::path file = kDir / "InterpolationTest.gltf";
  // Scale 1 -> 0.5 at key 1 -> 1 at key 2: STEP holds 0.5, LINEAR is 0.75 halfway, CUBICSPLINE
  // (zero tangents) a quarter of the way is kH00 * 0.5 + kH01 * 1.
  const double halfway = 0.5 * (kKey1 + kKey2), quarter = kKey1 + 0.25 * (kKey2 - kKey1);
  const struct {
    const char* animation;
    double seconds;
    double scale;
  } scales[] = {{"Step Scale", halfway, 0.5},
                {"Linear Scale", halfway, 0.75},
                {"CubicSpline Scale", quarter, kH00 * 0.5 + kH01 * 1.0},
                {"Linear Scale", 0.0, 1.0},     // before the first key: held
                {"Linear Scale", 100.0, 1.0}};  // after the last
  for (const auto& [name, seconds, scale] : scales) {
    const std::vector<MeshChange> changes = load(file, name).at(seconds);
    ASSERT_EQ(changes.size(), 1u) << name;
    ASSERT_TRUE(changes[0].transform) << name;
    const Affine& t = *changes[0].transform;
    // The cube scales about its node's origin, which the rest placement put at the translation.
    for (int axis = 0; axis < 3; ++axis) EXPECT_NEAR(t.m[axis][axis], scale, 1e-6) << name;
  }

  // Translation keys y = 10 at key 1 and 6 at key 2 (from 6.6652 and 6.7342 at rest).
  const struct {
    const char* animation;
    const char* node;
    double seconds, rest_y, y;
  } moves[] = {{"Step Translation", "Cube.006", 0.6, 6.665226459503174, 10.0},
               {"Linear Translation", "Cube.009", 0.625, 6.958913326263428, 8.0},
               {"CubicSpline Translation", "Cube.008",
                0.4166666567325592 + 0.25 * (0.8333333134651184 - 0.4166666567325592),
                6.734194278717041, kH00 * 10.0 + kH01 * 6.0}};
  for (const auto& [name, node, seconds, rest_y, y] : moves) {
    const std::vector<MeshChange> changes = load(file, name).at(seconds);
    const MeshChange change = change_of(changes, absl::StrCat("at node '", node, "'"));
    ASSERT_TRUE(change.transform) << name;
    EXPECT_NEAR(change.transform->m[1][3], y - rest_y, 1e-5) << name;
    EXPECT_NEAR(change.transform->m[0][3], 0, 1e-6) << name;
  }

  // Rotations about z: 0, -45, -90, -135, -180 degrees at the keys. The cube's +x axis at rest
  // turns to where the rotation at that time points it.
  const double z_rest = 2 * std::atan2(-0.03925982117652893, 0.9992290735244751);
  const struct {
    const char* animation;
    double seconds, rest_angle, angle;
  } turns[] = {{"Step Rotation", 1.0, 0.0, -kPi / 2},
               {"Linear Rotation", 0.5 * (0.4166666567325592 + 0.875), z_rest, -0.375 * kPi},
               {"CubicSpline Rotation", 0.875,
                2 * std::atan2(-0.006683696992695332, 0.9999777674674988), -kPi / 2}};
  for (const auto& [name, seconds, rest_angle, angle] : turns) {
    const std::vector<MeshChange> changes = load(file, name).at(seconds);
    ASSERT_EQ(changes.size(), 1u) << name;
    const Affine& t = *changes[0].transform;
    const Vec3f rest_axis(float(std::cos(rest_angle)), float(std::sin(rest_angle)), 0);
    expect_near(t.apply_to_vector(rest_axis),
                Vec3f(float(std::cos(angle)), float(std::sin(angle)), 0), 1e-5f, name);
  }
}

// A quarter of the way between two cubic spline rotation keys, from the keys' values and
// tangents by glTF's Hermite formula, normalised.
TEST(GltfAnimation, CubicSplineRotationUsesTheTangents) {
  const double t1 = 0.4166666567325592, t2 = 0.875, dt = t2 - t1;
  const double v1[2] = {-0.3826834559440613, 0.9238795638084412},
               v2[2] = {-0.7071068286895752, 0.7071068286895752},
               out1[2] = {-0.04789090156555176, 0.9988526701927185},
               in2[2] = {-0.035464316606521606, 0.9993709921836853};
  const double s = 0.25, s2 = s * s, s3 = s2 * s;
  double q[2];
  for (int i = 0; i < 2; ++i) {
    q[i] = (2 * s3 - 3 * s2 + 1) * v1[i] + (s3 - 2 * s2 + s) * dt * out1[i] +
           (-2 * s3 + 3 * s2) * v2[i] + (s3 - s2) * dt * in2[i];
  }
  const double angle = 2 * std::atan2(q[0], q[1]);
  const double rest = 2 * std::atan2(-0.006683696992695332, 0.9999777674674988);
  const std::vector<MeshChange> changes =
      load(kDir / "InterpolationTest.gltf", "CubicSpline Rotation").at(t1 + s * dt);
  ASSERT_EQ(changes.size(), 1u);
  expect_near(
      changes[0].transform->apply_to_vector(Vec3f(float(std::cos(rest)), float(std::sin(rest)), 0)),
      Vec3f(float(std::cos(angle)), float(std::sin(angle)), 0), 1e-5f, "cubic rotation");
}

// What the loader names the file's meshes, the animation names them; the mesh an animation
// leaves alone is not among its changes.
TEST(GltfAnimation, NamesTheMeshesAsTheLoaderDoes) {
  const fs::path file = kDir / "InterpolationTest.gltf";
  absl::StatusOr<MeshFile> meshes = load_mesh_file(file);
  ASSERT_TRUE(meshes.ok()) << meshes.status();
  std::map<std::string, int> names;
  for (const Mesh& mesh : meshes->meshes) ++names[mesh.name];
  const GltfAnimation animation = load(file, "Linear Rotation");
  EXPECT_EQ(animation.name(), "Linear Rotation");
  EXPECT_NEAR(animation.duration_s(), 1.7083333730697632, 1e-6);
  for (const MeshChange& change : animation.at(0.3)) {
    EXPECT_EQ(names.count(change.mesh), 1u) << change.mesh;
  }
  EXPECT_EQ(animation.meshes(), 1u);
}

// BoxAnimated: the root lifts by 2.52 between 0 and 1.25 s and its grandchild, the inner box,
// turns half a turn about x from 1.25 to 2.5 s; halfway through the turn the box stands 90
// degrees over, 2.52 up, and the root's other mesh, which nothing moves, is not among the changes.
TEST(GltfAnimation, AChildMovesWithItsParent) {
  const GltfAnimation animation = load(kDir / "BoxAnimated.gltf", "");
  EXPECT_NEAR(animation.duration_s(), 3.708329916000366, 1e-6);
  const std::vector<MeshChange> changes = animation.at(1.875);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].mesh, "BoxAnimated.gltf: mesh 'inner_box' primitive 0 at node '2'");
  expect_near(changes[0].transform->apply_to_point(Vec3f(0, 1, 0)), Vec3f(0, 2.52f, 1), 1e-5f,
              "turned and lifted");
  expect_near(animation.at(0.625)[0].transform->apply_to_point(Vec3f(0, 1, 0)),
              Vec3f(0, 1 + 1.26f, 0), 1e-5f, "half lifted");
}

struct Reference {
  const char* file;
  double seconds;
  size_t vertex;
  Vec3f position;
};

// reference_poses.py's output.
constexpr Reference kReferences[] = {
    {"SimpleMorph.gltf", 1.5, 0, {0.000000f, 0.000000f, 0.000000f}},
    {"SimpleMorph.gltf", 1.5, 1, {1.000000f, 0.000000f, 0.000000f}},
    {"SimpleMorph.gltf", 1.5, 2, {1.000000f, 2.000000f, 0.000000f}},
    {"RiggedSimple.gltf", 1.0, 0, {0.000000f, -4.575077f, 1.000000f}},
    {"RiggedSimple.gltf", 1.0, 50, {-0.479982f, 0.017823f, 0.091250f}},
    {"RiggedSimple.gltf", 1.0, 95, {0.087806f, 4.096493f, -2.116989f}},
    {"CesiumMan.gltf", 0.5, 0, {0.104454f, 0.962182f, -0.016523f}},
    {"CesiumMan.gltf", 0.5, 1000, {-0.083357f, 1.426028f, 0.075121f}},
    {"CesiumMan.gltf", 0.5, 3000, {0.146018f, 1.401821f, -0.133661f}},
};

fs::path reference_path(const std::string& file) {
  return file == "CesiumMan.gltf" ? fs::path(CAUSTICA_SCENES_DIR) / "cesium-man" / file
                                  : kDir / file;
}

// Morphing (SimpleMorph) and skinning (RiggedSimple, CesiumMan) give the positions the
// independent Python reading of the files gives, with unit normals where the file has normals.
TEST(GltfAnimation, MorphsAndSkinsMatchAnIndependentReading) {
  for (const Reference& r : kReferences) {
    const std::vector<MeshChange> changes = load(reference_path(r.file), "").at(r.seconds);
    ASSERT_EQ(changes.size(), 1u) << r.file;
    const MeshChange& change = changes[0];
    ASSERT_TRUE(change.positions) << r.file;
    ASSERT_GT(change.positions->size(), r.vertex) << r.file;
    expect_near((*change.positions)[r.vertex], r.position, 2e-5f,
                absl::StrCat(r.file, " vertex ", r.vertex));
    ASSERT_TRUE(change.transform) << r.file;  // identity: the positions are where they go
    EXPECT_EQ(change.transform->m, Affine().m) << r.file;
    if (change.normals) {
      EXPECT_NEAR(length((*change.normals)[r.vertex]), 1.0f, 1e-5f) << r.file;
    }
  }
}

// A scene file's shape renames the changes as the scene reader names its meshes and places
// them by its transform.
TEST(GltfAnimation, PlacedInAShapeAsTheSceneReaderPlacesIt) {
  const fs::path file = kDir / "RiggedSimple.gltf";
  const Affine shape = translation(Vec3f(1, 2, 3)) * rotation_y_deg(90) * scaling(Vec3f(2.0f));
  std::vector<MeshChange> changes = load(file, "").at(1.0);
  const Vec3f file_position = (*changes[0].positions)[95];
  place_in_shape("shapes[3]", "robot", shape, changes);
  EXPECT_EQ(changes[0].mesh,
            "shapes[3] 'robot' (RiggedSimple.gltf: mesh 'Cylinder' primitive 0 at node '1')");
  expect_near((*changes[0].positions)[95], shape.apply_to_point(file_position), 1e-5f, "placed");

  std::vector<MeshChange> rigid = load(kDir / "InterpolationTest.gltf", "Linear Translation").at(1);
  const Affine file_transform = *rigid[0].transform;
  place_in_shape("shapes[0]", "", shape, rigid);
  // Moving in the file then placing is placing then moving by the conjugate.
  const Vec3f p(0.3f, -0.2f, 0.7f);
  expect_near(rigid[0].transform->apply_to_point(shape.apply_to_point(p)),
              shape.apply_to_point(file_transform.apply_to_point(p)), 1e-5f, "conjugate");
}

// Errors name the file and the part: an unknown animation lists the file's; a file without
// animations says so; a broken channel names itself.
TEST(GltfAnimation, ErrorsNameWhatIsWrong) {
  absl::StatusOr<GltfAnimation> missing =
      GltfAnimation::load(kDir / "InterpolationTest.gltf", "Bounce");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(std::string(missing.status().message()),
              ::testing::HasSubstr("no animation named 'Bounce' (the file has 'Step Scale', "));
  absl::StatusOr<GltfAnimation> still = GltfAnimation::load(
      fs::path(CAUSTICA_TEST_DATA) / "scene" / "thirdparty" / "gltf2" / "Cameras.gltf", "");
  ASSERT_FALSE(still.ok());
  EXPECT_THAT(std::string(still.status().message()), ::testing::HasSubstr("has no animations"));

  // SimpleMorph with its sampler's output cut short and an unknown interpolation.
  std::ifstream in(kDir / "SimpleMorph.gltf");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const fs::path dir = fs::temp_directory_path() / "caustica-gltf-animation-test";
  fs::create_directories(dir);
  for (const char* bin : {"simpleMorphAnimation.bin", "simpleMorphGeometry.bin"})
    fs::copy_file(kDir / bin, dir / bin, fs::copy_options::overwrite_existing);
  const struct {
    const char* from;
    const char* to;
    const char* message;
  } spoilt[] = {
      {"\"interpolation\":\"LINEAR\"", "\"interpolation\":\"SMOOTH\"",
       "animations[0].channels[0] (sampler 0).interpolation: 'SMOOTH' is not LINEAR, STEP or "
       "CUBICSPLINE"},
      {"\"path\":\"weights\"", "\"path\":\"colour\"",
       "animations[0].channels[0].target.path: 'colour' is not"},
  };
  for (const auto& [from, to, message] : spoilt) {
    std::string changed = text;
    const size_t at = changed.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    changed.replace(at, std::string(from).size(), to);
    std::ofstream(dir / "SimpleMorph.gltf") << changed;
    absl::StatusOr<GltfAnimation> bad = GltfAnimation::load(dir / "SimpleMorph.gltf", "");
    ASSERT_FALSE(bad.ok()) << to;
    EXPECT_THAT(std::string(bad.status().message()), ::testing::HasSubstr(message));
    EXPECT_THAT(std::string(bad.status().message()), ::testing::HasSubstr("SimpleMorph.gltf"));
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace caustica
