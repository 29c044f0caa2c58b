// The HTTP ports' server (server/http) against clients that misbehave on purpose: requests whose
// header never ends, more connections than the limit, headers and bodies over their limits,
// WebSocket messages announced larger than the limit, and clients that read nothing. Well-behaved
// clients are Boost.Beast's; the others write raw bytes.
#include "server/http/http_server.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/time.h>

#include <atomic>
#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

namespace caustica::server::http {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace bhttp = boost::beast::http;
namespace websocket = boost::beast::websocket;
using tcp = asio::ip::tcp;
using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;

// What the WebSocket handlers of one server saw.
struct Seen {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<std::string> texts;
  int opened = 0;
  int closed = 0;

  template <typename Predicate>
  bool wait(Predicate ready, std::chrono::milliseconds timeout = std::chrono::seconds(5)) {
    std::unique_lock lock(mutex);
    return changed.wait_for(lock, timeout, [&] { return ready(*this); });
  }
};

// Echoes text messages back, upper-cased so that the reply differs from the request.
class EchoHandler final : public WebSocketHandler {
 public:
  EchoHandler(WebSocketPeer& peer, Seen& seen) : peer_(peer), seen_(seen) {
    std::lock_guard lock(seen_.mutex);
    ++seen_.opened;
    seen_.changed.notify_all();
  }
  void on_text(std::string_view text) override {
    if (text == "flood") return flood();
    {
      std::lock_guard lock(seen_.mutex);
      seen_.texts.emplace_back(text);
      seen_.changed.notify_all();
    }
    std::string reply(text);
    for (char& c : reply) c = char(std::toupper(static_cast<unsigned char>(c)));
    peer_.send_text(reply);
  }
  void on_binary(std::string_view) override { peer_.send_text("no binary"); }
  void on_close() override {
    std::lock_guard lock(seen_.mutex);
    ++seen_.closed;
    seen_.changed.notify_all();
  }

 private:
  // 200 MiB of frames, of which only the one being sent and the newest may be held, then 20 MiB of
  // text, which must all be kept and so overflows the queue's bound.
  void flood() {
    for (int i = 0; i < 200; ++i) peer_.send_binary(std::string(1 << 20, char(i)));
    for (int i = 0; i < 20; ++i) peer_.send_text(std::string(1 << 20, 't'));
  }

  WebSocketPeer& peer_;
  Seen& seen_;
};

class HttpServerTest : public ::testing::Test {
 protected:
  void start(HttpLimits limits) {
    HttpRoutes routes;
    routes.serve = [](const HttpRequest& request) {
      return plain_text_response(200, request.method + " " + request.path);
    };
    routes.websocket_path = "/ws";
    routes.accept_websocket = [](const HttpRequest& request) {
      return request.header("Origin") != "http://evil.example";
    };
    routes.open_websocket = [this](WebSocketPeer& peer) {
      return std::make_unique<EchoHandler>(peer, seen_);
    };
    absl::StatusOr<std::unique_ptr<HttpServer>> server =
        HttpServer::start("127.0.0.1:0", "--test-listen", std::move(routes), limits);
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = *std::move(server);
  }

  tcp::socket connect() {
    tcp::socket socket(io_);
    socket.connect({asio::ip::make_address("127.0.0.1"), uint16_t(server_->port())});
    return socket;
  }

  // A GET through Beast's client on a new connection: the status and body, or the error.
  std::string get(const std::string& path, std::chrono::milliseconds timeout) {
    beast::tcp_stream stream(io_);
    beast::error_code ec;
    stream.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), uint16_t(server_->port())),
                   ec);
    if (ec) return "connect: " + ec.message();
    bhttp::request<bhttp::empty_body> request(bhttp::verb::get, path, 11);
    request.set(bhttp::field::host, "127.0.0.1");
    bhttp::write(stream.socket(), request, ec);
    if (ec) return "write: " + ec.message();
    beast::flat_buffer buffer;
    bhttp::response<bhttp::string_body> response;
    // Synchronous reads ignore the stream's timer, so the socket's own receive timeout bounds it.
    set_receive_timeout(stream.socket(), timeout);
    bhttp::read(stream.socket(), buffer, response, ec);
    if (ec) return "read: " + ec.message();
    return std::to_string(response.result_int()) + " " + response.body();
  }

  static void set_receive_timeout(tcp::socket& socket, std::chrono::milliseconds timeout) {
    timeval tv{.tv_sec = timeout.count() / 1000, .tv_usec = (timeout.count() % 1000) * 1000};
    setsockopt(socket.native_handle(), SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  }

  // Whether the server closes `socket` within `timeout`: reads until the end of the stream,
  // returning what was read, or nullopt when the time ran out first.
  static std::optional<std::string> read_until_closed(tcp::socket& socket,
                                                      std::chrono::milliseconds timeout) {
    set_receive_timeout(socket, timeout);
    std::string received;
    const auto deadline = Clock::now() + timeout;
    char chunk[4096];
    for (;;) {
      const ssize_t n = ::recv(socket.native_handle(), chunk, sizeof chunk, 0);
      if (n == 0) return received;
      if (n < 0) {
        if (errno == ECONNRESET) return received;
        if (Clock::now() >= deadline) return std::nullopt;
        continue;
      }
      received.append(chunk, size_t(n));
    }
  }

  // A WebSocket opened by Beast's client.
  std::unique_ptr<websocket::stream<tcp::socket>> open_websocket() {
    auto ws = std::make_unique<websocket::stream<tcp::socket>>(connect());
    ws->handshake("127.0.0.1", "/ws");
    return ws;
  }

  asio::io_context io_;
  Seen seen_;
  std::unique_ptr<HttpServer> server_;
};

