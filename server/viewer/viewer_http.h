// --http-listen: the browser viewer's HTTP server (Debian's civetweb). It serves the embedded page
// (viewer_assets.h) and, at /ws, one WebSocket per page, each a ViewerSession that talks to this
// server's RenderService over the in-process channel. Plaintext only for now.
#pragma once

#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "server/viewer/viewer_session.h"

struct mg_context;

namespace caustica::server::viewer {

// civetweb's listening_ports entry for a --http-listen HOST:PORT: "127.0.0.1:8080";
// "localhost" as 127.0.0.1, an empty host (":8080") as every interface ("8080").
// INVALID_ARGUMENT for a missing or non-numeric port, or an IPv6 host (civetweb here has none).
absl::StatusOr<std::string> civetweb_listening_port(std::string_view listen);

// Whether a WebSocket upgrade may proceed: browsers send Origin, which must name this very host,
// so that a page from elsewhere cannot drive the viewer with the user's loopback access. Clients
// that send no Origin (not browsers) are allowed: they could call gRPC directly anyway.
bool same_origin(std::string_view origin, std::string_view host);

class ViewerHttpServer {
 public:
  // Listens on `listen` (port 0 picks a free one) and serves sessions over `channel`.
  static absl::StatusOr<std::unique_ptr<ViewerHttpServer>> start(
      const std::string& listen, std::shared_ptr<grpc::Channel> channel,
      ViewerOptions options = {});
  ~ViewerHttpServer();

  int port() const { return port_; }
  // Closes every WebSocket (ending its frame stream) and stops listening. Idempotent.
  void stop();

  // For civetweb's callbacks.
  struct Callbacks;

 private:
  ViewerHttpServer() = default;
  mg_context* context_ = nullptr;
  int port_ = 0;
  std::shared_ptr<grpc::Channel> channel_;
  ViewerOptions options_;
};

}  // namespace caustica::server::viewer
