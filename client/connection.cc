// Opening a Connection, with the embedded default (see connection.h).
#include "client/connection.h"

#include <arpa/inet.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "client/health_check.h"
#include "proto/wire/api_version.h"
#include "proto/wire/bearer_token.h"

namespace caustica::client {
namespace {

// A server on the default port answers in well under this; nothing listening fails at once.
constexpr auto kProbeTimeout = std::chrono::milliseconds(1500);

bool is_loopback(std::string_view address) {
  // A target with a scheme: its (first) address decides.
  for (std::string_view scheme : {"ipv4:", "ipv6:", "dns:///"}) {
    if (address.starts_with(scheme)) address.remove_prefix(scheme.size());
  }
  return address.starts_with("localhost:") || address.starts_with("127.") ||
         address.starts_with("[::1]:");
}

// "host:port" or "[v6]:port" split in two; the brackets go.
absl::StatusOr<std::pair<std::string, std::string>> split_host_port(const std::string& endpoint) {
  const size_t colon = endpoint.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == endpoint.size()) {
    return absl::InvalidArgumentError(absl::StrCat("--server: '", endpoint, "' is not HOST:PORT"));
  }
  std::string host = endpoint.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
    host = host.substr(1, host.size() - 2);
  }
  return std::pair(host, endpoint.substr(colon + 1));
}

struct Resolved {
  std::vector<std::string> ipv4, ipv6;  // "10.0.0.1:50051", "[fd00::1]:50051"
};

// The addresses of `endpoint` ("host:port"), as gRPC's ipv4: and ipv6: targets spell them.
absl::StatusOr<Resolved> resolve(const std::string& endpoint) {
  absl::StatusOr<std::pair<std::string, std::string>> parts = split_host_port(endpoint);
  if (!parts.ok()) return parts.status();
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  if (const int error = getaddrinfo(parts->first.c_str(), parts->second.c_str(), &hints, &found);
      error != 0) {
    return absl::UnavailableError(
        absl::StrCat("--server: cannot resolve '", endpoint, "': ", gai_strerror(error)));
  }
  Resolved resolved;
  for (const addrinfo* a = found; a != nullptr; a = a->ai_next) {
    char text[INET6_ADDRSTRLEN] = {};
    if (a->ai_family == AF_INET) {
      inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(a->ai_addr)->sin_addr, text,
                sizeof(text));
      const std::string address = absl::StrCat(text, ":", parts->second);
      if (std::find(resolved.ipv4.begin(), resolved.ipv4.end(), address) == resolved.ipv4.end())
        resolved.ipv4.push_back(address);
    } else if (a->ai_family == AF_INET6) {
      inet_ntop(AF_INET6, &reinterpret_cast<const sockaddr_in6*>(a->ai_addr)->sin6_addr, text,
                sizeof(text));
      const std::string address = absl::StrCat("[", text, "]:", parts->second);
      if (std::find(resolved.ipv6.begin(), resolved.ipv6.end(), address) == resolved.ipv6.end())
        resolved.ipv6.push_back(address);
    }
  }
  freeaddrinfo(found);
  return resolved;
}

// "name:port" of a dns: target; gRPC's authority form dns://AUTHORITY/name:port as well.
std::string dns_name(const std::string& target) {
  std::string name = target.substr(4);  // after "dns:"
  if (name.starts_with("//")) {
    const size_t slash = name.find('/', 2);
    name = slash == std::string::npos ? std::string() : name.substr(slash + 1);
  }
  return name;
}

std::vector<std::string> split_list(const std::string& server) {
  std::vector<std::string> entries;
  for (absl::string_view entry : absl::StrSplit(server, ',', absl::SkipWhitespace())) {
    entries.emplace_back(absl::StripAsciiWhitespace(entry));
  }
  return entries;
}

bool is_replicated(const std::string& server) {
  return server.starts_with("dns:") || server.find(',') != std::string::npos;
}

// How long probing one replica may take when --timeout sets no deadline.
constexpr auto kReplicaProbeTimeout = std::chrono::seconds(5);

// How long the version check waits: a server that does not answer by then is reported by the
// command's own call.
constexpr auto kVersionTimeout = std::chrono::seconds(3);

