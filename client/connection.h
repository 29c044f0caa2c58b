// A connection to a Caustica server: the channel (with a message size limit that fits whole
// frames, and TLS when asked for), the RenderService stub, per-call deadlines and bearer token,
// and the embedded default server when the caller named none.
#pragma once

#include <grpcpp/channel.h>
#include <grpcpp/client_context.h>
#include <grpcpp/security/credentials.h>

#include <filesystem>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.grpc.pb.h"
#include "client/embedded_server.h"
#include "client/rpc_status.h"

namespace caustica::client {

// Where a server is looked for when none is named.
inline constexpr char kDefaultServerAddress[] = "localhost:50051";

struct ConnectOptions {
  // "host:port". Empty: kDefaultServerAddress when a server there reports SERVING, else an
  // embedded caustica-server that lives as long as the Connection.
  std::string server;
  double timeout_s = 0;     // deadline of every call; 0 = none
  int max_message_mb = 64;  // largest message received (a frame in one piece) or sent
  // Sent as `authorization: Bearer <token>` with every call to a server started with --tokens;
  // never to the embedded server, which has no tokens.
  std::string token;
  // TLS is on when tls_ca or tls_cert is set. tls_ca: PEM CA certificates that the server's
  // certificate must chain to (empty: gRPC's default roots). tls_cert and tls_key: a client
  // certificate, for servers that require one (--tls-client-ca).
  std::filesystem::path tls_ca;
  std::filesystem::path tls_cert;
  std::filesystem::path tls_key;
  EmbeddedServerOptions embedded;
};

// The channel credentials `options` ask for: TLS with the PEM files read (errors name the flag
// and the file), or plaintext.
absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> channel_credentials(
    const ConnectOptions& options);

class Connection {
 public:
  static absl::StatusOr<std::unique_ptr<Connection>> open(const ConnectOptions& options);

  v1::RenderService::Stub& stub() { return *stub_; }
  const std::shared_ptr<grpc::Channel>& channel() const { return channel_; }
  // A context for one call, carrying the deadline of --timeout and the token.
  std::unique_ptr<grpc::ClientContext> new_context() const;
  // Adds the token to a context made elsewhere, e.g. one with a deadline of its own. gRPC's
  // AccessTokenCredentials would refuse to send it over plaintext, which development servers use.
  void authorize(grpc::ClientContext& context) const;
  const std::string& address() const { return address_; }

  // One unary call with the deadline of --timeout, e.g. call(&Stub::GetScene, request).
  template <typename Request, typename Response>
  absl::StatusOr<Response> call(grpc::Status (v1::RenderService::Stub::*method)(
                                    grpc::ClientContext*, const Request&, Response*),
                                const Request& request) {
    Response response;
    std::unique_ptr<grpc::ClientContext> context = new_context();
    const grpc::Status status = (stub_.get()->*method)(context.get(), request, &response);
    if (!status.ok()) return to_absl(status);
    return response;
  }

  bool embedded() const { return server_ != nullptr; }
  // The embedded server's data directory; empty without one (or without an embedded server).
  std::filesystem::path embedded_data_dir() const {
    return server_ ? server_->data_dir() : std::filesystem::path();
  }

 private:
  Connection() = default;

  // Declared first so that it is destroyed last, after the channel to it.
  std::unique_ptr<EmbeddedServer> server_;
  std::string address_;
  double timeout_s_ = 0;
  std::string token_;  // empty: none sent
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::RenderService::Stub> stub_;
};

// A channel to `address` that accepts messages up to `max_message_bytes` both ways: plaintext, or
// with `credentials`.
std::shared_ptr<grpc::Channel> make_channel(const std::string& address, int max_message_bytes);
std::shared_ptr<grpc::Channel> make_channel(
    const std::string& address, int max_message_bytes,
    const std::shared_ptr<grpc::ChannelCredentials>& credentials);

}  // namespace caustica::client
