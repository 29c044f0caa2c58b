#include "proto/wire/bearer_token.h"

#include "absl/strings/str_format.h"

namespace caustica::wire {

absl::Status check_bearer_token(std::string_view token, std::string_view field) {
  for (size_t offset = 0; offset < token.size(); ++offset) {
    const auto byte = static_cast<unsigned char>(token[offset]);
    if (byte < 0x21 || byte > 0x7e) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s: byte 0x%02x at offset %d is not visible ASCII (a bearer token is 0x21 to 0x7E)",
          field, byte, offset));
    }
  }
  return absl::OkStatus();
}

}  // namespace caustica::wire
