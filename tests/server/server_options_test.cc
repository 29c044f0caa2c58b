// Flag values the server parses itself: sizes, log levels and device lists.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "server/log.h"
#include "server/server_main.h"

namespace caustica::server {
namespace {

TEST(ParseByteSize, UnitsAndPlainBytes) {
  EXPECT_EQ(parse_byte_size("8G").value(), size_t{8} << 30);
  EXPECT_EQ(parse_byte_size("512M").value(), size_t{512} << 20);
  EXPECT_EQ(parse_byte_size("512MiB").value(), size_t{512} << 20);
  EXPECT_EQ(parse_byte_size("64kb").value(), size_t{64} << 10);
  EXPECT_EQ(parse_byte_size("1.5G").value(), size_t{3} << 29);
  EXPECT_EQ(parse_byte_size("1T").value(), size_t{1} << 40);
  EXPECT_EQ(parse_byte_size("123456").value(), 123456u);
  EXPECT_EQ(parse_byte_size(" 2g ").value(), size_t{2} << 30);
  for (const char* bad : {"", "G", "-1G", "12X", "1e30", "nan", "8 G B"}) {
    EXPECT_EQ(parse_byte_size(bad).status().code(), absl::StatusCode::kInvalidArgument) << bad;
  }
}

TEST(ParseLogLevel, Names) {
  EXPECT_EQ(parse_log_level("debug").value(), LogLevel::kDebug);
  EXPECT_EQ(parse_log_level("info").value(), LogLevel::kInfo);
  EXPECT_EQ(parse_log_level("warn").value(), LogLevel::kWarning);
  EXPECT_EQ(parse_log_level("error").value(), LogLevel::kError);
  EXPECT_FALSE(parse_log_level("verbose").ok());
}

using ::testing::ElementsAre;
using ::testing::HasSubstr;

TEST(ParseDevices, AllCountsAndListsOnTheGpu) {
  EXPECT_THAT(parse_devices("all", DeviceKind::kCuda, 4).value(), ElementsAre(0, 1, 2, 3));
  EXPECT_THAT(parse_devices("2", DeviceKind::kCuda, 4).value(), ElementsAre(0, 1));
  EXPECT_THAT(parse_devices("4", DeviceKind::kCuda, 4).value(), ElementsAre(0, 1, 2, 3));
  EXPECT_THAT(parse_devices("3,1", DeviceKind::kCuda, 4).value(), ElementsAre(3, 1));
  EXPECT_THAT(parse_devices(" 0, 0 ", DeviceKind::kCuda, 1).value(), ElementsAre(0, 0));
  // Without a GPU, `all` leaves the explanation to the backend.
  EXPECT_THAT(parse_devices("all", DeviceKind::kCuda, 0).value(), ElementsAre(0));
}

TEST(ParseDevices, OnTheCpuOnlyTheNumberCounts) {
  EXPECT_THAT(parse_devices("all", DeviceKind::kCpu, 1).value(), ElementsAre(0));
  EXPECT_THAT(parse_devices("3", DeviceKind::kCpu, 1).value(), ElementsAre(0, 0, 0));
  EXPECT_THAT(parse_devices("0,5", DeviceKind::kCpu, 1).value(), ElementsAre(0, 0));
  EXPECT_EQ(parse_devices("64", DeviceKind::kCpu, 1).value().size(), 64u);
}

TEST(ParseDevices, BadValuesNameTheFlagAndTheValue) {
  const std::string many = [] {
    std::string list = "0";
    for (int i = 0; i < 64; ++i) list += ",0";
    return list;
  }();
  const std::vector<std::string> values = {"",   " ",    "none", "0",  "-1",  "+1", "1.5",
                                           "2x", "0,,1", "0,",   ",0", "0,x", "65", many};
  for (const std::string& bad : values) {
    for (DeviceKind kind : {DeviceKind::kCpu, DeviceKind::kCuda}) {
      absl::StatusOr<std::vector<int>> devices = parse_devices(bad, kind, 8);
      ASSERT_EQ(devices.status().code(), absl::StatusCode::kInvalidArgument) << "'" << bad << "'";
      EXPECT_THAT(devices.status().message(), HasSubstr("--devices '" + bad + "'"));
    }
  }
  // Beyond the visible GPUs.
  EXPECT_THAT(parse_devices("3", DeviceKind::kCuda, 2).status().message(),
              HasSubstr("asks for 3 GPUs but 2 GPUs are visible"));
  EXPECT_THAT(parse_devices("0,2", DeviceKind::kCuda, 2).status().message(),
              HasSubstr("no GPU 2: 2 GPUs are visible (0 to 1)"));
  EXPECT_FALSE(parse_devices("0", DeviceKind::kCuda, 0).ok());
}

TEST(ServerStart, TransportMemoryBelowTwoMessagesIsRefusedByName) {
  ServerOptions options;
  options.listen = "127.0.0.1:0";
  options.device = "cpu";
  options.max_message_mb = 64;
  options.transport_memory_mb = 100;
  absl::StatusOr<std::unique_ptr<Server>> server = Server::start(options);
  ASSERT_FALSE(server.ok());
  EXPECT_THAT(server.status().message(),
              HasSubstr("--transport-memory-mb: 100 is less than twice --max-message-mb (64)"));
}

}  // namespace
}  // namespace caustica::server
