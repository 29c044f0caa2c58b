// One server on several devices (--devices, --split-frames) end to end: where scenes land, what
// GetStats reports per device, concurrent renders on different devices, frames against a
// one-device server, deletes, restores from --data-dir and refused --devices values. The devices
// are CPU backends, so every path runs without a GPU; with CAUSTICA_TEST_DEVICE set they are
// that many backends on its first device instead.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

// Flags for a server on `count` devices: CPU backends, or with CAUSTICA_TEST_DEVICE (which the
// harness passes as --device) that many backends on its device 0, which one GPU can hold.
std::vector<std::string> devices_args(int count) {
  if (const char* device = std::getenv("CAUSTICA_TEST_DEVICE");
      device != nullptr && *device != '\0' && std::string(device) != "cpu") {
    // One device is the count 1 (a lone "0" would be the count 0).
    if (count == 1) return {"--devices", "1"};
    return {"--devices", absl::StrJoin(std::vector<std::string>(count, "0"), ",")};
  }
  return {"--device", "cpu", "--devices", std::to_string(count)};
}

v1::Stats get_stats(v1::RenderService::Stub& stub) {
  v1::Stats stats;
  grpc::ClientContext context;
  set_deadline(context);
  const grpc::Status status = stub.GetStats(&context, {}, &stats);
  EXPECT_TRUE(status.ok()) << status.error_message();
  return stats;
}

std::vector<uint32_t> devices_of(const v1::SceneInfo& info) {
  return {info.devices().begin(), info.devices().end()};
}

// `scene` uploaded to a fresh one-device server and rendered there.
std::vector<float> one_device_frame(const Scene& scene, uint32_t passes) {
  std::unique_ptr<ServerProcess> single = ServerProcess::start(devices_args(1));
  if (single == nullptr) return {};
  auto stub = single->stub();
  return render_linear(*stub, upload_scene(*stub, scene, "reference"), passes);
}

// Pixels that differ beyond relative `tolerance` (0: any difference).
size_t mismatches(const std::vector<float>& a, const std::vector<float>& b, float tolerance) {
  EXPECT_EQ(a.size(), b.size());
  size_t count = 0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
    const float allowed = tolerance * std::max({std::abs(a[i]), std::abs(b[i]), 1e-3f});
    if (tolerance == 0 ? a[i] != b[i] : std::abs(a[i] - b[i]) > allowed) ++count;
  }
  return count;
}

class TwoDevices : public ServerTest {
 protected:
  std::vector<std::string> server_args() const override { return devices_args(2); }
};

TEST_F(TwoDevices, ScenesSpreadOverTheDevicesAndStatsShowEach) {
  const v1::Stats empty = get_stats(*stub_);
  ASSERT_EQ(empty.devices_size(), 2);
  const std::string a = upload_scene(*stub_, cornell_box(24, 24, 2000, 16, 1), "a");
  const std::string b = upload_scene(*stub_, cornell_box(24, 24, 2000, 16, 2), "b");
  const v1::SceneInfo info_a = get_scene(*stub_, a);
  const v1::SceneInfo info_b = get_scene(*stub_, b);
  // Both devices start empty, so the first scene takes device 0 (the lower index of equals) and
  // the second the one with more free budget left.
  EXPECT_THAT(devices_of(info_a), ElementsAre(0u));
  EXPECT_THAT(devices_of(info_b), ElementsAre(1u));

  const v1::Stats stats = get_stats(*stub_);
  ASSERT_EQ(stats.devices_size(), 2);
  uint64_t used = 0, budget = 0;
  for (int i = 0; i < 2; ++i) {
    const v1::DeviceStats& device = stats.devices(i);
    SCOPED_TRACE(device.ShortDebugString());
    EXPECT_EQ(device.index(), uint32_t(i));
    EXPECT_FALSE(device.name().empty());
    EXPECT_EQ(device.kind(), stats.device().kind());
    EXPECT_GT(device.compute_units(), 0u);
    EXPECT_EQ(device.memory_budget_bytes(), uint64_t{8} << 30) << "--memory-budget is per device";
    EXPECT_EQ(device.scenes(), 1u);
    EXPECT_EQ(device.queue_waiting(), 0u);
    const v1::SceneInfo& scene = i == 0 ? info_a : info_b;
    EXPECT_GT(scene.device_bytes(), 0u);
    EXPECT_EQ(device.memory_used_bytes(),
              empty.devices(i).memory_used_bytes() + scene.device_bytes());
    EXPECT_GE(device.memory_peak_bytes(), device.memory_used_bytes());
    used += device.memory_used_bytes();
    budget += device.memory_budget_bytes();
  }
  // The fields of one-device servers: the first device and the sums.
  EXPECT_EQ(stats.device().name(), stats.devices(0).name());
  EXPECT_EQ(stats.memory_used_bytes(), used);
  EXPECT_EQ(stats.memory_budget_bytes(), budget);
  EXPECT_EQ(stats.tenant().memory_limit_bytes(), budget);
  EXPECT_EQ(stats.scenes(), 2u);
  for (const v1::SceneInfo& listed : list_scenes(*stub_)) {
    EXPECT_EQ(listed.devices_size(), 1) << listed.scene_id();
  }
}

