// Bearer tokens as both sides of the API carry them: the value of the `authorization` metadata
// ("Bearer <token>") and a field of the server's --tokens file. gRPC aborts the whole process when
// a call's metadata holds a byte outside visible ASCII, so every token that comes from a person or
// a browser is checked here before it can reach a call.
#pragma once

#include <string_view>

#include "absl/status/status.h"

namespace caustica::wire {

// RFC 6750's tokens are visible ASCII, 0x21 to 0x7E; a space would also split the header value
// into a scheme and more than one credential. OK for the empty token (none sent), else
// INVALID_ARGUMENT led by `field` and naming the first byte outside:
// "hello.token: byte 0x0a at offset 12 is not visible ASCII (a bearer token is 0x21 to 0x7E)".
absl::Status check_bearer_token(std::string_view token, std::string_view field);

}  // namespace caustica::wire
