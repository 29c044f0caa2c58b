#include "server/http/http_server.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/strand.hpp>
#include <boost/asio/thread_pool.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <charconv>
#include <condition_variable>
#include <deque>
#include <list>
#include <mutex>
#include <optional>
#include <thread>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"

namespace caustica::server::http {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace bhttp = boost::beast::http;
namespace websocket = boost::beast::websocket;
using tcp = asio::ip::tcp;

namespace {

// Debian's Abseil has a string_view of its own.
absl::string_view av(std::string_view text) { return absl::string_view(text.data(), text.size()); }

constexpr char kServerName[] = "caustica-server";
// Answered to a connection over the limit with nothing to evict; written without waiting, since
// the limit is there because sockets cannot all be served.
constexpr std::string_view kBusyResponse =
    "HTTP/1.1 503 Service Unavailable\r\nContent-Length: 0\r\nConnection: close\r\n\r\n";

// Connections the server can close: for stop(), and to evict one at the connection limit.
class Closable {
 public:
  virtual ~Closable() = default;
  // A reference that keeps it alive; null once it is being destroyed. The registry's lock is
  // released before a held reference is dropped, since the last one destroys it, and destruction
  // takes that lock.
  virtual std::shared_ptr<Closable> hold() = 0;
  // Closes it from its strand; the caller holds a reference.
  virtual void close_now() = 0;
  // Whether it is still waiting for a whole request header, and so may be evicted.
  virtual bool awaiting_header() const = 0;
};

HttpRequest to_request(const bhttp::request<bhttp::empty_body>& message) {
  HttpRequest request;
  request.method = std::string(message.method_string());
  request.target = std::string(message.target());
  request.path = request.target.substr(0, request.target.find('?'));
  for (const auto& field : message) {
    request.headers.emplace_back(std::string(field.name_string()), std::string(field.value()));
  }
  return request;
}

}  // namespace

std::string_view HttpRequest::header(std::string_view name) const {
  for (const auto& [key, value] : headers) {
    if (absl::EqualsIgnoreCase(key, av(name))) return value;
  }
  return {};
}

HttpResponse plain_text_response(int status, std::string_view line) {
  HttpResponse response;
  response.status = status;
  response.content_type = "text/plain; charset=utf-8";
  response.body = absl::StrCat(av(line), "\n");
  return response;
}

absl::StatusOr<ListenAddress> parse_listen_address(std::string_view listen, std::string_view flag) {
  const size_t colon = listen.rfind(':');
  if (colon == std::string_view::npos) {
    return absl::InvalidArgumentError(absl::StrCat(av(flag), ": '", av(listen), "' is not HOST:PORT"));
  }
  ListenAddress address;
  address.host = std::string(listen.substr(0, colon));
  const std::string_view port = listen.substr(colon + 1);
  const auto [end, error] = std::from_chars(port.data(), port.data() + port.size(), address.port);
  if (port.empty() || error != std::errc() || end != port.data() + port.size() ||
      address.port < 0 || address.port > 65535) {
    return absl::InvalidArgumentError(absl::StrCat(av(flag), ": '", av(listen), "' has no port number"));
  }
  if (address.host.starts_with('[') && address.host.ends_with(']')) {
    address.host = address.host.substr(1, address.host.size() - 2);
  } else if (address.host.find(':') != std::string::npos) {
    return absl::InvalidArgumentError(
        absl::StrCat(av(flag), ": '", av(listen), "': write an IPv6 address in brackets, [::1]:PORT"));
  }
  if (address.host.empty()) address.host = "0.0.0.0";
  if (absl::AsciiStrToLower(address.host) == "localhost") address.host = "127.0.0.1";
  boost::system::error_code ec;
  asio::ip::make_address(address.host, ec);
  if (ec) {
    return absl::InvalidArgumentError(
        absl::StrCat(av(flag), ": '", av(listen), "': '", address.host, "' is not an IP address"));
  }
  return address;
}

class HttpServer::Impl {
 public:
  Impl(HttpRoutes routes, HttpLimits limits)
      : routes_(std::move(routes)),
        limits_(limits),
        handler_threads_(std::max<size_t>(1, limits.max_websockets)) {}

