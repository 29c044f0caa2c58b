// What a server and a client say of their own build, to find out whether they understand each
// other: the release, and the API version, which follows from the API's definition itself so that
// no one has to remember to raise it.
#pragma once

#include <string>

#include "caustica/v1/render_service.pb.h"

namespace caustica::wire {

// The release this program was built as, e.g. "0.1.0".
const char* release_version();

// "v1-" and the CRC-32 (8 hex digits) of the caustica.v1 .proto files' descriptors as compiled
// into this program: any change to a message, field or call changes it.
const std::string& api_version();

// This program's VersionInfo.
v1::VersionInfo own_version();

// Empty when `server` speaks this program's API and is this program's release; else a sentence
// for a warning, saying what differs and what may follow from it.
std::string version_mismatch(const v1::VersionInfo& server);

}  // namespace caustica::wire
