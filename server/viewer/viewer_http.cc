#include "server/viewer/viewer_http.h"

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "server/log.h"
#include "server/viewer/viewer_assets.h"

namespace caustica::server::viewer {
namespace {

constexpr char kWebSocketPath[] = "/ws";

// Headers of every page response. The page loads nothing from elsewhere, which the policy
// enforces; no-cache makes browsers revalidate with the ETag, so a new binary's page shows at once.
const std::vector<std::pair<std::string, std::string>>& page_headers() {
  static const auto* headers = new std::vector<std::pair<std::string, std::string>>{
      {"Cache-Control", "no-cache"},
      {"X-Content-Type-Options", "nosniff"},
      {"Referrer-Policy", "no-referrer"},
      {"Content-Security-Policy",
       "default-src 'self'; img-src 'self' blob: data:; connect-src 'self'; "
       "frame-ancestors 'none'"}};
  return *headers;
}

http::HttpResponse serve_asset(const http::HttpRequest& request) {
  if (request.method != "GET" && request.method != "HEAD") {
    http::HttpResponse refused = http::plain_text_response(405, "only GET and HEAD");
    refused.headers.emplace_back("Allow", "GET, HEAD");
    return refused;
  }
  const ViewerAsset* asset = find_viewer_asset(request.path);
  if (asset == nullptr) return http::plain_text_response(404, "not found");
  http::HttpResponse response;
  response.headers = page_headers();
  response.headers.emplace_back("ETag", std::string(asset->etag));
  if (request.header("If-None-Match") == asset->etag) {
    response.status = 304;
    return response;
  }
  response.content_type = std::string(asset->content_type);
  response.body = std::string(asset->body);
  return response;
}

// One WebSocket's session, with the peer as its sink.
class ViewerConnection final : public http::WebSocketHandler, public ViewerSink {
 public:
  ViewerConnection(http::WebSocketPeer& peer, std::shared_ptr<grpc::Channel> channel,
                   const ViewerOptions& options)
      : peer_(peer), session_(std::move(channel), *this, options) {}

  void on_text(std::string_view text) override { session_.handle_text(text); }
  void on_binary(std::string_view) override { session_.handle_binary(); }
  void on_close() override { session_.close(); }

  void send_text(const std::string& text) override { peer_.send_text(text); }
  void send_binary(const std::string& bytes) override { peer_.send_binary(bytes); }

 private:
  http::WebSocketPeer& peer_;
  ViewerSession session_;  // last: its stream thread sends through the peer above
};

}  // namespace

bool same_origin(std::string_view origin, std::string_view host) {
  if (origin.empty()) return true;
  const std::string lower_origin = absl::AsciiStrToLower(std::string(origin));
  const std::string lower_host = absl::AsciiStrToLower(std::string(host));
  return lower_origin == "http://" + lower_host || lower_origin == "https://" + lower_host;
}

http::HttpRoutes viewer_routes(std::shared_ptr<grpc::Channel> channel, ViewerOptions options) {
  http::HttpRoutes routes;
  routes.serve = &serve_asset;
  routes.websocket_path = kWebSocketPath;
  routes.accept_websocket = [](const http::HttpRequest& request) {
    if (same_origin(request.header("Origin"), request.header("Host"))) return true;
    log_line(LogLevel::kWarning,
             absl::StrCat("caustica-server: viewer: refused a WebSocket from origin ",
                          printable(request.header("Origin")), " (host ",
                          printable(request.header("Host")), ")"));
    return false;
  };
  routes.open_websocket = [channel = std::move(channel),
                           options](http::WebSocketPeer& peer) -> std::unique_ptr<http::WebSocketHandler> {
    return std::make_unique<ViewerConnection>(peer, channel, options);
  };
  return routes;
}

absl::StatusOr<std::unique_ptr<ViewerHttpServer>> ViewerHttpServer::start(
    const std::string& listen, std::shared_ptr<grpc::Channel> channel, ViewerOptions options,
    http::HttpLimits limits) {
  absl::StatusOr<std::unique_ptr<http::HttpServer>> server = http::HttpServer::start(
      listen, "--http-listen", viewer_routes(std::move(channel), options), limits);
  if (!server.ok()) return server.status();
  return std::unique_ptr<ViewerHttpServer>(new ViewerHttpServer(*std::move(server)));
}

}  // namespace caustica::server::viewer