  absl::Status listen(const ListenAddress& address, std::string_view flag);
  void stop();

  const HttpRoutes& routes() const { return routes_; }
  const HttpLimits& limits() const { return limits_; }
  asio::thread_pool& handler_threads() { return handler_threads_; }
  int port() const { return port_; }

  // Every connection registers itself for its lifetime.
  std::list<Closable*>::iterator enroll(Closable* connection) {
    std::lock_guard lock(mutex_);
    return connections_.insert(connections_.end(), connection);
  }
  void leave(std::list<Closable*>::iterator at) {
    std::lock_guard lock(mutex_);
    connections_.erase(at);
  }
  size_t connections() const {
    std::lock_guard lock(mutex_);
    return connections_.size();
  }

  // A WebSocket slot, or false when all are taken.
  bool claim_websocket() {
    std::lock_guard lock(mutex_);
    if (stopping_ || websockets_ >= limits_.max_websockets) return false;
    ++websockets_;
    return true;
  }
  void release_websocket() {
    std::lock_guard lock(mutex_);
    --websockets_;
    websockets_changed_.notify_all();
  }
  size_t websockets() const {
    std::lock_guard lock(mutex_);
    return websockets_;
  }

 private:
  void accept();
  void admit(tcp::socket socket);
  // At the connection limit: closes the oldest connection still waiting for its header; false
  // when there is none.
  bool evict_one();

  const HttpRoutes routes_;
  const HttpLimits limits_;
  // Declared before the I/O context, whose destruction destroys the handlers still queued in it,
  // and with them connections that leave this list.
  mutable std::mutex mutex_;
  std::condition_variable websockets_changed_;
  std::list<Closable*> connections_;
  size_t websockets_ = 0;
  bool stopping_ = false;

