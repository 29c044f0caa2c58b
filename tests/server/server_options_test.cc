// Flag values the server parses itself: sizes and log levels.
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

}  // namespace
}  // namespace caustica::server
