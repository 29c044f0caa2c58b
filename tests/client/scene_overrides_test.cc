// The scene overrides of render, stream, animate and scene upload: what they change in a scene
// file's scene before upload and what they ask of UpdateSettings for a scene id.
#include <gtest/gtest.h>

#include "client/scene_source.h"
#include "renderer/accel/structure_kind.h"

namespace caustica::client {
namespace {

TEST(SceneOverrides, StructureChangesTheSceneBeforeUpload) {
  SceneOverrides overrides;
  EXPECT_TRUE(overrides.empty());
  overrides.structure = StructureKind::kBinnedSah;
  EXPECT_FALSE(overrides.empty()) << "a structure alone is an override";
  Scene scene;
  scene.settings.k_nearest = 32;
  overrides.apply(scene);
  EXPECT_EQ(scene.settings.structure, StructureKind::kBinnedSah);
  EXPECT_EQ(scene.settings.k_nearest, 32u) << "what is not overridden stays";
}

TEST(SceneOverrides, StructureGoesToUpdateSettings) {
  SceneOverrides overrides;
  overrides.structure = StructureKind::kBinnedSah;
  const v1::UpdateSettingsRequest request = overrides.request("s-1");
  EXPECT_EQ(request.scene_id(), "s-1");
  EXPECT_EQ(request.settings().structure(), v1::BINNED_SAH);
  EXPECT_FALSE(request.settings().has_k_nearest());
  EXPECT_EQ(request.width(), 0u);

  overrides.structure = StructureKind::kLbvh4;
  EXPECT_EQ(overrides.request("s-1").settings().structure(), v1::LBVH4);
  EXPECT_EQ(SceneOverrides{}.request("s-1").settings().structure(), v1::STRUCTURE_UNSPECIFIED)
      << "no override keeps the scene's structure";
}

TEST(SceneOverrides, IntegratorChangesTheSceneOrGoesToUpdateSettings) {
  SceneOverrides overrides;
  overrides.integrator = Integrator::kPath;
  EXPECT_FALSE(overrides.empty()) << "an integrator alone is an override";
  Scene scene;
  overrides.apply(scene);
  EXPECT_EQ(scene.settings.integrator, Integrator::kPath);
  EXPECT_EQ(overrides.request("s-1").settings().integrator(), v1::PATH);
  EXPECT_EQ(SceneOverrides{}.request("s-1").settings().integrator(), v1::INTEGRATOR_UNSPECIFIED)
      << "no override keeps the scene's integrator";
}

TEST(SceneOverrides, EstimatorChangesTheSceneOrGoesToUpdateSettings) {
  SceneOverrides overrides;
  overrides.estimator = EstimatorKind::kSppm;
  EXPECT_FALSE(overrides.empty()) << "an estimator alone is an override";
  Scene scene;
  overrides.apply(scene);
  EXPECT_EQ(scene.settings.estimator, EstimatorKind::kSppm);
  EXPECT_EQ(overrides.request("s-1").settings().estimator(), v1::SPPM);
  EXPECT_EQ(SceneOverrides{}.request("s-1").settings().estimator(), v1::ESTIMATOR_UNSPECIFIED);
}

}  // namespace
}  // namespace caustica::client
