// Conversion of gRPC statuses and the CLI's error line (see rpc_status.h).
#include "client/rpc_status.h"

#include "absl/strings/str_cat.h"

namespace caustica::client {

absl::Status to_absl(const grpc::Status& status) {
  if (status.ok()) return absl::OkStatus();
  return absl::Status(static_cast<absl::StatusCode>(status.error_code()), status.error_message());
}

std::string error_line(std::string_view command, const absl::Status& status) {
  return absl::StrCat("caustica: ", absl::string_view(command.data(), command.size()), ": ",
                      absl::StatusCodeToString(status.code()), ": ", status.message());
}

}  // namespace caustica::client
