// Client bytes in the server's log: printable() on its own, a log line built with it, and the real
// server's request line for a call whose scene id is meant to forge a line and clear a terminal.
#include "server/log.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "absl/strings/str_cat.h"
#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

using server::printable;
using ::testing::HasSubstr;
using ::testing::Not;

TEST(Log, PrintableEscapesEveryByteOutsidePrintableAscii) {
  EXPECT_EQ(printable("s-0123abcd ('cornell box')"), "s-0123abcd (\\'cornell box\\')");
  EXPECT_EQ(printable("a\nb"), "a\\nb");
  EXPECT_EQ(printable("\r\n"), "\\r\\n");
  EXPECT_EQ(printable("\t"), "\\t");
  EXPECT_EQ(printable(std::string(1, '\0')), "\\x00");
  EXPECT_EQ(printable("\x7f"), "\\x7f");
  EXPECT_EQ(printable("\xc3\xa9"), "\\xc3\\xa9");
  EXPECT_EQ(printable("\x1b[2J"), "\\x1b[2J");
  // The backslash too, so that a client's own "\n" cannot pass for an escaped newline.
  EXPECT_EQ(printable("\\n"), "\\\\n");
}

TEST(Log, ALineWithClientBytesStaysOneLine) {
  ::testing::internal::CaptureStderr();
  server::log_line(server::LogLevel::kWarning,
                   absl::StrCat("GetScene scene=", printable("x\n2026-01-01T00:00:00.000Z E y")));
  const std::string written = ::testing::internal::GetCapturedStderr();
  EXPECT_THAT(written, HasSubstr(" W GetScene scene=x\\n2026-01-01T00:00:00.000Z E y\n"));
  EXPECT_EQ(written.find('\n'), written.size() - 1) << written;
}

TEST_F(ServerTest, ClientBytesInRequestLinesAreEscaped) {
  const std::string forged = "s-\n2026-01-01T00:00:00.000Z I forged\x1b[2J\xc3\xa9";
  EXPECT_EQ(get_scene_status(*stub_, forged).error_code(), grpc::StatusCode::NOT_FOUND);
  const std::string log = server_->log();
  EXPECT_THAT(log, HasSubstr("GetScene scene=s-\\n2026-01-01T00:00:00.000Z I forged\\x1b[2J"
                             "\\xc3\\xa9"));
  EXPECT_THAT(log, Not(HasSubstr("\n2026-01-01T00:00:00.000Z I forged")));
  EXPECT_THAT(log, Not(HasSubstr("\x1b")));
}

}  // namespace
}  // namespace caustica::testing