TEST(HttpListen, AddressesOfTheListenFlags) {
  EXPECT_EQ(parse_listen_address("127.0.0.1:8080", "--x")->host, "127.0.0.1");
  EXPECT_EQ(parse_listen_address("127.0.0.1:8080", "--x")->port, 8080);
  EXPECT_EQ(parse_listen_address("localhost:0", "--x")->host, "127.0.0.1");
  EXPECT_EQ(parse_listen_address(":8080", "--x")->host, "0.0.0.0");
  EXPECT_EQ(parse_listen_address("[::1]:80", "--x")->host, "::1");
  EXPECT_FALSE(parse_listen_address("8080", "--x").ok());
  EXPECT_FALSE(parse_listen_address("127.0.0.1:http", "--x").ok());
  EXPECT_FALSE(parse_listen_address("127.0.0.1:70000", "--x").ok());
  EXPECT_FALSE(parse_listen_address("example.com:80", "--x").ok());
  EXPECT_THAT(std::string(parse_listen_address("::1:80", "--metrics-listen").status().message()),
              HasSubstr("--metrics-listen"));
}

TEST_F(HttpServerTest, AnswersRequestsAndKeepsConnectionsAlive) {
  start({});
  EXPECT_EQ(get("/page?x=1", std::chrono::seconds(5)), "200 GET /page\n");
  beast::tcp_stream stream(connect());
  for (int i = 0; i < 3; ++i) {
    bhttp::request<bhttp::empty_body> request(bhttp::verb::get, "/again", 11);
    bhttp::write(stream, request);
    beast::flat_buffer buffer;
    bhttp::response<bhttp::string_body> response;
    bhttp::read(stream, buffer, response);
    EXPECT_EQ(response.body(), "GET /again\n");
  }
}