  asio::io_context io_;
  std::optional<asio::executor_work_guard<asio::io_context::executor_type>> work_;
  tcp::acceptor acceptor_{asio::make_strand(io_)};
  asio::thread_pool handler_threads_;
  std::vector<std::thread> io_threads_;
  int port_ = 0;
};

namespace {

// One WebSocket after its upgrade: reads on the connection's strand, hands each message to the
// handler on a thread of the handler pool and reads the next when that call has returned.
class WebSocketConnection final : public WebSocketPeer,
                                  public Closable,
                                  public std::enable_shared_from_this<WebSocketConnection> {
 public:
  WebSocketConnection(HttpServer::Impl& server, beast::tcp_stream stream)
      : server_(server), ws_(std::move(stream)), enrolled_(server.enroll(this)) {}
  ~WebSocketConnection() override {
    server_.leave(enrolled_);
    server_.release_websocket();
  }

  void accept(bhttp::request<bhttp::empty_body> request) {
    const HttpLimits& limits = server_.limits();
    beast::get_lowest_layer(ws_).expires_never();
    websocket::stream_base::timeout timeout{};
    timeout.handshake_timeout = limits.header_timeout;
    timeout.idle_timeout = limits.idle_timeout;
    timeout.keep_alive_pings = true;
    ws_.set_option(timeout);
    ws_.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& response) { response.set(bhttp::field::server, kServerName); }));
    ws_.read_message_max(limits.max_message_bytes);
    ws_.async_accept(request, beast::bind_front_handler(&WebSocketConnection::on_accept,
                                                         shared_from_this()));
  }

  void send_text(std::string text) override { enqueue(std::move(text), /*binary=*/false); }
  void send_binary(std::string bytes) override { enqueue(std::move(bytes), /*binary=*/true); }

  std::shared_ptr<Closable> hold() override { return weak_from_this().lock(); }
  void close_now() override {
    asio::post(ws_.get_executor(), [self = shared_from_this()] { self->fail(); });
  }
  bool awaiting_header() const override { return false; }

 private:
  struct Outgoing {
    std::string bytes;
    bool binary = false;
  };

  void on_accept(beast::error_code ec) {
    if (ec || closed_) return fail();
    handler_ = server_.routes().open_websocket(*this);
    read();
  }

  void read() {
    if (closed_) return;
    ws_.async_read(buffer_,
                   beast::bind_front_handler(&WebSocketConnection::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, size_t) {
    if (ec) return fail();
    std::string message = beast::buffers_to_string(buffer_.data());
    buffer_.consume(buffer_.size());
    handling_ = true;
    asio::post(server_.handler_threads(),
               [self = shared_from_this(), message = std::move(message), text = ws_.got_text()] {
                 if (text) {
                   self->handler_->on_text(message);
                 } else {
                   self->handler_->on_binary(message);
                 }
                 asio::dispatch(self->ws_.get_executor(), [self] {
                   self->handling_ = false;
                   if (self->closed_) return self->finish();
                   self->read();
                 });
               });
  }

  // On the strand. Queued bytes are bounded: a client that does not read is closed rather than
  // buffered for.
  void enqueue(std::string bytes, bool binary) {
    asio::post(ws_.get_executor(), [self = shared_from_this(), bytes = std::move(bytes),
                                    binary]() mutable {
      if (self->closed_) return;
      auto& queue = self->outgoing_;
      const size_t first_waiting = self->writing_ ? 1 : 0;
      if (binary) {
        for (size_t i = first_waiting; i < queue.size(); ++i) {
          if (!queue[i].binary) continue;
          self->queued_bytes_ -= queue[i].bytes.size();
          queue.erase(queue.begin() + ptrdiff_t(i));
          break;
        }
      }
      if (self->queued_bytes_ + bytes.size() > self->server_.limits().max_queued_bytes) {
        return self->fail();
      }
      self->queued_bytes_ += bytes.size();
      queue.push_back({std::move(bytes), binary});
      self->write();
    });
  }

  void write() {
    if (writing_ || outgoing_.empty() || closed_) return;
    writing_ = true;
    ws_.binary(outgoing_.front().binary);
    ws_.async_write(asio::buffer(outgoing_.front().bytes),
                    beast::bind_front_handler(&WebSocketConnection::on_write, shared_from_this()));
  }

  void on_write(beast::error_code ec, size_t) {
    writing_ = false;
    if (closed_) return outgoing_.clear();
    queued_bytes_ -= outgoing_.front().bytes.size();
    outgoing_.pop_front();
    if (ec) return fail();
    write();
  }

  // On the strand: closes the socket once. The handler hears of it last, after a call of its that
  // is still running.
  void fail() {
    if (closed_) return;
    closed_ = true;
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
    beast::get_lowest_layer(ws_).close();
    // The message being written stays until its write completes: the write still refers to it.
    outgoing_.erase(outgoing_.begin() + (writing_ ? 1 : 0), outgoing_.end());
    queued_bytes_ = 0;
    if (!handling_) finish();
  }

  void finish() {
    if (handler_ == nullptr) return;
    asio::post(server_.handler_threads(), [self = shared_from_this()] {
      self->handler_->on_close();
      self->handler_.reset();
    });
  }

  HttpServer::Impl& server_;
  websocket::stream<beast::tcp_stream> ws_;
  const std::list<Closable*>::iterator enrolled_;
  beast::flat_buffer buffer_;
  std::unique_ptr<WebSocketHandler> handler_;
  std::deque<Outgoing> outgoing_;
  size_t queued_bytes_ = 0;
  bool writing_ = false;
  bool handling_ = false;  // a message is with the handler
  bool closed_ = false;
};

// One connection until it upgrades or closes: requests read with the header's size and time
// bounded, answered by the routes, kept alive between requests.
class HttpConnection final : public Closable, public std::enable_shared_from_this<HttpConnection> {
 public:
  HttpConnection(HttpServer::Impl& server, tcp::socket socket)
      : server_(server),
        stream_(std::move(socket)),
        buffer_(server.limits().max_header_bytes + 1024),
        enrolled_(server.enroll(this)) {}
  ~HttpConnection() override { server_.leave(enrolled_); }

  void start() {
    asio::dispatch(stream_.get_executor(),
                   beast::bind_front_handler(&HttpConnection::read, shared_from_this()));
  }

  std::shared_ptr<Closable> hold() override { return weak_from_this().lock(); }
  void close_now() override {
    awaiting_header_ = false;  // so that it is not chosen twice
    asio::post(stream_.get_executor(), [self = shared_from_this()] { self->close(); });
  }
  bool awaiting_header() const override { return awaiting_header_; }

 private:
  void read() {
    parser_.emplace();
    parser_->header_limit(uint32_t(server_.limits().max_header_bytes));
    parser_->body_limit(server_.limits().max_body_bytes);
    awaiting_header_ = true;
    stream_.expires_after(server_.limits().header_timeout);
    bhttp::async_read(stream_, buffer_, *parser_,
                      beast::bind_front_handler(&HttpConnection::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, size_t) {
    awaiting_header_ = false;
    if (ec == bhttp::error::header_limit || ec == beast::http::error::buffer_overflow) {
      return refuse(bhttp::status::request_header_fields_too_large, "request header too large");
    }
    if (ec == bhttp::error::body_limit) {
      return refuse(bhttp::status::payload_too_large, "requests here carry no body");
    }
    if (ec == beast::error::timeout || ec) return close();
    bhttp::request<bhttp::empty_body> message = parser_->release();
    const HttpRequest request = to_request(message);
    const HttpRoutes& routes = server_.routes();
    if (!routes.websocket_path.empty() && request.path == routes.websocket_path &&
        websocket::is_upgrade(message)) {
      return upgrade(std::move(message), request);
    }
    HttpResponse response = routes.serve(request);
    respond(std::move(response), message.method() == bhttp::verb::head, message.keep_alive());
  }

  void upgrade(bhttp::request<bhttp::empty_body> message, const HttpRequest& request) {
    if (server_.routes().accept_websocket && !server_.routes().accept_websocket(request)) {
      return refuse(bhttp::status::forbidden, "this page may not open the viewer's WebSocket");
    }
    if (!server_.claim_websocket()) {
      return refuse(bhttp::status::service_unavailable, "too many viewers are open");
    }
    std::make_shared<WebSocketConnection>(server_, std::move(stream_))->accept(std::move(message));
  }

  void refuse(bhttp::status status, std::string_view why) {
    respond(plain_text_response(int(status), why), /*head=*/false, /*keep_alive=*/false);
  }

  void respond(HttpResponse response, bool head, bool keep_alive) {
    auto message = std::make_shared<bhttp::response<bhttp::string_body>>();
    message->result(unsigned(response.status));
    message->version(11);
    message->set(bhttp::field::server, kServerName);
    if (!response.content_type.empty()) {
      message->set(bhttp::field::content_type, response.content_type);
    }
    for (const auto& [name, value] : response.headers) message->set(name, value);
    // A HEAD response announces the body's length without sending it.
    const size_t body_bytes = response.body.size();
    if (!head) message->body() = std::move(response.body);
    message->content_length(body_bytes);
    message->keep_alive(keep_alive);
    // A response's time is bounded as a request's is: a client that reads nothing is dropped.
    stream_.expires_after(server_.limits().header_timeout);
    bhttp::async_write(stream_, *message,
                       [self = shared_from_this(), message, keep_alive](beast::error_code ec,
                                                                        size_t) {
                         if (ec) return self->close();
                         if (!keep_alive) return self->linger();
                         self->read();
                       });
  }

  void close() {
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_both, ignored);
    stream_.close();
  }

  // After a last response, reads and drops what the client still sends for a moment before
  // closing: closing with unread bytes would reset the connection, and the client would lose the
  // response (a refusal of an oversized header, say) before reading it.
  void linger() {
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
    stream_.expires_after(std::chrono::seconds(1));
    drain_ = std::make_unique<std::array<char, 4096>>();
    drain();
  }
  void drain() {
    stream_.async_read_some(asio::buffer(*drain_),
                            [self = shared_from_this()](beast::error_code ec, size_t) {
                              if (ec) return self->close();
                              self->drain();
                            });
  }

  HttpServer::Impl& server_;
  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<bhttp::request_parser<bhttp::empty_body>> parser_;
  std::atomic<bool> awaiting_header_ = true;
  const std::list<Closable*>::iterator enrolled_;
  std::unique_ptr<std::array<char, 4096>> drain_;
};

}  // namespace

absl::Status HttpServer::Impl::listen(const ListenAddress& address, std::string_view flag) {
  beast::error_code ec;
  const tcp::endpoint endpoint(asio::ip::make_address(address.host), uint16_t(address.port));
  acceptor_.open(endpoint.protocol(), ec);
  if (!ec) acceptor_.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) acceptor_.bind(endpoint, ec);
  if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    return absl::UnavailableError(absl::StrCat(av(flag), ": cannot listen on ", address.host, ":",
                                               address.port, ": ", ec.message()));
  }
  port_ = acceptor_.local_endpoint().port();
  work_.emplace(io_.get_executor());
  accept();
  for (unsigned i = 0; i < std::max(1u, limits_.io_threads); ++i) {
    io_threads_.emplace_back([this] { io_.run(); });
  }
  return absl::OkStatus();
}

