// Server log lines on stderr: a timestamp, a level and one line of text, written whole so lines of
// concurrent requests never interleave. `--log-level` drops the levels below it.
#pragma once

#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace caustica::server {

enum class LogLevel { kDebug = 0, kInfo = 1, kWarning = 2, kError = 3 };

// "debug", "info", "warning" (or "warn"), "error".
absl::StatusOr<LogLevel> parse_log_level(std::string_view name);
void set_log_level(LogLevel level);
bool log_enabled(LogLevel level);
void log_line(LogLevel level, std::string_view text);
// `text` from a client, fit for a log line: control bytes, DEL and non-ASCII bytes escaped (\n,
// \x7f, \xc3\xa9), and quotes and backslashes too, so that no client can forge a line, write
// terminal escapes into the log or make its text read as ours. Every client string that goes into
// a log line goes through it: ids, names, peers, and status messages that quote a request.
std::string printable(std::string_view text);

}  // namespace caustica::server