// Asks the server for its version and warns on stderr when it speaks another API or is another
// release, or does not say (a server from before GetVersion). Says nothing when the call fails
// otherwise: the command's own call reports that.
void warn_on_version_mismatch(Connection& connection) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + kVersionTimeout);
  connection.authorize(context);
  v1::VersionInfo server;
  const grpc::Status status =
      connection.stub().GetVersion(&context, v1::GetVersionRequest(), &server);
  std::string warning;
  if (status.error_code() == grpc::StatusCode::UNIMPLEMENTED) {
    warning = "the server does not report its version (it predates this client's API " +
              wire::api_version() + "): calls may be refused or fields lost";
  } else if (status.ok()) {
    warning = wire::version_mismatch(server);
  }
  if (!warning.empty()) std::cerr << "caustica: warning: " << warning << "\n";
}

absl::StatusOr<std::string> read_pem_file(const char* flag, const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return absl::InvalidArgumentError(
        absl::StrCat(flag, ": cannot read ", path.string(), ": ", std::strerror(errno)));
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad() || text.str().empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(flag, ": ", path.string(), " is empty or unreadable"));
  }
  return text.str();
}

bool uses_tls(const ConnectOptions& options) {
  return !options.tls_ca.empty() || !options.tls_cert.empty();
}

}  // namespace

const char kReplicatedServiceConfig[] = R"json({
  "loadBalancingConfig": [{"round_robin": {}}],
  "healthCheckConfig": {"serviceName": ""},
  "methodConfig": [{
    "name": [{"service": "caustica.v1.RenderService", "method": "ListScenes"},
             {"service": "caustica.v1.RenderService", "method": "GetVersion"},
             {"service": "caustica.v1.RenderService", "method": "GetStats"}],
    "retryPolicy": {"maxAttempts": 3, "initialBackoff": "0.1s", "maxBackoff": "1s",
                    "backoffMultiplier": 2, "retryableStatusCodes": ["UNAVAILABLE"]}
  }]
})json";

absl::StatusOr<std::vector<std::string>> replica_targets(const std::string& server) {
  std::vector<std::string> targets;
  if (!is_replicated(server)) return targets;
  if (server.starts_with("dns:")) {
    absl::StatusOr<Resolved> resolved = resolve(dns_name(server));
    if (!resolved.ok()) return resolved.status();
    for (const std::string& a : resolved->ipv4) targets.push_back("ipv4:" + a);
    for (const std::string& a : resolved->ipv6) targets.push_back("ipv6:" + a);
    return targets;
  }
  for (const std::string& entry : split_list(server)) {
    absl::StatusOr<std::pair<std::string, std::string>> parts = split_host_port(entry);
    if (!parts.ok()) return parts.status();
    // A name stays a name, so that its replica is found wherever it moves.
    unsigned char address[sizeof(in6_addr)];
    if (inet_pton(AF_INET, parts->first.c_str(), address) == 1) {
      targets.push_back("ipv4:" + entry);
    } else if (inet_pton(AF_INET6, parts->first.c_str(), address) == 1) {
      targets.push_back(absl::StrCat("ipv6:[", parts->first, "]:", parts->second));
    } else {
      targets.push_back("dns:///" + entry);
    }
  }
  return targets;
}

absl::StatusOr<std::string> balanced_target(const std::string& server) {
  if (server.starts_with("dns:")) return server;
  // gRPC's static lists (ipv4:A,B) take addresses of one family, so names are resolved here.
  std::vector<std::string> ipv4, ipv6;
  bool all_ipv4 = true, all_ipv6 = true;
  for (const std::string& entry : split_list(server)) {
    absl::StatusOr<Resolved> resolved = resolve(entry);
    if (!resolved.ok()) return resolved.status();
    all_ipv4 = all_ipv4 && !resolved->ipv4.empty();
    all_ipv6 = all_ipv6 && !resolved->ipv6.empty();
    if (!resolved->ipv4.empty()) ipv4.push_back(resolved->ipv4.front());
    if (!resolved->ipv6.empty()) ipv6.push_back(resolved->ipv6.front());
  }
  if (all_ipv4) return "ipv4:" + absl::StrJoin(ipv4, ",");
  if (all_ipv6) return "ipv6:" + absl::StrJoin(ipv6, ",");
  return absl::InvalidArgumentError(
      absl::StrCat("--server: the replicas of '", server,
                   "' must all have IPv4 or all IPv6 addresses (or use dns:///NAME:PORT)"));
}

absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> channel_credentials(
    const ConnectOptions& options) {
  if (!options.tls_cert.empty() && options.tls_key.empty()) {
    return absl::InvalidArgumentError("--tls-cert: needs --tls-key");
  }
  if (!options.tls_key.empty() && options.tls_cert.empty()) {
    return absl::InvalidArgumentError("--tls-key: needs --tls-cert");
  }
  if (!uses_tls(options)) return grpc::InsecureChannelCredentials();
  grpc::SslCredentialsOptions ssl;
  if (!options.tls_ca.empty()) {
    absl::StatusOr<std::string> ca = read_pem_file("--tls-ca", options.tls_ca);
    if (!ca.ok()) return ca.status();
    ssl.pem_root_certs = *std::move(ca);
  }
  if (!options.tls_cert.empty()) {
    absl::StatusOr<std::string> cert = read_pem_file("--tls-cert", options.tls_cert);
    if (!cert.ok()) return cert.status();
    absl::StatusOr<std::string> key = read_pem_file("--tls-key", options.tls_key);
    if (!key.ok()) return key.status();
    ssl.pem_cert_chain = *std::move(cert);
    ssl.pem_private_key = *std::move(key);
  }
  return grpc::SslCredentials(ssl);
}

std::shared_ptr<grpc::Channel> make_channel(const std::string& address, int max_message_bytes) {
  return make_channel(address, max_message_bytes, grpc::InsecureChannelCredentials());
}

std::shared_ptr<grpc::Channel> make_channel(
    const std::string& address, int max_message_bytes,
    const std::shared_ptr<grpc::ChannelCredentials>& credentials, int max_reconnect_backoff_ms,
    const std::string& service_config) {
  grpc::ChannelArguments args;
  if (!service_config.empty()) args.SetServiceConfigJSON(service_config);
  if (max_reconnect_backoff_ms > 0) {
    args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, max_reconnect_backoff_ms);
    args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, max_reconnect_backoff_ms);
  }
  args.SetMaxReceiveMessageSize(max_message_bytes);
  args.SetMaxSendMessageSize(max_message_bytes);
  // A proxy from the environment cannot reach this machine's loopback.
  if (is_loopback(address)) args.SetInt(GRPC_ARG_ENABLE_HTTP_PROXY, 0);
  return grpc::CreateCustomChannel(address, credentials, args);
}

absl::StatusOr<std::unique_ptr<Connection>> Connection::open(const ConnectOptions& options) {
  // Checked before any call: gRPC aborts the process on a metadata value it cannot carry, such as
  // a token read from a file with its line ending.
  if (absl::Status token = wire::check_bearer_token(options.token, "--token ($CAUSTICA_TOKEN)");
      !token.ok()) {
    return token;
  }
  absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> credentials =
      channel_credentials(options);
  if (!credentials.ok()) return credentials.status();
  std::unique_ptr<Connection> connection(new Connection());
  const int max_bytes = std::max(1, options.max_message_mb) * (1 << 20);
  connection->address_ = options.server;
  connection->server_arg_ = options.server;
  connection->timeout_s_ = options.timeout_s;
  connection->credentials_ = *credentials;
  connection->max_message_bytes_ = max_bytes;
  connection->max_reconnect_backoff_ms_ = options.max_reconnect_backoff_ms;
  if (is_replicated(options.server)) {
    absl::StatusOr<std::vector<std::string>> replicas = replica_targets(options.server);
    if (!replicas.ok()) return replicas.status();
    if (replicas->empty()) {
      return absl::UnavailableError(absl::StrCat("--server: ", options.server, " has no address"));
    }
    absl::StatusOr<std::string> target = balanced_target(options.server);
    if (!target.ok()) return target.status();
    connection->replicas_ = *std::move(replicas);
    connection->channel_ = make_channel(*target, max_bytes, *credentials,
                                        options.max_reconnect_backoff_ms, kReplicatedServiceConfig);
  }
  if (connection->address_.empty()) {
    const std::shared_ptr<grpc::Channel> probe =
        make_channel(kDefaultServerAddress, max_bytes, *credentials);
    absl::StatusOr<ServingStatus> health =
        check_health(probe, std::chrono::system_clock::now() + kProbeTimeout, false);
    if (health.ok() && *health == ServingStatus::kServing) {
      connection->address_ = kDefaultServerAddress;
      connection->channel_ = probe;
    } else {
      absl::StatusOr<std::unique_ptr<EmbeddedServer>> server =
          EmbeddedServer::start(options.embedded);
      if (!server.ok()) return server.status();
      connection->server_ = *std::move(server);
      connection->address_ = connection->server_->address();
    }
  }
  if (connection->channel_ == nullptr) {
    // The embedded server listens on loopback in plaintext and has no tokens.
    connection->channel_ = connection->embedded()
                               ? make_channel(connection->address_, max_bytes)
                               : make_channel(connection->address_, max_bytes, *credentials,
                                              options.max_reconnect_backoff_ms);
  }
  if (!connection->embedded()) {
    connection->token_ = options.token;
    if (!connection->token_.empty() && !uses_tls(options) && !is_loopback(connection->address_)) {
      std::cerr << "caustica: warning: the token goes to " << connection->address_
                << " unencrypted (no --tls-ca)\n";
    }
  }
  connection->stub_ = v1::RenderService::NewStub(connection->channel_);
  warn_on_version_mismatch(*connection);
  return connection;
}

