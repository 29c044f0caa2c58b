// A pass's photons traced in shares (paths [first, first + count) of the whole, as devices of a
// multi-device frame trace them) are the whole pass's photons: merged by merge_traced_photons, the
// same photons in the same order, bit for bit, with and without differentials and media.
#include "renderer/photon/photon_shares.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "renderer/photon/photon_tracer.h"
#include "renderer/resident/resident_scene.h"
#include "renderer/scene/load_scene.h"

namespace caustica {
namespace {

template <typename T>
void expect_same_bytes(const std::vector<T>& a, const std::vector<T>& b, const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  // An empty vector's data() may be null, which memcmp must not be given even for no bytes.
  if (!a.empty()) EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(T))) << what;
}

void expect_shares_make_the_whole(const std::string& scene_name, bool differentials,
                                  const std::vector<uint32_t>& cuts) {
  SCOPED_TRACE(scene_name + (differentials ? " with differentials" : ""));
  absl::StatusOr<Scene> scene =
      load_scene(std::string(CAUSTICA_SCENES_DIR) + "/" + scene_name + "/scene.json");
  ASSERT_TRUE(scene.ok()) << scene.status();
  auto backend = make_cpu_backend(size_t(1) << 30);
  ResidentScene resident = ResidentScene::upload(*backend, *scene);
  const uint32_t total = cuts.back();
  PhotonTraceSettings whole_settings{total, 16, 7, 2};
  whole_settings.differentials = differentials;
  const TracedPhotons whole = trace_photons(*backend, resident, whole_settings);
  ASSERT_GT(whole.caustic.size() + whole.global.size() + whole.volume.size(), 100u);

  std::vector<TracedPhotons> shares;
  uint32_t emitted = 0;
  for (size_t i = 0; i + 1 < cuts.size(); ++i) {
    PhotonTraceSettings share = whole_settings;
    share.first_path = cuts[i];
    share.photon_count = cuts[i + 1] - cuts[i];
    share.total_paths = total;
    shares.push_back(trace_photons(*backend, resident, share));
    emitted += shares.back().emitted;
  }
  EXPECT_EQ(emitted, whole.emitted);
  const TracedPhotons merged = merge_traced_photons(*backend, shares);
  EXPECT_EQ(merged.emitted, whole.emitted);
  EXPECT_EQ(merged.caustic_from_slots, whole.caustic_from_slots);
  EXPECT_EQ(merged.global_from_slots, whole.global_from_slots);
  EXPECT_EQ(merged.volume_from_slots, whole.volume_from_slots);
  expect_same_bytes(merged.caustic.download(), whole.caustic.download(), "caustic");
  expect_same_bytes(merged.global.download(), whole.global.download(), "global");
  expect_same_bytes(merged.volume.download(), whole.volume.download(), "volume");
  expect_same_bytes(merged.caustic_footprints.download(), whole.caustic_footprints.download(),
                    "caustic footprints");
  expect_same_bytes(merged.global_footprints.download(), whole.global_footprints.download(),
                    "global footprints");
  expect_same_bytes(merged.volume_footprints.download(), whole.volume_footprints.download(),
                    "volume footprints");
}

TEST(PhotonShares, TwoEqualSharesAreTheWholePass) {
  expect_shares_make_the_whole("cornell-caustics", false, {0, 10000, 20000});
}

TEST(PhotonShares, UnequalSharesWithDifferentials) {
  expect_shares_make_the_whole("cornell-caustics", true, {0, 1, 7001, 12000});
}

TEST(PhotonShares, MediaKeepTheirCollisionsInOrder) {
  expect_shares_make_the_whole("fog-caustics", false, {0, 4000, 9000, 15000});
}

}  // namespace
}  // namespace caustica
