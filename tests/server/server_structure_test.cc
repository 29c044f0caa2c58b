// End to end over loopback: every bundled scene rendered by the real caustica-server through every
// ray-tracing structure, chosen at upload and switched by UpdateSettings, against the lbvh4 image,
// and with every density estimator.
// The server runs on the device CAUSTICA_TEST_DEVICE names (the harness passes it on), so the
// same test covers a GPU server.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "proto/wire/scene_wire.h"
#include "renderer/accel/structure_kind.h"
#include "renderer/engine.h"
#include "renderer/scene/load_scene.h"
#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

constexpr int kWidth = 64, kHeight = 48;
constexpr uint32_t kPhotons = 4000, kK = 16, kPasses = 2, kSeed = 11;

// Every structure finds the same closest hits (the brute-force tests of
// tests/renderer/accel/structure_test.cc) but may break an exact tie between coincident triangles
// another way, which sends a path elsewhere. On the CPU the images are in fact identical, so the
// tolerance stays tight enough to catch a structure that misses or misplaces a hit.
constexpr double kRelativeRmse = 0.002;

// Every scenes/*/scene.json, in name order so that failures read the same on every run.
std::vector<std::filesystem::path> bundled_scenes() {
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(CAUSTICA_SCENES_DIR)) {
    const std::filesystem::path file = entry.path() / "scene.json";
    if (std::filesystem::exists(file)) files.push_back(file);
  }
  std::sort(files.begin(), files.end());
  return files;
}

// The scene at a test-sized resolution and photon count, tracing through `kind`.
Scene small_scene(const std::filesystem::path& file, StructureKind kind) {
  Scene scene = small_scene_from(file, kWidth, kHeight, kPhotons, kK, kSeed);
  scene.settings.structure = kind;
  return scene;
}

// Root-mean-square difference of two RGBA images' colour channels, relative to the reference's
// root-mean-square value.
double relative_rmse(const std::vector<float>& reference, const std::vector<float>& image) {
  double difference = 0, norm = 0;
  for (size_t i = 0; i < reference.size(); ++i) {
    if (i % 4 == 3) continue;  // alpha
    const double d = double(image[i]) - reference[i];
    difference += d * d;
    norm += double(reference[i]) * reference[i];
  }
  return std::sqrt(difference / norm);
}

// The scene's RGBA32F frame at kPasses passes (empty when the call fails), whose geometry epoch
// goes to `geometry_epoch`.
std::string render_linear(v1::RenderService::Stub& stub, const std::string& scene_id,
                          uint64_t* geometry_epoch = nullptr) {
  v1::Frame frame;
  const grpc::Status status =
      render_frame(stub, scene_id, kPasses, frame_format(v1::RGBA32F_LINEAR), &frame);
  EXPECT_TRUE(status.ok()) << status.error_message();
  if (!status.ok()) return {};
  EXPECT_EQ(frame.passes(), kPasses);
  EXPECT_EQ(frame.data().size(), size_t(kWidth) * kHeight * 16);
  if (geometry_epoch != nullptr) *geometry_epoch = frame.epochs().geometry();
  return frame.data();
}

// What SceneInfo must say of a scene built with `kind`.
void expect_structure(const v1::SceneInfo& info, StructureKind kind) {
  EXPECT_EQ(info.structure(), structure_kind_name(kind));
  EXPECT_EQ(info.settings().structure(), wire::encode_structure(kind));
  // dacrt stores no nodes: only the triangles and their boxes.
  if (kind == StructureKind::kDacrt) {
    EXPECT_EQ(info.structure_nodes(), 0u);
  } else {
    EXPECT_GT(info.structure_nodes(), 0u);
  }
  EXPECT_GT(info.structure_bytes(), 0u);
  // With C_T = C_I = 1 the root alone costs 1 and its leaves' triangles add to it.
  EXPECT_GT(info.structure_sah_cost(), 1);
}

// Both ways of choosing a structure, for every bundled scene and every kind: uploaded with the
// kind in its settings, and switched to it by UpdateSettings after an lbvh4 upload. Each image
// must match lbvh4's, and the two ways must agree bit for bit, since the film restarts at pass 0
// with the same seed either way. One case per scene, so that the seeds' scenes of 70,000
// triangles each stay inside the suite's time limit.
class EveryStructure : public ServerTest,
                       public ::testing::WithParamInterface<std::filesystem::path> {};

