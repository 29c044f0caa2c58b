#include "server/viewer/viewer_http.h"

#include <civetweb.h>

#include <charconv>
#include <mutex>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "server/log.h"
#include "server/viewer/viewer_assets.h"

namespace caustica::server::viewer {
namespace {

constexpr char kWebSocketPath[] = "/ws";

// Headers of every page response. The page loads nothing from elsewhere, which the policy
// enforces; no-cache makes browsers revalidate with the ETag, so a new binary's page shows at once.
constexpr char kPageHeaders[] =
    "Cache-Control: no-cache\r\n"
    "X-Content-Type-Options: nosniff\r\n"
    "Referrer-Policy: no-referrer\r\n"
    "Content-Security-Policy: default-src 'self'; img-src 'self' blob: data:; "
    "connect-src 'self'; frame-ancestors 'none'\r\n";

// One WebSocket: its session, and the lock that keeps the session's two threads from
// interleaving their writes.
class Connection final : public ViewerSink {
 public:
  Connection(mg_connection* connection, std::shared_ptr<grpc::Channel> channel,
             const ViewerOptions& options)
      : connection_(connection), session_(std::move(channel), *this, options) {}

  void send_text(const std::string& text) override { write(MG_WEBSOCKET_OPCODE_TEXT, text); }
  void send_binary(const std::string& bytes) override { write(MG_WEBSOCKET_OPCODE_BINARY, bytes); }
  ViewerSession& session() { return session_; }

 private:
  void write(int opcode, const std::string& bytes) {
    std::lock_guard lock(write_mutex_);
    mg_websocket_write(connection_, opcode, bytes.data(), bytes.size());
  }

  mg_connection* connection_;
  std::mutex write_mutex_;
  ViewerSession session_;  // last: its stream thread writes through the members above
};

}  // namespace

absl::StatusOr<std::string> civetweb_listening_port(std::string_view listen_view) {
  const std::string listen(listen_view);
  const size_t colon = listen.rfind(':');
  if (colon == std::string_view::npos) {
    return absl::InvalidArgumentError(
        absl::StrCat("--http-listen: '", listen, "' is not HOST:PORT"));
  }
  std::string host = listen.substr(0, colon);
  const std::string port = listen.substr(colon + 1);
  int number = -1;
  const auto [end, error] = std::from_chars(port.data(), port.data() + port.size(), number);
  if (port.empty() || error != std::errc() || end != port.data() + port.size() || number < 0 ||
      number > 65535) {
    return absl::InvalidArgumentError(
        absl::StrCat("--http-listen: '", listen, "' has no port number"));
  }
  if (host.find(':') != std::string::npos || host.starts_with('[')) {
    return absl::InvalidArgumentError(
        absl::StrCat("--http-listen: '", listen, "': IPv6 addresses are not supported"));
  }
  if (host.empty() || host == "0.0.0.0") return std::to_string(number);
  if (absl::AsciiStrToLower(host) == "localhost") host = "127.0.0.1";
  return absl::StrCat(host, ":", number);
}

bool same_origin(std::string_view origin, std::string_view host) {
  if (origin.empty()) return true;
  const std::string lower_origin = absl::AsciiStrToLower(std::string(origin));
  const std::string lower_host = absl::AsciiStrToLower(std::string(host));
  return lower_origin == "http://" + lower_host || lower_origin == "https://" + lower_host;
}

struct ViewerHttpServer::Callbacks {
  static int serve_asset(mg_connection* connection, void*) {
    const mg_request_info* request = mg_get_request_info(connection);
    const std::string_view method = request->request_method;
    if (method != "GET" && method != "HEAD") {
      mg_send_http_error(connection, 405, "%s", "only GET and HEAD");
      return 405;
    }
    const ViewerAsset* asset = find_viewer_asset(request->local_uri);
    if (asset == nullptr) {
      mg_send_http_error(connection, 404, "%s", "not found");
      return 404;
    }
    const char* if_none_match = mg_get_header(connection, "If-None-Match");
    if (if_none_match != nullptr && std::string_view(if_none_match) == asset->etag) {
      mg_printf(connection,
                "HTTP/1.1 304 Not Modified\r\nETag: %.*s\r\n%sContent-Length: 0\r\n\r\n",
                static_cast<int>(asset->etag.size()), asset->etag.data(), kPageHeaders);
      return 304;
    }
    mg_printf(connection,
              "HTTP/1.1 200 OK\r\nContent-Type: %.*s\r\nContent-Length: %zu\r\nETag: %.*s\r\n%s"
              "\r\n",
              static_cast<int>(asset->content_type.size()), asset->content_type.data(),
              asset->body.size(), static_cast<int>(asset->etag.size()), asset->etag.data(),
              kPageHeaders);
    if (method == "GET") mg_write(connection, asset->body.data(), asset->body.size());
    return 200;
  }

