// A connection to a Caustica server: the channel (with a message size limit that fits whole
// frames), the RenderService stub, per-call deadlines, and the embedded default server when the
// caller named none.
#pragma once

#include <grpcpp/channel.h>
#include <grpcpp/client_context.h>

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
  EmbeddedServerOptions embedded;
};

class Connection {
 public:
  static absl::StatusOr<std::unique_ptr<Connection>> open(const ConnectOptions& options);

  v1::RenderService::Stub& stub() { return *stub_; }
  const std::shared_ptr<grpc::Channel>& channel() const { return channel_; }
  // A context for one call, carrying the deadline of --timeout.
  std::unique_ptr<grpc::ClientContext> new_context() const;
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

 private:
  Connection() = default;

  // Declared first so that it is destroyed last, after the channel to it.
  std::unique_ptr<EmbeddedServer> server_;
  std::string address_;
  double timeout_s_ = 0;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::RenderService::Stub> stub_;
};

// A channel to `address` that accepts messages up to `max_message_bytes` both ways.
std::shared_ptr<grpc::Channel> make_channel(const std::string& address, int max_message_bytes);

}  // namespace caustica::client
