// Keyframes from a scene's glTF animation: one a frame at the frame rate, each mesh named as the
// scene reader names the shape's meshes and placed as the sampler places it in the shape; with a
// script, frame i joins keyframe i; a scene without the animation is refused by name.
#include "client/gltf_keyframes.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <set>

#include "proto/wire/scene_wire.h"
#include "renderer/scene/gltf_animation.h"
#include "renderer/scene/load_scene.h"

namespace caustica::client {
namespace {

namespace fs = std::filesystem;

const fs::path kScene = fs::path(CAUSTICA_SCENES_DIR) / "cesium-man" / "scene.json";

TEST(GltfKeyframes, OneKeyframeAFrameNamedAsTheSceneNamesTheMeshes) {
  absl::StatusOr<GltfAnimation> clip =
      GltfAnimation::load(kScene.parent_path() / "CesiumMan.gltf", "");
  ASSERT_TRUE(clip.ok()) << clip.status();
  constexpr int kFps = 10;
  absl::StatusOr<std::vector<v1::Keyframe>> keyframes = gltf_keyframes(kScene, "0", kFps, {});
  ASSERT_TRUE(keyframes.ok()) << keyframes.status();
  EXPECT_EQ(keyframes->size(), size_t(std::floor(clip->duration_s() * kFps)) + 1);

  absl::StatusOr<Scene> scene = load_scene(kScene);
  ASSERT_TRUE(scene.ok()) << scene.status();
  std::set<std::string> names;
  for (const Mesh& mesh : scene->meshes) names.insert(mesh.name);
  for (size_t i = 0; i < keyframes->size(); ++i) {
    const v1::Keyframe& keyframe = (*keyframes)[i];
    EXPECT_TRUE(keyframe.keep_lights());
    ASSERT_EQ(keyframe.meshes_size(), 1);
    EXPECT_EQ(names.count(keyframe.meshes(0).mesh()), 1u) << keyframe.meshes(0).mesh();
    // The shape has no transform: the sampler's own positions.
    std::vector<MeshChange> expected = clip->at(double(i) / kFps);
    place_in_shape("shapes[4]", "man", Affine(), expected);
    EXPECT_EQ(keyframe.meshes(0).SerializeAsString(),
              wire::encode_mesh_change(expected[0]).SerializeAsString())
        << "keyframe " << i;
  }
  EXPECT_NE((*keyframes)[0].meshes(0).positions(100), (*keyframes)[5].meshes(0).positions(100));
}

TEST(GltfKeyframes, AScriptsKeyframesCarryTheAnimation) {
  std::vector<v1::Keyframe> script(3);
  script[1].set_passes(4);
  script[2].set_keep_lights(true);
  absl::StatusOr<std::vector<v1::Keyframe>> keyframes = gltf_keyframes(kScene, "0", 24, script);
  ASSERT_TRUE(keyframes.ok()) << keyframes.status();
  ASSERT_EQ(keyframes->size(), 3u);
  EXPECT_EQ((*keyframes)[1].passes(), 4u);
  EXPECT_FALSE((*keyframes)[0].keep_lights());  // the script's empty list stays what it was
  for (const v1::Keyframe& keyframe : *keyframes) EXPECT_EQ(keyframe.meshes_size(), 1);
}

TEST(GltfKeyframes, ASceneWithoutTheAnimationIsRefusedByName) {
  absl::StatusOr<std::vector<v1::Keyframe>> keyframes = gltf_keyframes(kScene, "Run", 24, {});
  ASSERT_FALSE(keyframes.ok());
  EXPECT_EQ(keyframes.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(std::string(keyframes.status().message()),
              ::testing::HasSubstr("has the animation 'Run': "));
  EXPECT_THAT(std::string(keyframes.status().message()),
              ::testing::HasSubstr("no animation named 'Run' (the file has 0)"));
  keyframes =
      gltf_keyframes(fs::path(CAUSTICA_SCENES_DIR) / "cornell-box" / "scene.json", "0", 24, {});
  ASSERT_FALSE(keyframes.ok());
  EXPECT_THAT(std::string(keyframes.status().message()),
              ::testing::HasSubstr("it names no .gltf or .glb file"));
}

}  // namespace
}  // namespace caustica::client