TEST_P(EveryStructure, RendersTheBundledSceneAsLbvh4Does) {
  const std::filesystem::path& file = GetParam();
  const std::string name = file.parent_path().filename().string();

  // Kinds that do not trace through a scene's media are refused, naming the medium problem.
  auto renders = [&](StructureKind kind) {
    const Scene scene = small_scene(file, kind);
    return media_support(scene, scene.settings).ok();
  };
  std::map<StructureKind, std::string> uploaded;
  for (StructureKind kind : kStructureKinds) {
    SCOPED_TRACE(absl::StrCat("uploaded with ", structure_kind_name(kind)));
    v1::SceneInfo info;
    const grpc::Status status = upload(
        *stub_,
        scene_chunks(small_scene(file, kind), absl::StrCat(name, "-", structure_kind_name(kind))),
        &info);
    if (!renders(kind)) {
      EXPECT_EQ(status.error_code(), grpc::StatusCode::UNIMPLEMENTED);
      EXPECT_NE(status.error_message().find("media:"), std::string::npos) << status.error_message();
      continue;
    }
    ASSERT_TRUE(status.ok()) << status.error_message();
    expect_structure(info, kind);
    expect_structure(get_scene(*stub_, info.scene_id()), kind);
    uploaded[kind] = render_linear(*stub_, info.scene_id());
    ASSERT_FALSE(uploaded[kind].empty());
    delete_scene(*stub_, info.scene_id());
  }
  const std::vector<float> reference = frame_floats(uploaded.at(StructureKind::kLbvh4));
  EXPECT_GT(mean_rgb(reference), 0.001) << "the image should not be black";
  for (const auto& [kind, frame] : uploaded) {
    const double error = relative_rmse(reference, frame_floats(frame));
    EXPECT_LT(error, kRelativeRmse) << "uploaded with " << structure_kind_name(kind);
  }

  const std::string id = upload_scene(*stub_, small_scene(file, StructureKind::kLbvh4),
                                      absl::StrCat(name, "-switched"));
  uint64_t geometry = 0;
  EXPECT_EQ(render_linear(*stub_, id, &geometry), uploaded.at(StructureKind::kLbvh4));
  for (StructureKind kind : kStructureKinds) {
    if (kind == StructureKind::kLbvh4) continue;
    SCOPED_TRACE(absl::StrCat("switched to ", structure_kind_name(kind)));
    v1::UpdateSettingsRequest request;
    request.set_scene_id(id);
    request.mutable_settings()->set_structure(wire::encode_structure(kind));
    v1::RebuildReport report;
    {
      grpc::ClientContext context;
      set_deadline(context);
      const grpc::Status status = stub_->UpdateSettings(&context, request, &report);
      if (!renders(kind)) {
        EXPECT_EQ(status.error_code(), grpc::StatusCode::UNIMPLEMENTED);
        continue;
      }
      ASSERT_TRUE(status.ok()) << status.error_message();
    }
    EXPECT_NE(std::find(report.rebuilt().begin(), report.rebuilt().end(), "geometry"),
              report.rebuilt().end())
        << "rebuilt: " << absl::StrJoin(report.rebuilt(), ", ");
    EXPECT_GT(report.epochs().geometry(), geometry);
    const v1::SceneInfo info = get_scene(*stub_, id);
    expect_structure(info, kind);
    EXPECT_EQ(info.epochs().geometry(), report.epochs().geometry());

    const std::string switched = render_linear(*stub_, id, &geometry);
    ASSERT_FALSE(switched.empty());
    EXPECT_EQ(geometry, report.epochs().geometry());
    EXPECT_LT(relative_rmse(reference, frame_floats(switched)), kRelativeRmse);
    EXPECT_TRUE(switched == uploaded.at(kind)) << "switched and uploaded frames differ";
  }
  delete_scene(*stub_, id);
}

INSTANTIATE_TEST_SUITE_P(BundledScenes, EveryStructure, ::testing::ValuesIn(bundled_scenes()),
                         [](const auto& info) {
                           std::string name = info.param.parent_path().filename().string();
                           std::replace(name.begin(), name.end(), '-', '_');
                           return name;
                         });

// Every estimator through the server, for every bundled scene: uploaded with it in the settings
// and switched to it by UpdateSettings after a knn upload, the two frames the same to the bit (the
// film and SPPM's statistics restart at pass 0 with the same seed either way), and SceneInfo
// naming it.
TEST_F(ServerTest, EveryEstimatorRendersEveryBundledScene) {
  const std::vector<std::filesystem::path> files = bundled_scenes();
  ASSERT_GE(files.size(), 3u) << CAUSTICA_SCENES_DIR;
  for (const std::filesystem::path& file : files) {
    const std::string name = file.parent_path().filename().string();
    SCOPED_TRACE(name);
    const std::string switched_id =
        upload_scene(*stub_, small_scene(file, kDefaultStructure), absl::StrCat(name, "-knn"));
    // UpdateSettings naming `kind` for the scene uploaded with knn.
    auto switch_estimator = [&](EstimatorKind kind) {
      v1::UpdateSettingsRequest request;
      request.set_scene_id(switched_id);
      request.mutable_settings()->set_estimator(wire::encode_estimator(kind));
      v1::RebuildReport report;
      grpc::ClientContext context;
      set_deadline(context);
      return stub_->UpdateSettings(&context, request, &report);
    };
    for (const SettingKind<EstimatorKind>& estimator : kEstimatorKinds) {
      const EstimatorKind kind = estimator.value;
      SCOPED_TRACE(estimator.name);
      Scene scene = small_scene(file, kDefaultStructure);
      scene.settings.estimator = kind;
      if (!media_support(scene, scene.settings).ok()) {
        // Refused on upload and by UpdateSettings alike, and the scene keeps its estimator.
        v1::SceneInfo info;
        EXPECT_EQ(upload(*stub_, scene_chunks(scene, name), &info).error_code(),
                  grpc::StatusCode::UNIMPLEMENTED);
        EXPECT_EQ(switch_estimator(kind).error_code(), grpc::StatusCode::UNIMPLEMENTED);
        EXPECT_EQ(get_scene(*stub_, switched_id).settings().estimator(), v1::KNN);
        continue;
      }
      const std::string id = upload_scene(*stub_, scene, absl::StrCat(name, "-", kind_name(kind)));
      EXPECT_EQ(get_scene(*stub_, id).settings().estimator(), wire::encode_estimator(kind));
      const std::string uploaded = render_linear(*stub_, id);
      ASSERT_FALSE(uploaded.empty());
      EXPECT_GT(mean_rgb(frame_floats(uploaded)), 0.001) << "the image should not be black";
      delete_scene(*stub_, id);

      ASSERT_TRUE(switch_estimator(kind).ok());
      EXPECT_EQ(get_scene(*stub_, switched_id).settings().estimator(),
                wire::encode_estimator(kind));
      EXPECT_TRUE(render_linear(*stub_, switched_id) == uploaded)
          << "switched and uploaded frames differ";
    }
    delete_scene(*stub_, switched_id);
  }
}

