#include "proto/wire/api_version.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>

#include "absl/strings/str_format.h"
#include "proto/wire/scene_wire.h"

namespace caustica::wire {

const char* release_version() { return CAUSTICA_RELEASE; }

const std::string& api_version() {
  static const std::string version = [] {
    // The service's file and the files it imports, in import order: the whole API.
    std::string definition;
    const google::protobuf::FileDescriptor* service = v1::Stats::descriptor()->file();
    for (int i = 0; i < service->dependency_count(); ++i) {
      google::protobuf::FileDescriptorProto proto;
      service->dependency(i)->CopyTo(&proto);
      definition += proto.SerializeAsString();
    }
    google::protobuf::FileDescriptorProto proto;
    service->CopyTo(&proto);
    definition += proto.SerializeAsString();
    return absl::StrFormat("v1-%08x", chunk_crc32(definition));
  }();
  return version;
}

v1::VersionInfo own_version() {
  v1::VersionInfo info;
  info.set_server_version(release_version());
  info.set_api_version(api_version());
  return info;
}

std::string version_mismatch(const v1::VersionInfo& server) {
  if (server.api_version() != api_version()) {
    return absl::StrFormat(
        "the server speaks API %s and this client %s (server %s, client %s): calls may be "
        "refused or fields lost; use a client of the server's release",
        server.api_version().empty() ? "(none reported)" : server.api_version(), api_version(),
        server.server_version().empty() ? "(unknown)" : server.server_version(), release_version());
  }
  if (server.server_version() != release_version()) {
    return absl::StrFormat("the server is release %s and this client %s (the same API, %s)",
                           server.server_version(), release_version(), api_version());
  }
  return "";
}

}  // namespace caustica::wire