void HttpServer::Impl::accept() {
  acceptor_.async_accept(asio::make_strand(io_), [this](beast::error_code ec, tcp::socket socket) {
    if (ec == asio::error::operation_aborted || !acceptor_.is_open()) return;
    if (!ec) admit(std::move(socket));
    accept();
  });
}

void HttpServer::Impl::admit(tcp::socket socket) {
  if (connections() >= limits_.max_connections && !evict_one()) {
    beast::error_code ignored;
    socket.non_blocking(true, ignored);
    socket.write_some(asio::buffer(kBusyResponse), ignored);
    socket.close(ignored);
    return;
  }
  beast::error_code ignored;
  socket.set_option(tcp::no_delay(true), ignored);
  std::make_shared<HttpConnection>(*this, std::move(socket))->start();
}

bool HttpServer::Impl::evict_one() {
  std::shared_ptr<Closable> victim;
  {
    std::lock_guard lock(mutex_);
    for (Closable* connection : connections_) {
      if (connection->awaiting_header() && (victim = connection->hold())) break;
    }
  }
  if (victim == nullptr) return false;
  victim->close_now();
  return true;
}

void HttpServer::Impl::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    stopping_ = true;
  }
  if (io_threads_.empty()) return;
  asio::post(acceptor_.get_executor(), [this] {
    beast::error_code ignored;
    acceptor_.close(ignored);
  });
  std::vector<std::shared_ptr<Closable>> open;
  {
    std::lock_guard lock(mutex_);
    for (Closable* connection : connections_) {
      if (std::shared_ptr<Closable> held = connection->hold()) open.push_back(std::move(held));
    }
  }
  for (const std::shared_ptr<Closable>& connection : open) connection->close_now();
  open.clear();
  // The handlers' on_close ends their work (the viewer's frame streams) before the caller goes on
  // to stop what they use.
  std::unique_lock lock(mutex_);
  websockets_changed_.wait(lock, [this] { return websockets_ == 0; });
  lock.unlock();
  work_.reset();
  io_.stop();
  for (std::thread& thread : io_threads_) thread.join();
  handler_threads_.join();
}

HttpServer::HttpServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

absl::StatusOr<std::unique_ptr<HttpServer>> HttpServer::start(std::string_view listen,
                                                              std::string_view flag,
                                                              HttpRoutes routes,
                                                              HttpLimits limits) {
  absl::StatusOr<ListenAddress> address = parse_listen_address(listen, flag);
  if (!address.ok()) return address.status();
  auto impl = std::make_unique<Impl>(std::move(routes), limits);
  if (absl::Status status = impl->listen(*address, flag); !status.ok()) return status;
  return std::unique_ptr<HttpServer>(new HttpServer(std::move(impl)));
}

HttpServer::~HttpServer() { stop(); }

int HttpServer::port() const { return impl_->port(); }
size_t HttpServer::connections() const { return impl_->connections(); }
size_t HttpServer::websockets() const { return impl_->websockets(); }
void HttpServer::stop() { impl_->stop(); }

}  // namespace caustica::server::http