  static int websocket_connect(const mg_connection* connection, void*) {
    auto* mutable_connection = const_cast<mg_connection*>(connection);
    const char* origin = mg_get_header(mutable_connection, "Origin");
    const char* host = mg_get_header(mutable_connection, "Host");
    if (!same_origin(origin ? origin : "", host ? host : "")) {
      log_line(LogLevel::kWarning,
               absl::StrCat("caustica-server: viewer: refused a WebSocket from origin ",
                            origin ? origin : "", " (host ", host ? host : "", ")"));
      return 1;
    }
    return 0;
  }

  static void websocket_ready(mg_connection* connection, void* data) {
    auto* server = static_cast<ViewerHttpServer*>(data);
    mg_set_user_connection_data(connection,
                                new Connection(connection, server->channel_, server->options_));
  }

  static int websocket_data(mg_connection* connection, int bits, char* bytes, size_t size, void*) {
    auto* open = static_cast<Connection*>(mg_get_user_connection_data(connection));
    if (open == nullptr) return 0;
    const int opcode = bits & 0x0f;
    const bool final_fragment = (bits & 0x80) != 0;
    switch (opcode) {
      case MG_WEBSOCKET_OPCODE_TEXT:
        if (!final_fragment) {
          open->send_text(
              error_message(absl::InvalidArgumentError("fragmented messages are not accepted")));
          return 1;
        }
        open->session().handle_text(std::string_view(bytes, size));
        return 1;
      case MG_WEBSOCKET_OPCODE_BINARY:
      case MG_WEBSOCKET_OPCODE_CONTINUATION:
        open->session().handle_binary();
        return 1;
      case MG_WEBSOCKET_OPCODE_CONNECTION_CLOSE:
        return 0;
      default:  // ping and pong
        return 1;
    }
  }

  static void websocket_close(const mg_connection* connection, void*) {
    auto* open = static_cast<Connection*>(
        mg_get_user_connection_data(const_cast<mg_connection*>(connection)));
    if (open == nullptr) return;
    open->session().close();
    delete open;
    mg_set_user_connection_data(const_cast<mg_connection*>(connection), nullptr);
  }
};

absl::StatusOr<std::unique_ptr<ViewerHttpServer>> ViewerHttpServer::start(
    const std::string& listen, std::shared_ptr<grpc::Channel> channel, ViewerOptions options) {
  absl::StatusOr<std::string> port = civetweb_listening_port(listen);
  if (!port.ok()) return port.status();
  static std::once_flag library_initialised;
  std::call_once(library_initialised, [] { mg_init_library(MG_FEATURES_WEBSOCKET); });

  std::unique_ptr<ViewerHttpServer> server(new ViewerHttpServer());
  server->channel_ = std::move(channel);
  server->options_ = options;
  // Each WebSocket holds a worker thread while it is open, so there are enough for a few pages
  // beside the page loads. Pings keep idle sockets open: browsers answer them unprompted.
  const char* civetweb_options[] = {"listening_ports", port->c_str(), "num_threads", "32",
                                    "websocket_timeout_ms", "10000", "enable_websocket_ping_pong",
                                    "yes", "request_timeout_ms", "10000",
                                    // A frame goes out as a small header and then its bytes; with
                                    // Nagle's algorithm on, the bytes waited for the browser's
                                    // delayed acknowledgement.
                                    "tcp_nodelay", "1", nullptr};
  mg_callbacks callbacks{};
  // civetweb logs a failed bind through log_message; the error below says the same.
  callbacks.log_message = [](const mg_connection*, const char*) { return 1; };
  server->context_ = mg_start(&callbacks, server.get(), civetweb_options);
  if (server->context_ == nullptr) {
    return absl::UnavailableError(absl::StrCat("--http-listen: cannot listen on ", listen));
  }
  mg_set_request_handler(server->context_, "/", &Callbacks::serve_asset, nullptr);
  mg_set_websocket_handler(server->context_, kWebSocketPath, &Callbacks::websocket_connect,
                           &Callbacks::websocket_ready, &Callbacks::websocket_data,
                           &Callbacks::websocket_close, server.get());
  mg_server_port ports[4];
  const int count = mg_get_server_ports(server->context_, 4, ports);
  if (count < 1) {
    server->stop();
    return absl::UnavailableError(absl::StrCat("--http-listen: no port on ", listen));
  }
  server->port_ = ports[0].port;
  return server;
}

void ViewerHttpServer::stop() {
  if (context_ == nullptr) return;
  mg_stop(context_);
  context_ = nullptr;
}

ViewerHttpServer::~ViewerHttpServer() { stop(); }

}  // namespace caustica::server::viewer