TEST_F(TwoDevices, ClientsOnDifferentDevicesRenderAtOnceAndMatchOneDevice) {
  const Scene scene_a = cornell_box(32, 32, 3000, 16, 3);
  const Scene scene_b = cornell_box(32, 32, 3000, 16, 4);
  const std::string a = upload_scene(*stub_, scene_a, "a");
  const std::string b = upload_scene(*stub_, scene_b, "b");
  ASSERT_THAT(devices_of(get_scene(*stub_, b)), ElementsAre(1u));

  const uint32_t passes = 3;
  std::vector<float> frame_a, frame_b;
  std::thread other([&] {
    auto stub = server_->stub();
    frame_a = render_linear(*stub, a, passes);
  });
  frame_b = render_linear(*stub_, b, passes);
  other.join();
  ASSERT_FALSE(frame_a.empty());
  ASSERT_FALSE(frame_b.empty());
  EXPECT_GT(mean_rgb(frame_a), 0.01);
  EXPECT_GT(mean_rgb(frame_b), 0.01);

  // Device 1 renders its scene alone, so the frame is the one a one-device server gives.
  const std::vector<float> reference = one_device_frame(scene_b, passes);
  EXPECT_EQ(mismatches(frame_b, reference, 0), 0u) << "of " << reference.size() << " channels";
}

TEST_F(TwoDevices, DeletingASceneFreesItsDevice) {
  const v1::Stats empty = get_stats(*stub_);
  const std::string a = upload_scene(*stub_, cornell_box(24, 24, 2000, 16, 1), "a");
  const std::string b = upload_scene(*stub_, cornell_box(24, 24, 2000, 16, 2), "b");
  render_linear(*stub_, b, 1);
  const v1::Stats full = get_stats(*stub_);
  ASSERT_EQ(full.devices_size(), 2);
  ASSERT_GT(full.devices(1).memory_used_bytes(), empty.devices(1).memory_used_bytes());

  grpc::ClientContext context;
  set_deadline(context);
  v1::DeleteSceneRequest request;
  request.set_scene_id(b);
  v1::DeleteSceneResponse response;
  ASSERT_TRUE(stub_->DeleteScene(&context, request, &response).ok());
  EXPECT_EQ(response.bytes_freed(),
            full.devices(1).memory_used_bytes() - empty.devices(1).memory_used_bytes());

  const v1::Stats after = get_stats(*stub_);
  EXPECT_EQ(after.devices(1).memory_used_bytes(), empty.devices(1).memory_used_bytes());
  EXPECT_EQ(after.devices(1).scenes(), 0u);
  EXPECT_EQ(after.devices(0).memory_used_bytes(), full.devices(0).memory_used_bytes())
      << "the other device's scene stays";
  EXPECT_EQ(after.devices(0).scenes(), 1u);
  // The freed device takes the next scene.
  const std::string c = upload_scene(*stub_, cornell_box(24, 24, 2000, 16, 3), "c");
  EXPECT_THAT(devices_of(get_scene(*stub_, c)), ElementsAre(1u));
  (void)a;
}

class SplitFrames : public ServerTest {
 protected:
  std::vector<std::string> server_args() const override {
    std::vector<std::string> args = devices_args(3);
    args.push_back("--split-frames");
    return args;
  }
};

