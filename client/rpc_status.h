// gRPC statuses as absl::Status, and the one-line error format of the `caustica` CLI. gRPC and
// Abseil number their status codes alike, so the conversion keeps the code a person acts on.
#pragma once

#include <grpcpp/support/status.h>

#include <string>
#include <string_view>

#include "absl/status/status.h"

namespace caustica::client {

absl::Status to_absl(const grpc::Status& status);

// "caustica: <command>: <CODE>: <message>", e.g. "caustica: render: NOT_FOUND: no scene 'x'".
std::string error_line(std::string_view command, const absl::Status& status);

}  // namespace caustica::client
