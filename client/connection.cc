// Opening a Connection, with the embedded default (see connection.h).
#include "client/connection.h"

#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>

#include <chrono>
#include <iostream>
#include <string>

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

}  // namespace

std::shared_ptr<grpc::Channel> make_channel(const std::string& address, int max_message_bytes) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(max_message_bytes);
  args.SetMaxSendMessageSize(max_message_bytes);
  // A proxy from the environment cannot reach this machine's loopback.
  if (is_loopback(address)) args.SetInt(GRPC_ARG_ENABLE_HTTP_PROXY, 0);
  return grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
}

absl::StatusOr<std::unique_ptr<Connection>> Connection::open(const ConnectOptions& options) {
  std::unique_ptr<Connection> connection(new Connection());
  const int max_bytes = std::max(1, options.max_message_mb) * (1 << 20);
  connection->address_ = options.server;
  connection->timeout_s_ = options.timeout_s;
  if (connection->address_.empty()) {
    const std::shared_ptr<grpc::Channel> probe = make_channel(kDefaultServerAddress, max_bytes);
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
    connection->channel_ = make_channel(connection->address_, max_bytes);
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
  return context;
}

}  // namespace caustica::client
