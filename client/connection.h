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
#include <vector>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.grpc.pb.h"
#include "client/embedded_server.h"
#include "client/rpc_status.h"

namespace caustica::client {

// Where a server is looked for when none is named.
inline constexpr char kDefaultServerAddress[] = "localhost:50051";

struct ConnectOptions {
  // "host:port". Empty: kDefaultServerAddress when a server there reports SERVING, else an
  // embedded caustica-server that lives as long as the Connection. Replicas of one service:
  // "host:port,host:port,..." or "dns:///name:port" (every address the name resolves to).
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
  // The longest wait between attempts to reconnect to a server that is down; 0: gRPC's default,
  // which grows to minutes. Commands that wait for replicas to come back keep it short.
  int max_reconnect_backoff_ms = 0;
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
  // The replica a scene-bound call went to once pinned, else what --server named.
  const std::string& address() const { return address_; }

  // With several replicas (see ConnectOptions::server), stateless calls go round-robin over
  // those that pass gRPC's health checks, retried on UNAVAILABLE; a scene lives on one replica,
  // so calls about it must be pinned there first. Both pins are no-ops with one server.
  bool replicated() const { return !replicas_.empty(); }
  const std::vector<std::string>& replicas() const { return replicas_; }
  // Points stub() at the replica that holds `scene_id`, asking each with GetScene. NOT_FOUND
  // naming the replicas asked when none has it; UNAVAILABLE naming the unreachable ones when
  // none of the others has it, since one of those may have held it.
  absl::Status pin_to_scene(const std::string& scene_id);
  // Points stub() at one replica that reports SERVING, for an upload and the calls on its scene.
  absl::Status pin_any();
  // A channel to one replica alone (from replicas()).
  std::shared_ptr<grpc::Channel> replica_channel(const std::string& replica) const;

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
  std::vector<std::string> replicas_;  // gRPC targets of the single replicas; empty: one server
  std::shared_ptr<grpc::ChannelCredentials> credentials_;
  int max_message_bytes_ = 0;
  int max_reconnect_backoff_ms_ = 0;
  std::string server_arg_;  // --server as given
};

// The replicas `server` names: the entries of "A,B,C", or every address of "dns:///name:port",
// each as a gRPC target of that one replica ("ipv4:10.0.0.1:50051"); empty for a single server.
absl::StatusOr<std::vector<std::string>> replica_targets(const std::string& server);
// The gRPC target of the channel that spreads calls over `server`'s replicas.
absl::StatusOr<std::string> balanced_target(const std::string& server);
// The service config of that channel: round_robin over healthy replicas, and retries on
// UNAVAILABLE for the calls that do not concern one scene.
extern const char kReplicatedServiceConfig[];

// A channel to `address` that accepts messages up to `max_message_bytes` both ways: plaintext, or
// with `credentials`.
std::shared_ptr<grpc::Channel> make_channel(const std::string& address, int max_message_bytes);
std::shared_ptr<grpc::Channel> make_channel(
    const std::string& address, int max_message_bytes,
    const std::shared_ptr<grpc::ChannelCredentials>& credentials, int max_reconnect_backoff_ms = 0,
    const std::string& service_config = "");

}  // namespace caustica::client