// Two scenes on one server, the same geometry through binned-sah and hybrid with different stage
// schedules: each is built with its own (its SceneInfo reports the schedule and a tree of its own
// SAH cost), an UpdateSettings of the schedule rebuilds the structure as a fresh upload with it
// builds it, and a refused schedule names the stage.
TEST_F(ServerTest, ScenesOnOneServerBuildTheirStructuresWithTheirOwnOptions) {
  const std::filesystem::path file =
      std::filesystem::path(CAUSTICA_SCENES_DIR) / "cornell-caustics" / "scene.json";
  for (StructureKind kind : {StructureKind::kBinnedSah, StructureKind::kHybrid}) {
    SCOPED_TRACE(structure_kind_name(kind));
    Scene coarse = small_scene(file, kind), fine = coarse;
    ASSERT_FALSE(parse_binned_sah_stages("512:2,16:2", coarse.settings.build.binned_sah));
    ASSERT_FALSE(parse_binned_sah_stages("512:64,16:8", fine.settings.build.binned_sah));
    fine.settings.build.binned_sah.reorder = BinnedSahReorder::kSegmentedSplits;
    const std::string coarse_id = upload_scene(*stub_, coarse, "coarse");
    const std::string fine_id = upload_scene(*stub_, fine, "fine");
    const v1::SceneInfo coarse_info = get_scene(*stub_, coarse_id);
    const v1::SceneInfo fine_info = get_scene(*stub_, fine_id);
    EXPECT_EQ(coarse_info.settings().build().ShortDebugString(),
              wire::encode_settings(coarse.settings).build().ShortDebugString());
    EXPECT_EQ(fine_info.settings().build().binned_sah_stages_size(), 2);
    EXPECT_EQ(fine_info.settings().build().binned_sah_stages(0).bins(), 64u);
    EXPECT_EQ(fine_info.settings().build().binned_sah_reorder(), v1::BINNED_SAH_REORDER_SPLIT);
    EXPECT_NE(coarse_info.structure_sah_cost(), fine_info.structure_sah_cost());

    // The coarse scene changed to the fine schedule is the fine scene, structure and image.
    v1::UpdateSettingsRequest request;
    request.set_scene_id(coarse_id);
    *request.mutable_settings()->mutable_build() = fine_info.settings().build();
    v1::RebuildReport report;
    {
      grpc::ClientContext context;
      set_deadline(context);
      const grpc::Status status = stub_->UpdateSettings(&context, request, &report);
      ASSERT_TRUE(status.ok()) << status.error_message();
    }
    EXPECT_NE(std::find(report.rebuilt().begin(), report.rebuilt().end(), "geometry"),
              report.rebuilt().end());
    const v1::SceneInfo changed = get_scene(*stub_, coarse_id);
    EXPECT_EQ(changed.structure_sah_cost(), fine_info.structure_sah_cost());
    EXPECT_EQ(changed.structure_nodes(), fine_info.structure_nodes());
    EXPECT_LT(relative_rmse(frame_floats(render_linear(*stub_, fine_id)),
                            frame_floats(render_linear(*stub_, coarse_id))),
              kRelativeRmse);

    // A schedule out of order is refused by name and changes nothing.
    request.mutable_settings()->mutable_build()->mutable_binned_sah_stages(1)->set_above(4096);
    grpc::ClientContext context;
    set_deadline(context);
    const grpc::Status refused = stub_->UpdateSettings(&context, request, &report);
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(refused.error_message().find("settings.build.binned_sah_stages: stage 2 ('4096:8')"),
              std::string::npos)
        << refused.error_message();
    EXPECT_EQ(get_scene(*stub_, coarse_id).structure_sah_cost(), fine_info.structure_sah_cost());
    delete_scene(*stub_, coarse_id);
    delete_scene(*stub_, fine_id);
  }
}

}  // namespace
}  // namespace caustica::testing
