// The server's HTTP ports (--http-listen's viewer and --metrics-listen) on Boost.Beast over Asio.
// The server is event-driven, so a slow or idle connection costs a timer and a few kilobytes, never
// a thread. Each limit a client could push against is set here (docs/reliability.md, "HTTP
// ports"): connections open at once, a request header's bytes and time, bodies, WebSocket messages
// (refused from their frame header, before any payload is read) and what waits to be sent.
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"

namespace caustica::server::http {

struct HttpLimits {
  // Connections open at once. At the limit a new connection evicts the oldest one that has not yet
  // sent a whole request header; with none to evict it is answered 503 and closed.
  size_t max_connections = 512;
  // From a connection's start, or the end of its last response, until its request header is whole.
  std::chrono::milliseconds header_timeout{5000};
  // A WebSocket that sends nothing for this long is closed; the server pings it halfway through,
  // which browsers answer unprompted.
  std::chrono::milliseconds idle_timeout{30000};
  size_t max_header_bytes = 8 * 1024;
  // Requests here carry no body: one with a body is answered 413.
  size_t max_body_bytes = 0;
  // A WebSocket message, checked against the length its frame header announces.
  size_t max_message_bytes = 64 * 1024;
  // WebSockets open at once; each has a thread for its handler's calls, which may block.
  size_t max_websockets = 64;
  // Bytes waiting to be sent to one connection; a client that reads none of them is closed.
  size_t max_queued_bytes = 64 << 20;
  unsigned io_threads = 2;
};

struct HttpRequest {
  std::string method;  // "GET"
  std::string target;  // "/ws?x=1"
  std::string path;    // "/ws"
  std::vector<std::pair<std::string, std::string>> headers;
  // A header's value (names compare without case); empty when absent.
  std::string_view header(std::string_view name) const;
};

struct HttpResponse {
  int status = 200;
  std::string content_type;
  std::string body;  // a HEAD response gets its Content-Length without it
  std::vector<std::pair<std::string, std::string>> headers;
};

// A text/plain response of one line, for refusals and short answers.
HttpResponse plain_text_response(int status, std::string_view line);

// What a WebSocket's handler sends through. Safe from any thread; nothing is sent once closed.
class WebSocketPeer {
 public:
  virtual ~WebSocketPeer() = default;
  virtual void send_text(std::string text) = 0;
  // Binary messages are frames of a picture: one that has not begun to go out is replaced by a
  // newer one, so a slow client gets the latest frame rather than a backlog.
  virtual void send_binary(std::string bytes) = 0;
};

// One WebSocket's messages. Its calls come one at a time on a thread of their own, which may block
// (the next message is not read before the call returns); on_close is the last.
class WebSocketHandler {
 public:
  virtual ~WebSocketHandler() = default;
  virtual void on_text(std::string_view text) = 0;
  virtual void on_binary(std::string_view bytes) = 0;
  virtual void on_close() = 0;
};

struct HttpRoutes {
  // Every request but a WebSocket upgrade to websocket_path; called on an I/O thread, so it must
  // not block.
  std::function<HttpResponse(const HttpRequest&)> serve;
  // Empty: no WebSockets.
  std::string websocket_path;
  // Whether an upgrade may proceed (an Origin check); a refusal is answered 403.
  std::function<bool(const HttpRequest&)> accept_websocket;
  std::function<std::unique_ptr<WebSocketHandler>(WebSocketPeer&)> open_websocket;
};

// HOST:PORT as given to a --*-listen flag: "localhost" is 127.0.0.1, an empty host every IPv4
// interface, "[::1]:80" an IPv6 address. INVALID_ARGUMENT naming `flag` otherwise.
struct ListenAddress {
  std::string host;
  int port = 0;
};
absl::StatusOr<ListenAddress> parse_listen_address(std::string_view listen, std::string_view flag);

class HttpServer {
 public:
  // Listens on `listen` (port 0 picks a free one); UNAVAILABLE naming `flag` when it cannot.
  static absl::StatusOr<std::unique_ptr<HttpServer>> start(std::string_view listen,
                                                           std::string_view flag,
                                                           HttpRoutes routes,
                                                           HttpLimits limits = {});
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  int port() const;
  // Connections open now, WebSockets among them.
  size_t connections() const;
  size_t websockets() const;
  // Stops listening, closes every connection and waits for the WebSocket handlers' on_close.
  // Idempotent.
  void stop();

  class Impl;

 private:
  explicit HttpServer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace caustica::server::http