TEST_F(SplitFrames, EveryDeviceHoldsTheSceneAndFramesMatchOneDevice) {
  Scene path = cornell_box(40, 36, 3000, 16, 5);
  path.settings.integrator = Integrator::kPath;
  const Scene knn = cornell_box(40, 36, 3000, 16, 6);
  const std::string path_id = upload_scene(*stub_, path, "path");
  const std::string knn_id = upload_scene(*stub_, knn, "knn");
  EXPECT_THAT(devices_of(get_scene(*stub_, path_id)), ElementsAre(0u, 1u, 2u));
  EXPECT_THAT(devices_of(get_scene(*stub_, knn_id)), ElementsAre(0u, 1u, 2u));

  const v1::Stats stats = get_stats(*stub_);
  ASSERT_EQ(stats.devices_size(), 3);
  for (const v1::DeviceStats& device : stats.devices()) {
    EXPECT_EQ(device.scenes(), 2u) << device.index();
    EXPECT_GT(device.memory_used_bytes(), 0u) << device.index();
  }

  const uint32_t passes = 2;
  const std::vector<float> path_frame = render_linear(*stub_, path_id, passes);
  const std::vector<float> knn_frame = render_linear(*stub_, knn_id, passes);
  EXPECT_GT(mean_rgb(path_frame), 0.01);
  EXPECT_GT(mean_rgb(knn_frame), 0.01);
  EXPECT_EQ(mismatches(path_frame, one_device_frame(path, passes), 0), 0u)
      << "the path integrator's samples follow from the pixel alone";
  EXPECT_EQ(mismatches(knn_frame, one_device_frame(knn, passes), 1e-5f), 0u)
      << "knn sums the merged photons in another order";
}

class DurableDevices : public ::testing::Test {
 protected:
  void SetUp() override { data_dir_ = make_temp_dir("caustica-devices"); }
  void TearDown() override {
    if (!HasFailure()) std::filesystem::remove_all(data_dir_);
  }

  // A server on data_dir_ with `extra` flags, waited for until it has restored its scenes.
  std::unique_ptr<ServerProcess> start(std::vector<std::string> extra) {
    return start_restored_server(data_dir_, extra);
  }

  std::filesystem::path data_dir_;
};

TEST_F(DurableDevices, RestoredScenesArePlacedAgain) {
  std::vector<std::string> ids;
  std::vector<float> before;
  {
    std::unique_ptr<ServerProcess> server = start(devices_args(2));
    ASSERT_NE(server, nullptr);
    auto stub = server->stub();
    ids.push_back(upload_scene(*stub, cornell_box(24, 24, 2000, 16, 1), "a"));
    ids.push_back(upload_scene(*stub, cornell_box(24, 24, 2000, 16, 2), "b"));
    before = render_linear(*stub, ids[1], 2);
    ASSERT_EQ(server->terminate(), 0);
  }
  {
    // Restored one by one, each onto the device with the most free budget then.
    std::unique_ptr<ServerProcess> server = start(devices_args(2));
    ASSERT_NE(server, nullptr);
    auto stub = server->stub();
    std::vector<uint32_t> placed;
    for (const std::string& id : ids) {
      const std::vector<uint32_t> devices = devices_of(get_scene(*stub, id));
      ASSERT_EQ(devices.size(), 1u) << id;
      placed.push_back(devices[0]);
    }
    std::sort(placed.begin(), placed.end());
    EXPECT_THAT(placed, ElementsAre(0u, 1u));
    const v1::Stats stats = get_stats(*stub);
    ASSERT_EQ(stats.devices_size(), 2);
    EXPECT_EQ(stats.devices(0).scenes(), 1u);
    EXPECT_EQ(stats.devices(1).scenes(), 1u);
    EXPECT_GT(stats.devices(0).memory_used_bytes(), 0u);
    EXPECT_GT(stats.devices(1).memory_used_bytes(), 0u);
    EXPECT_EQ(mismatches(render_linear(*stub, ids[1], 2), before, 0), 0u);
    ASSERT_EQ(server->terminate(), 0);
  }
  {
    // Another layout on restart: the placement follows the server's flags, not the last run's.
    std::vector<std::string> args = devices_args(3);
    args.push_back("--split-frames");
    std::unique_ptr<ServerProcess> server = start(args);
    ASSERT_NE(server, nullptr);
    auto stub = server->stub();
    for (const std::string& id : ids) {
      EXPECT_THAT(devices_of(get_scene(*stub, id)), ElementsAre(0u, 1u, 2u)) << id;
    }
    EXPECT_GT(mean_rgb(render_linear(*stub, ids[0], 1)), 0.01);
  }
}

TEST(DevicesFlag, BadValuesAreRefusedByName) {
  const std::vector<std::string> values = {
      "''",  "none", "0",
      "-1",  "1.5",  "0,,1",
      "0,x", "65",   absl::StrJoin(std::vector<std::string>(65, "0"), ",")};
  for (const std::string& bad : values) {
    const CommandRun run = run_command(absl::StrCat(
        "'", CAUSTICA_SERVER_BIN, "' --device cpu --listen 127.0.0.1:0 --devices ", bad));
    EXPECT_NE(run.exit_code, 0) << bad << ": " << run.output;
    EXPECT_THAT(run.output, HasSubstr("--devices")) << bad;
  }
}

}  // namespace
}  // namespace caustica::testing
