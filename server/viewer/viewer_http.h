// --http-listen: the browser viewer's HTTP port (server/http). It serves the embedded page
// (viewer_assets.h) and, at /ws, one WebSocket per page, each a ViewerSession that talks to this
// server's RenderService over the in-process channel. Plaintext only for now.
#pragma once

#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "server/http/http_server.h"
#include "server/viewer/viewer_session.h"

namespace caustica::server::viewer {

// Whether a WebSocket upgrade may proceed: browsers send Origin, which must name this very host,
// so that a page from elsewhere cannot drive the viewer with the user's loopback access. Clients
// that send no Origin (not browsers) are allowed: they could call gRPC directly anyway.
bool same_origin(std::string_view origin, std::string_view host);

// The page and the WebSocket route, for HttpServer.
http::HttpRoutes viewer_routes(std::shared_ptr<grpc::Channel> channel, ViewerOptions options);

class ViewerHttpServer {
 public:
  // Listens on `listen` (port 0 picks a free one) and serves sessions over `channel`.
  static absl::StatusOr<std::unique_ptr<ViewerHttpServer>> start(
      const std::string& listen, std::shared_ptr<grpc::Channel> channel,
      ViewerOptions options = {}, http::HttpLimits limits = {});

  int port() const { return http_->port(); }
  // Closes every WebSocket (ending its frame stream) and stops listening. Idempotent.
  void stop() { http_->stop(); }

 private:
  explicit ViewerHttpServer(std::unique_ptr<http::HttpServer> http) : http_(std::move(http)) {}
  std::unique_ptr<http::HttpServer> http_;
};

}  // namespace caustica::server::viewer