// Forty connections that send their headers a byte at a time, more than a thread-per-connection
// server's workers, do not keep a well-behaved client waiting; each is closed when its header
// time runs out.
TEST_F(HttpServerTest, SlowHeadersNeitherBlockOthersNorStayOpen) {
  HttpLimits limits;
  limits.header_timeout = std::chrono::milliseconds(1500);
  start(limits);
  std::vector<tcp::socket> slow;
  for (int i = 0; i < 40; ++i) {
    slow.push_back(connect());
    asio::write(slow.back(), asio::buffer(std::string_view("GET / HTTP/1.1\r\nHost: x\r\n")));
  }
  const auto before = Clock::now();
  EXPECT_EQ(get("/", std::chrono::seconds(1)), "200 GET /\n");
  EXPECT_LT(Clock::now() - before, std::chrono::seconds(1));
  for (tcp::socket& socket : slow) {
    asio::write(socket, asio::buffer(std::string_view("X")));
  }
  int closed = 0;
  for (tcp::socket& socket : slow)
    closed += read_until_closed(socket, std::chrono::seconds(5)) ? 1 : 0;
  EXPECT_EQ(closed, 40);
  for (int i = 0; i < 200 && server_->connections() > 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(server_->connections(), 0u);
}

// At the connection limit an idle connection makes room for a new one; connections past it with
// nothing to evict are answered 503.
TEST_F(HttpServerTest, TheConnectionLimitEvictsTheOldestIdleConnection) {
  HttpLimits limits;
  limits.max_connections = 8;
  limits.header_timeout = std::chrono::seconds(30);
  start(limits);
  std::vector<tcp::socket> idle;
  for (int i = 0; i < 8; ++i) idle.push_back(connect());
  while (server_->connections() < 8) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(get("/", std::chrono::seconds(2)), "200 GET /\n");
  ASSERT_TRUE(read_until_closed(idle.front(), std::chrono::seconds(2)).has_value())
      << "the oldest idle connection was not the one evicted";
  // The GET's own connection closes once answered, but the server may count it a moment longer;
  // counted, it would take the place of the eighth WebSocket below.
  while (server_->connections() > 7) std::this_thread::sleep_for(std::chrono::milliseconds(5));

  std::vector<std::unique_ptr<websocket::stream<tcp::socket>>> open;
  for (int i = 0; i < 8; ++i) open.push_back(open_websocket());
  tcp::socket refused = connect();
  const std::optional<std::string> answer = read_until_closed(refused, std::chrono::seconds(2));
  ASSERT_TRUE(answer.has_value());
  EXPECT_THAT(*answer, HasSubstr("503"));
}

TEST_F(HttpServerTest, HeadersAndBodiesOverTheirLimitsAreRefused) {
  start({});
  tcp::socket large = connect();
  asio::write(large,
              asio::buffer("GET / HTTP/1.1\r\nX-Pad: " + std::string(20000, 'a') + "\r\n\r\n"));
  std::optional<std::string> answer = read_until_closed(large, std::chrono::seconds(2));
  ASSERT_TRUE(answer.has_value());
  EXPECT_THAT(*answer, HasSubstr("431"));

  tcp::socket body = connect();
  asio::write(body, asio::buffer(std::string_view(
                        "POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 1000000000\r\n\r\n")));
  answer = read_until_closed(body, std::chrono::seconds(2));
  ASSERT_TRUE(answer.has_value());
  EXPECT_THAT(*answer, HasSubstr("413"));
}

TEST_F(HttpServerTest, WebSocketsEchoAndRefuseOtherOrigins) {
  start({});
  auto ws = open_websocket();
  ws->write(asio::buffer(std::string_view("hello")));
  beast::flat_buffer buffer;
  ws->read(buffer);
  EXPECT_EQ(beast::buffers_to_string(buffer.data()), "HELLO");

  websocket::stream<tcp::socket> foreign(connect());
  foreign.set_option(websocket::stream_base::decorator([](websocket::request_type& request) {
    request.set(bhttp::field::origin, "http://evil.example");
  }));
  beast::error_code ec;
  websocket::response_type response;
  foreign.handshake(response, "127.0.0.1", "/ws", ec);
  EXPECT_TRUE(ec);
  EXPECT_EQ(response.result_int(), 403u);
}

// The frame header announces 256 MiB; the server closes the socket on reading it (status 1009,
// message too big) without waiting for, or making room for, the payload.
TEST_F(HttpServerTest, AMessageOverTheLimitIsRefusedFromItsFrameHeader) {
  start({});
  auto ws = open_websocket();
  const uint64_t announced = uint64_t(256) << 20;
  std::string header = {char(0x81), char(0x80 | 127)};
  for (int shift = 56; shift >= 0; shift -= 8) header.push_back(char((announced >> shift) & 0xff));
  header += std::string("\x01\x02\x03\x04", 4);  // the client's mask
  asio::write(ws->next_layer(), asio::buffer(header));
  const std::optional<std::string> answer =
      read_until_closed(ws->next_layer(), std::chrono::seconds(2));
  ASSERT_TRUE(answer.has_value()) << "the server waited for the payload";
  // A close frame whose status is 1009.
  ASSERT_GE(answer->size(), 4u);
  EXPECT_EQ(uint8_t((*answer)[0]), 0x88);
  EXPECT_EQ((uint8_t((*answer)[2]) << 8) | uint8_t((*answer)[3]), 1009);
  // The server's side of the close waits for the client's.
  ws->next_layer().close();
  EXPECT_TRUE(seen_.wait([](Seen& s) { return s.closed == 1; }));
  EXPECT_TRUE(seen_.texts.empty());
}

// Fragments count towards one message: two fragments under the limit that add up over it close
// the socket too.
TEST_F(HttpServerTest, FragmentsAddUpToTheMessageLimit) {
  HttpLimits limits;
  limits.max_message_bytes = 1024;
  start(limits);
  auto ws = open_websocket();
  ws->auto_fragment(false);
  ws->write_some(false, asio::buffer(std::string(700, 'a')));
  beast::error_code ec;
  ws->write_some(true, asio::buffer(std::string(700, 'b')), ec);
  beast::flat_buffer buffer;
  ws->read(buffer, ec);
  EXPECT_EQ(ec, websocket::error::closed);
  EXPECT_EQ(ws->reason().code, websocket::close_code::too_big);
  EXPECT_TRUE(seen_.texts.empty());
}

// A client that reads nothing while the server sends: binary messages replace one another while
// they wait, and text past the queue's bound closes the connection instead of buffering it.
TEST_F(HttpServerTest, AClientThatReadsNothingIsNotBufferedFor) {
  HttpLimits limits;
  limits.max_queued_bytes = 8 << 20;
  start(limits);
  auto ws = open_websocket();
  ws->write(asio::buffer(std::string_view("flood")));
  EXPECT_TRUE(seen_.wait([](Seen& s) { return s.closed == 1; }, std::chrono::seconds(10)));
}

TEST_F(HttpServerTest, StopClosesEveryWebSocketAndCallsOnClose) {
  start({});
  auto first = open_websocket();
  auto second = open_websocket();
  ASSERT_TRUE(seen_.wait([](Seen& s) { return s.opened == 2; }));
  server_->stop();
  EXPECT_EQ(seen_.closed, 2);
  EXPECT_EQ(server_->websockets(), 0u);
}

}  // namespace
}  // namespace caustica::server::http
