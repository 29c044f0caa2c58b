// Opening a Connection, with the embedded default (see connection.h).
#include "client/connection.h"

#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include "absl/strings/str_cat.h"
#include "client/health_check.h"
#include "proto/wire/api_version.h"

namespace caustica::client {
namespace {

// A server on the default port answers in well under this; nothing listening fails at once.
constexpr auto kProbeTimeout = std::chrono::milliseconds(1500);

bool is_loopback(const std::string& address) {
  return address.rfind("localhost:", 0) == 0 || address.rfind("127.", 0) == 0 ||
         address.rfind("[::1]:", 0) == 0;
}

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
    const std::shared_ptr<grpc::ChannelCredentials>& credentials) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(max_message_bytes);
  args.SetMaxSendMessageSize(max_message_bytes);
  // A proxy from the environment cannot reach this machine's loopback.
  if (is_loopback(address)) args.SetInt(GRPC_ARG_ENABLE_HTTP_PROXY, 0);
  return grpc::CreateCustomChannel(address, credentials, args);
}

absl::StatusOr<std::unique_ptr<Connection>> Connection::open(const ConnectOptions& options) {
  absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> credentials =
      channel_credentials(options);
  if (!credentials.ok()) return credentials.status();
  std::unique_ptr<Connection> connection(new Connection());
  const int max_bytes = std::max(1, options.max_message_mb) * (1 << 20);
  connection->address_ = options.server;
  connection->timeout_s_ = options.timeout_s;
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
                               : make_channel(connection->address_, max_bytes, *credentials);
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

}  // namespace caustica::client