std::unique_ptr<grpc::ClientContext> Connection::new_context() const {
  auto context = std::make_unique<grpc::ClientContext>();
  if (timeout_s_ > 0) {
    context->set_deadline(std::chrono::system_clock::now() +
                          std::chrono::microseconds(static_cast<int64_t>(timeout_s_ * 1e6)));
  }
  authorize(*context);
  return context;
}

void Connection::authorize(grpc::ClientContext& context) const {
  if (!token_.empty()) context.AddMetadata("authorization", "Bearer " + token_);
}

std::shared_ptr<grpc::Channel> Connection::replica_channel(const std::string& replica) const {
  return make_channel(replica, max_message_bytes_, credentials_, max_reconnect_backoff_ms_);
}

absl::Status Connection::pin_to_scene(const std::string& scene_id) {
  if (!replicated()) return absl::OkStatus();
  std::vector<std::string> unreachable;
  std::string last_error;
  for (const std::string& replica : replicas_) {
    std::shared_ptr<grpc::Channel> channel = replica_channel(replica);
    std::unique_ptr<v1::RenderService::Stub> stub = v1::RenderService::NewStub(channel);
    grpc::ClientContext context;
    context.set_deadline(
        std::chrono::system_clock::now() +
        (timeout_s_ > 0
             ? std::chrono::microseconds(static_cast<int64_t>(timeout_s_ * 1e6))
             : std::chrono::duration_cast<std::chrono::microseconds>(kReplicaProbeTimeout)));
    authorize(context);
    v1::GetSceneRequest request;
    request.set_scene_id(scene_id);
    v1::SceneInfo info;
    const grpc::Status status = stub->GetScene(&context, request, &info);
    if (status.ok()) {
      channel_ = std::move(channel);
      stub_ = std::move(stub);
      address_ = replica;
      return absl::OkStatus();
    }
    switch (status.error_code()) {
      case grpc::StatusCode::NOT_FOUND:
        break;
      case grpc::StatusCode::UNAVAILABLE:
      case grpc::StatusCode::DEADLINE_EXCEEDED:
        unreachable.push_back(replica);
        last_error = status.error_message();
        break;
      default:  // e.g. a bad token: every replica would say the same
        return absl::Status(static_cast<absl::StatusCode>(status.error_code()),
                            absl::StrCat(replica, ": ", status.error_message()));
    }
  }
  if (!unreachable.empty()) {
    return absl::UnavailableError(absl::StrCat(
        "scene '", scene_id, "' is on none of the replicas of ", server_arg_,
        " that answered; it may have been on ", absl::StrJoin(unreachable, ", "),
        ", which cannot be reached (", last_error, "): upload it again if that replica is gone"));
  }
  return absl::NotFoundError(absl::StrCat("no scene '", scene_id, "' on any replica of ",
                                          server_arg_, " (asked ", absl::StrJoin(replicas_, ", "),
                                          ")"));
}

absl::Status Connection::pin_any() {
  if (!replicated()) return absl::OkStatus();
  // A random first replica, so that commands spread their scenes over the fleet.
  const size_t first = std::random_device()() % replicas_.size();
  std::vector<std::string> failures;
  for (size_t i = 0; i < replicas_.size(); ++i) {
    const std::string& replica = replicas_[(first + i) % replicas_.size()];
    std::shared_ptr<grpc::Channel> channel = replica_channel(replica);
    absl::StatusOr<ServingStatus> health =
        check_health(channel, std::chrono::system_clock::now() + kReplicaProbeTimeout, false);
    if (health.ok() && *health == ServingStatus::kServing) {
      channel_ = std::move(channel);
      stub_ = v1::RenderService::NewStub(channel_);
      address_ = replica;
      return absl::OkStatus();
    }
    failures.push_back(absl::StrCat(
        replica, ": ", health.ok() ? "not serving" : std::string(health.status().message())));
  }
  return absl::UnavailableError(absl::StrCat("no replica of ", server_arg_, " is serving (",
                                             absl::StrJoin(failures, "; "), ")"));
}

}  // namespace caustica::client
