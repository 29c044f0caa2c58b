// The soak's hostile clients (see hostile_client.h). Socket work runs on the client's own
// io_context, one operation at a time, each on a beast::tcp_stream whose deadline closes the
// socket when it passes, so that no answer the server fails to give can hang a client.
#include "bench/hostile_client.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <google/protobuf/stubs/logging.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/generic/generic_stub.h>
#include <sys/socket.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <functional>
#include <nlohmann/json.hpp>
#include <thread>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "caustica/v1/render_service.grpc.pb.h"
#include "client/connection.h"
#include "client/health_check.h"
#include "client/rpc_status.h"
#include "proto/wire/scene_wire.h"

namespace caustica {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace bhttp = boost::beast::http;
namespace websocket = boost::beast::websocket;
namespace protobuf = google::protobuf;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;
using Json = nlohmann::json;
using WebSocket = websocket::stream<beast::tcp_stream>;
using FieldChain = std::vector<const protobuf::FieldDescriptor*>;

constexpr size_t kFirstUnexpected = 5;
// Replies read from a hostile call before a stream still going is cancelled.
constexpr int kMostReplies = 3;
// A target no stream reaches: those streams end only when the client cancels them.
constexpr uint32_t kEndlessPasses = 1u << 30;
// Far over the HTTP server's request header limit and its WebSocket message limit.
constexpr size_t kOversizedHeaderBytes = size_t{64} << 10;
constexpr uint64_t kAnnouncedMessageBytes = uint64_t{256} << 20;
// Slow and idle sockets per port, and how their headers trickle in: a few seconds in all, well
// inside the HTTP server's time to a whole header.
constexpr int kSlowPerPort = 2, kIdlePerPort = 2;
constexpr int kTrickleSteps = 8;
constexpr auto kTricklePause = std::chrono::milliseconds(250);

// Bytes no well-behaved client sends in a string: control characters, a terminal escape, DEL,
// non-ASCII, invalid UTF-8, format directives, a way out of a directory, and a megabyte.
const std::vector<std::string>& hostile_values() {
  static const std::vector<std::string> values = {
      std::string("\0", 1),     "\r\n",     "\x1b[2J",  "\x7f",   "\xc3\xa9",
      "\xe2\x80\xae",           "\xff\xfe", "\xc0\x80", "%n%s%x", "../../../etc/passwd",
      std::string(1 << 20, 'x')};
  return values;
}

// Viewer tokens gRPC metadata cannot carry; a hello with one is refused by name.
const std::vector<std::string>& bad_tokens() {
  static const std::vector<std::string> tokens = {"\xc3\xa9",           "\n",   "\r\n", "\t",
                                                  std::string("\0", 1), "\x7f", "a b",  "\xff"};
  return tokens;
}

// Bytes that are not the port's protocol, or a broken form of it.
const std::vector<std::string>& garbage() {
  static const std::vector<std::string> bytes = {
      std::string("PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n") + std::string(16, '\xff'),
      std::string("GET / HTTP/1.1\r\nHost: \x01\x7f\r\nContent-Length: -5\r\n\r\n"),
      std::string("\x16\x03\x01\x00\xff\x01\x00\x00\xfb\x03\x03", 11),
      std::string("POST /ws HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\nzz\r\n"),
      std::string("GET /%00%c0%af/../.. HTTP/1.0\r\n\r\n"),
      std::string(4096, '\0')};
  return bytes;
}

constexpr char kHttp2Preface[] = "PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n";

// --- the gRPC side ---

struct HostileMethod {
  std::string path;  // "/caustica.v1.RenderService/GetScene"
  const protobuf::MethodDescriptor* method;
  std::vector<FieldChain> strings;  // every string field, as the fields leading to it
};

void collect_strings(const protobuf::Descriptor* type, FieldChain& chain,
                     std::vector<FieldChain>& found) {
  if (chain.size() > 3) return;  // messages nest (lights in keyframes); deeper adds nothing new
  for (int f = 0; f < type->field_count(); ++f) {
    const protobuf::FieldDescriptor* field = type->field(f);
    chain.push_back(field);
    if (field->type() == protobuf::FieldDescriptor::TYPE_STRING ||
        field->type() == protobuf::FieldDescriptor::TYPE_BYTES) {
      found.push_back(chain);
    } else if (field->type() == protobuf::FieldDescriptor::TYPE_MESSAGE) {
      collect_strings(field->message_type(), chain, found);
    }
    chain.pop_back();
  }
}

// RenderService's methods that take a string anywhere, found through the descriptors so that a
// new field is attacked without editing this.
const std::vector<HostileMethod>& hostile_methods() {
  static const std::vector<HostileMethod> methods = [] {
    std::vector<HostileMethod> found;
    const protobuf::ServiceDescriptor* service =
        protobuf::DescriptorPool::generated_pool()->FindServiceByName(
            v1::RenderService::service_full_name());
    for (int m = 0; service != nullptr && m < service->method_count(); ++m) {
      HostileMethod method{absl::StrCat("/", service->full_name(), "/", service->method(m)->name()),
                           service->method(m),
                           {}};
      FieldChain chain;
      collect_strings(method.method->input_type(), chain, method.strings);
      if (!method.strings.empty()) found.push_back(std::move(method));
    }
    return found;
  }();
  return methods;
}

// A request of `method` with `value` in the field `chain` leads to, and the target's id in its
// scene_id so that the call gets past the lookup to where the string is used. DeleteScene gets no
// id: it would remove the target.
std::string hostile_request(const HostileMethod& method, const FieldChain& chain,
                            const std::string& value, const std::string& target) {
  const protobuf::Descriptor* type = method.method->input_type();
  std::unique_ptr<protobuf::Message> request(
      protobuf::MessageFactory::generated_factory()->GetPrototype(type)->New());
  const protobuf::FieldDescriptor* id = type->FindFieldByName("scene_id");
  if (id != nullptr && id != chain.front() && method.method->name() != "DeleteScene") {
    request->GetReflection()->SetString(request.get(), id, target);
  }
  protobuf::Message* message = request.get();
  for (size_t i = 0; i + 1 < chain.size(); ++i) {
    const protobuf::Reflection* reflection = message->GetReflection();
    message = chain[i]->is_repeated() ? reflection->AddMessage(message, chain[i])
                                      : reflection->MutableMessage(message, chain[i]);
  }
  if (chain.back()->is_repeated()) {
    message->GetReflection()->AddString(message, chain.back(), value);
  } else {
    message->GetReflection()->SetString(message, chain.back(), value);
  }
  // Protobuf logs every string that is not UTF-8 as it serializes it; sending those is the point.
  protobuf::LogSilencer quiet;
  return request->SerializePartialAsString();
}

std::string bytes_of(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  std::string bytes;
  if (!buffer.Dump(&slices).ok()) return bytes;
  for (const grpc::Slice& slice : slices) {
    bytes.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
  }
  return bytes;
}

// A call of any method, unary or streaming, with `request` as its one message, through gRPC's
// generic stub: the status, after at most kMostReplies replies (a stream still going then is
// cancelled). The first reply goes to `first_reply`.
grpc::Status generic_call(const std::shared_ptr<grpc::Channel>& channel, const std::string& path,
                          const std::string& request, double deadline_s,
                          std::string* first_reply = nullptr) {
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() +
                       std::chrono::milliseconds(int64_t(deadline_s * 1000)));
  grpc::CompletionQueue queue;
  std::unique_ptr<grpc::GenericClientAsyncReaderWriter> call =
      stub.PrepareCall(&context, path, &queue);
  // Starts one operation and waits for it: whether it succeeded.
  const auto step = [&](const std::function<void(void*)>& start) {
    start(&queue);
    void* tag = nullptr;
    bool ok = false;
    return queue.Next(&tag, &ok) && ok;
  };
  if (step([&](void* tag) { call->StartCall(tag); })) {
    const grpc::Slice slice(request);
    const grpc::ByteBuffer message(&slice, 1);
    if (step([&](void* tag) { call->Write(message, tag); })) {
      step([&](void* tag) { call->WritesDone(tag); });
    }
    grpc::ByteBuffer reply;
    int replies = 0;
    while (replies < kMostReplies && step([&](void* tag) { call->Read(&reply, tag); })) {
      if (replies++ == 0 && first_reply != nullptr) *first_reply = bytes_of(reply);
    }
    if (replies == kMostReplies) context.TryCancel();
  }
  grpc::Status status;
  step([&](void* tag) { call->Finish(&status, tag); });
  queue.Shutdown();
  void* tag;
  bool ok;
  while (queue.Next(&tag, &ok)) {
  }
  return status;
}

// Codes that say the server broke or stopped answering, or let a call outlive its deadline; any
// other refusal of a hostile call is what the server may answer.
bool broken(grpc::StatusCode code) {
  return code == grpc::StatusCode::UNAVAILABLE || code == grpc::StatusCode::DEADLINE_EXCEEDED ||
         code == grpc::StatusCode::UNKNOWN;
}

std::string status_text(const grpc::Status& status) { return client::to_absl(status).ToString(); }

// A connection of its own for hostile calls, so that what they do to their transport (a message
// over the limit, a reset stream) is not shared with the well-formed clients' calls.
std::shared_ptr<grpc::Channel> own_channel(int port) {
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  args.SetInt(GRPC_ARG_ENABLE_HTTP_PROXY, 0);
  args.SetMaxSendMessageSize(-1);
  args.SetMaxReceiveMessageSize(kHostileMaxMessageMb << 20);
  return grpc::CreateCustomChannel(absl::StrCat("127.0.0.1:", port),
                                   grpc::InsecureChannelCredentials(), args);
}

// --- sockets ---

// Runs what `start` begins on `io` to its end and returns its error; the stream's deadline, set
// before, bounds it.
template <typename Start>
beast::error_code await(asio::io_context& io, Start&& start) {
  beast::error_code result = asio::error::operation_aborted;
  start([&result](beast::error_code ec, auto&&...) { result = ec; });
  io.restart();
  io.run();
  return result;
}

tcp::endpoint loopback(int port) {
  return {asio::ip::make_address_v4("127.0.0.1"), uint16_t(port)};
}

bhttp::request<bhttp::empty_body> get_request(int port, const std::string& target) {
  bhttp::request<bhttp::empty_body> request(bhttp::verb::get, target, 11);
  request.set(bhttp::field::host, absl::StrCat("127.0.0.1:", port));
  request.keep_alive(false);
  return request;
}

// --- the record ---

enum class Outcome { kRefused, kAccepted, kBusy, kUnexpected };

void record(HostileLog& log, Outcome outcome, const std::string& what = "") {
  ++log.probes;
  switch (outcome) {
    case Outcome::kRefused:
      ++log.refused;
      break;
    case Outcome::kAccepted:
      ++log.accepted;
      break;
    case Outcome::kBusy:
      ++log.busy;
      break;
    case Outcome::kUnexpected:
      ++log.unexpected;
      if (log.first_unexpected.size() < kFirstUnexpected) log.first_unexpected.push_back(what);
      break;
  }
}

}  // namespace

void HostileLog::merge(const HostileLog& other) {
  actions += other.actions;
  probes += other.probes;
  refused += other.refused;
  accepted += other.accepted;
  busy += other.busy;
  unexpected += other.unexpected;
  for (const std::string& e : other.first_unexpected) {
    if (first_unexpected.size() < kFirstUnexpected) first_unexpected.push_back(e);
  }
}

class HostileClient::Impl {
 public:
  Impl(int index, const HostilePorts& ports, const std::string& target, const Scene& scene,
       double deadline_s)
      : index_(index),
        ports_(ports),
        target_(target),
        scene_(scene),
        deadline_s_(deadline_s),
        timeout_(std::chrono::milliseconds(int64_t(deadline_s * 1000))) {}

  void act(HostileLogs& logs) {
    const int kind = int((uint64_t(index_) + actions_) % kHostileClasses);
    // Which variant of the class: turns with every visit, and differs between clients.
    const uint64_t variant = uint64_t(index_) + actions_ / kHostileClasses;
    ++actions_;
    HostileLog& log = logs[kind];
    ++log.actions;
    // A gRPC connection for this action alone, closed after it: the server holds on to the
    // buffers of a large message (a megabyte string, a refused oversized message) for as long as
    // the connection that sent it stays open, which would make the memory at the start and the
    // end depend on what each client sent last.
    channel_ = own_channel(ports_.grpc);
    stub_ = v1::RenderService::NewStub(channel_);
    switch (kind) {
      case kHostileStrings:
        hostile_strings(log, variant);
        break;
      case kMalformedBytes:
        malformed_bytes(log, variant);
        break;
      case kWebSocketRefusals:
        websocket_refusals(log, variant);
        break;
      case kSlowConnections:
        slow_connections(log);
        break;
      case kAbruptDisconnects:
        abrupt_disconnects(log);
        break;
    }
    stub_.reset();
    channel_.reset();
  }

 private:
  std::vector<std::pair<const char*, int>> every_port() const {
    return {{"grpc", ports_.grpc},
            {"health", ports_.health},
            {"metrics", ports_.metrics},
            {"http", ports_.http}};
  }
  bool is_http(int port) const { return port == ports_.metrics || port == ports_.http; }
  std::string path_on(int port) const { return port == ports_.metrics ? "/metrics" : "/"; }

  std::unique_ptr<grpc::ClientContext> context() const {
    auto context = std::make_unique<grpc::ClientContext>();
    context->set_deadline(std::chrono::system_clock::now() + timeout_);
    return context;
  }

  // A stream connected to `port`, or the error (a port that stopped taking connections).
  beast::error_code connect(beast::tcp_stream& stream, int port) {
    stream.expires_after(timeout_);
    return await(io_, [&](auto done) { stream.async_connect(loopback(port), done); });
  }

  beast::error_code write(beast::tcp_stream& stream, const std::string& bytes) {
    stream.expires_after(timeout_);
    return await(io_, [&](auto done) { asio::async_write(stream, asio::buffer(bytes), done); });
  }

  // The status of the HTTP response the stream receives next, or the error.
  absl::StatusOr<int> read_status(beast::tcp_stream& stream) {
    beast::flat_buffer buffer;
    bhttp::response<bhttp::string_body> response;
    stream.expires_after(timeout_);
    const beast::error_code ec =
        await(io_, [&](auto done) { bhttp::async_read(stream, buffer, response, done); });
    if (ec) return absl::UnavailableError(absl::StrCat("no HTTP response: ", ec.message()));
    return response.result_int();
  }

  // Connects, sends `bytes` and closes. The server may close first, which is a refusal too; only
  // a port that no longer takes connections is unexpected.
  void send_and_close(HostileLog& log, const char* name, int port, const std::string& bytes) {
    beast::tcp_stream stream(io_);
    if (beast::error_code ec = connect(stream, port)) {
      record(log, Outcome::kUnexpected,
             absl::StrCat("the ", name, " port ", port, " took no connection: ", ec.message()));
      return;
    }
    write(stream, bytes);
    record(log, Outcome::kAccepted);
  }

  // A /ws session, or why none came; `busy` when the upgrade met the WebSocket limit (503).
  std::unique_ptr<WebSocket> open_viewer(HostileLog& log) {
    auto ws = std::make_unique<WebSocket>(io_);
    if (beast::error_code ec = connect(beast::get_lowest_layer(*ws), ports_.http)) {
      record(log, Outcome::kUnexpected,
             absl::StrCat("the viewer port took no connection: ", ec.message()));
      return nullptr;
    }
    websocket::response_type response;
    beast::get_lowest_layer(*ws).expires_after(timeout_);
    const beast::error_code ec = await(io_, [&](auto done) {
      ws->async_handshake(response, absl::StrCat("127.0.0.1:", ports_.http), "/ws", done);
    });
    if (!ec) return ws;
    if (response.result() == bhttp::status::service_unavailable) {
      record(log, Outcome::kBusy);
    } else {
      record(
          log, Outcome::kUnexpected,
          absl::StrCat("WebSocket upgrade: ", ec.message(), " (HTTP ", response.result_int(), ")"));
    }
    return nullptr;
  }

  beast::error_code send_text(WebSocket& ws, const Json& message) {
    const std::string text = message.dump(-1, ' ', false, Json::error_handler_t::replace);
    ws.text(true);
    beast::get_lowest_layer(ws).expires_after(timeout_);
    return await(io_, [&](auto done) { ws.async_write(asio::buffer(text), done); });
  }

  // The viewer's next text message (frames, which are binary, are skipped), or why none came.
  absl::StatusOr<Json> read_text(WebSocket& ws) {
    beast::flat_buffer buffer;
    const Clock::time_point give_up = Clock::now() + timeout_;
    while (Clock::now() < give_up) {
      beast::get_lowest_layer(ws).expires_after(timeout_);
      if (beast::error_code ec = await(io_, [&](auto done) { ws.async_read(buffer, done); })) {
        return absl::UnavailableError(absl::StrCat("no viewer message: ", ec.message()));
      }
      if (ws.got_text()) {
        Json message = Json::parse(beast::buffers_to_string(buffer.data()), nullptr, false);
        if (message.is_discarded()) return absl::DataLossError("a viewer message not JSON");
        return message;
      }
      buffer.consume(buffer.size());
    }
    return absl::DeadlineExceededError("no viewer text message, only frames");
  }

  // Expects a viewer message of `type` next; records it as `outcome` or as unexpected.
  void expect_text(HostileLog& log, WebSocket& ws, const char* type, Outcome outcome,
                   const char* after, const char* mention = nullptr) {
    absl::StatusOr<Json> reply = read_text(ws);
    if (!reply.ok()) {
      record(log, Outcome::kUnexpected, absl::StrCat(after, ": ", reply.status().ToString()));
    } else if (reply->value("type", "") != type ||
               (mention != nullptr && !absl::StrContains(reply->value("message", ""), mention))) {
      record(log, Outcome::kUnexpected, absl::StrCat(after, ": ", reply->dump()));
    } else {
      record(log, outcome);
    }
  }

  // (a) One method, each of its string fields in a call of its own, with one hostile value. Any
  // answer but a broken server's is acceptable; an upload that was accepted is deleted again.
  void hostile_strings(HostileLog& log, uint64_t variant) {
    const std::vector<HostileMethod>& methods = hostile_methods();
    if (methods.empty()) {
      record(log, Outcome::kUnexpected, "no RenderService method with a string field found");
      return;
    }
    const HostileMethod& method = methods[variant % methods.size()];
    const std::string& value =
        hostile_values()[(variant / methods.size()) % hostile_values().size()];
    for (const FieldChain& chain : method.strings) {
      std::string reply;
      const grpc::Status status =
          generic_call(channel_, method.path, hostile_request(method, chain, value, target_),
                       deadline_s_, &reply);
      const std::string call = absl::StrCat(method.path, " with ", value.size(), " bytes in ",
                                            chain.back()->full_name());
      if (broken(status.error_code())) {
        record(log, Outcome::kUnexpected, absl::StrCat(call, ": ", status_text(status)));
        continue;
      }
      record(log, status.ok() ? Outcome::kAccepted : Outcome::kRefused);
      v1::SceneInfo made;
      if (status.ok() && method.method->name() == "UploadScene" && made.ParseFromString(reply) &&
          !made.scene_id().empty()) {
        v1::DeleteSceneRequest remove;
        remove.set_scene_id(made.scene_id());
        v1::DeleteSceneResponse removed;
        if (grpc::Status s = stub_->DeleteScene(context().get(), remove, &removed); !s.ok()) {
          record(log, Outcome::kUnexpected,
                 absl::StrCat(call, " made a scene that could not be deleted: ", status_text(s)));
        }
      }
    }
  }

  // (b) By turns: requests cut short, garbage, and requests over the limits, on every port.
  void malformed_bytes(HostileLog& log, uint64_t variant) {
    // An HTTP request header without the blank line that ends it.
    const std::string request_head = "GET /metrics HTTP/1.1\r\nHost: 127.0.0.1\r\n";
    switch (variant % 3) {
      case 0: {
        v1::GetSceneRequest request;
        request.set_scene_id(target_);
        std::string cut = request.SerializeAsString();
        cut.resize(cut.size() / 2);
        const grpc::Status status =
            generic_call(channel_, "/caustica.v1.RenderService/GetScene", cut, deadline_s_);
        if (status.ok() || broken(status.error_code())) {
          record(log, Outcome::kUnexpected,
                 absl::StrCat("GetScene cut short: ", status_text(status)));
        } else {
          record(log, Outcome::kRefused);
        }
        for (const auto& [name, port] : every_port()) {
          const std::string whole = is_http(port) ? request_head : std::string(kHttp2Preface);
          send_and_close(log, name, port, whole.substr(0, whole.size() / 2));
        }
        break;
      }
      case 1: {
        int i = 0;
        for (const auto& [name, port] : every_port()) {
          send_and_close(log, name, port, garbage()[(variant / 3 + i++) % garbage().size()]);
        }
        break;
      }
      default: {
        const grpc::Status status = generic_call(
            channel_, "/caustica.v1.RenderService/UploadScene",
            std::string((size_t(kHostileMaxMessageMb) << 20) + 4096, '\x0a'), deadline_s_);
        if (status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
          record(log, Outcome::kRefused);
        } else {
          record(log, Outcome::kUnexpected,
                 absl::StrCat("an UploadScene message over the limit: ", status_text(status)));
        }
        for (const auto& [name, port] : every_port()) {
          if (!is_http(port)) {
            send_and_close(log, name, port,
                           std::string(kHttp2Preface) + std::string(size_t{1} << 20, '\xff'));
            continue;
          }
          beast::tcp_stream stream(io_);
          if (beast::error_code ec = connect(stream, port)) {
            record(log, Outcome::kUnexpected,
                   absl::StrCat("the ", name, " port took no connection: ", ec.message()));
            continue;
          }
          write(stream, absl::StrCat(request_head, "X-Filler: ",
                                     std::string(kOversizedHeaderBytes, 'a'), "\r\n\r\n"));
          const absl::StatusOr<int> answer = read_status(stream);
          if (answer.ok() && *answer == 431) {
            record(log, Outcome::kRefused);
          } else {
            record(log, Outcome::kUnexpected,
                   absl::StrCat(
                       "a header over the limit on the ", name, " port: ",
                       answer.ok() ? absl::StrCat("HTTP ", *answer) : answer.status().ToString()));
          }
        }
        break;
      }
    }
  }

  // (c) A hello with a token gRPC metadata cannot carry (refused by name, the session goes on),
  // a good hello, then a message announced far over the limit (closed with 1009 unread).
  void websocket_refusals(HostileLog& log, uint64_t variant) {
    std::unique_ptr<WebSocket> ws = open_viewer(log);
    if (ws == nullptr) return;
    send_text(*ws, {{"type", "hello"}, {"token", bad_tokens()[variant % bad_tokens().size()]}});
    expect_text(log, *ws, "error", Outcome::kRefused, "a hello with a bad token", "token");
    send_text(*ws, {{"type", "hello"}, {"token", ""}});
    expect_text(log, *ws, "scenes", Outcome::kAccepted, "a hello after a refused one");

    // A masked text frame with a 64-bit length, then some of what it announces.
    std::string frame = {char(0x81), char(0x80 | 127)};
    for (int shift = 56; shift >= 0; shift -= 8) {
      frame.push_back(char((kAnnouncedMessageBytes >> shift) & 0xff));
    }
    frame += std::string("\x11\x22\x33\x44") + std::string(4096, 'a');
    write(beast::get_lowest_layer(*ws), frame);
    beast::flat_buffer buffer;
    beast::get_lowest_layer(*ws).expires_after(timeout_);
    const beast::error_code ec = await(io_, [&](auto done) { ws->async_read(buffer, done); });
    if (ws->reason().code == websocket::close_code::too_big) {
      record(log, Outcome::kRefused);
    } else {
      record(log, Outcome::kUnexpected,
             absl::StrCat("a WebSocket message announced as ", kAnnouncedMessageBytes,
                          " bytes: close code ", ws->reason().code, ", ", ec.message()));
    }
  }

  // (d) Idle sockets and sockets whose request trickles in, on every port, held for a few seconds
  // while the other clients work. The HTTP ports must still answer the trickled request once it
  // is whole; the gRPC ports get their connection preface as slowly.
  void slow_connections(HostileLog& log) {
    struct Slow {
      std::unique_ptr<beast::tcp_stream> stream;
      int port;
      std::string request;
    };
    std::vector<std::unique_ptr<beast::tcp_stream>> idle;
    std::vector<Slow> slow;
    for (const auto& [name, port] : every_port()) {
      for (int i = 0; i < kIdlePerPort + kSlowPerPort; ++i) {
        auto stream = std::make_unique<beast::tcp_stream>(io_);
        if (beast::error_code ec = connect(*stream, port)) {
          record(log, Outcome::kUnexpected,
                 absl::StrCat("the ", name, " port took no connection: ", ec.message()));
          continue;
        }
        record(log, Outcome::kAccepted);
        if (i < kIdlePerPort) {
          idle.push_back(std::move(stream));
        } else {
          slow.push_back({std::move(stream), port,
                          is_http(port) ? absl::StrCat("GET ", path_on(port),
                                                       " HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                                                       "Connection: close\r\n")
                                        : std::string(kHttp2Preface)});
        }
      }
    }
    for (int step = 0; step < kTrickleSteps; ++step) {
      for (Slow& s : slow) {
        const size_t from = s.request.size() * step / kTrickleSteps;
        const size_t to = s.request.size() * (step + 1) / kTrickleSteps;
        write(*s.stream, s.request.substr(from, to - from));
      }
      std::this_thread::sleep_for(kTricklePause);
    }
    for (Slow& s : slow) {
      if (!is_http(s.port)) continue;
      write(*s.stream, "\r\n");
      const absl::StatusOr<int> answer = read_status(*s.stream);
      if (answer.ok() && *answer == 200) {
        record(log, Outcome::kAccepted);
      } else {
        record(log, Outcome::kUnexpected,
               absl::StrCat(
                   "a request trickled in over ", kTrickleSteps * kTricklePause.count(),
                   " ms to port ", s.port, ": ",
                   answer.ok() ? absl::StrCat("HTTP ", *answer) : answer.status().ToString()));
      }
    }
  }

  // (e) A stream cancelled after its first frame, an upload cut off after its header, and a
  // viewer whose socket is reset while its scene streams.
  void abrupt_disconnects(HostileLog& log) {
    {
      std::unique_ptr<grpc::ClientContext> call = context();
      v1::StreamFramesRequest request;
      request.set_scene_id(target_);
      request.set_target_passes(kEndlessPasses);
      auto reader = stub_->StreamFrames(call.get(), request);
      v1::Frame frame;
      const bool got_frame = reader->Read(&frame);
      call->TryCancel();
      const grpc::Status status = reader->Finish();
      if (got_frame && status.error_code() == grpc::StatusCode::CANCELLED) {
        record(log, Outcome::kAccepted);
      } else {
        record(log, Outcome::kUnexpected,
               absl::StrCat("a stream cancelled after ", got_frame ? "its first frame" : "no frame",
                            ": ", status_text(status)));
      }
    }
    {
      std::unique_ptr<grpc::ClientContext> call = context();
      v1::SceneInfo info;
      auto writer = stub_->UploadScene(call.get(), &info);
      v1::SceneChunk header;
      *header.mutable_header() = wire::encode_scene_header(scene_, "soak upload cut off");
      writer->Write(header);
      call->TryCancel();
      const grpc::Status status = writer->Finish();
      if (status.error_code() == grpc::StatusCode::CANCELLED) {
        record(log, Outcome::kAccepted);
      } else {
        record(log, Outcome::kUnexpected,
               absl::StrCat("an upload cut off after its header: ", status_text(status)));
      }
    }
    if (std::unique_ptr<WebSocket> ws = open_viewer(log)) {
      send_text(*ws, {{"type", "hello"}, {"token", ""}});
      expect_text(log, *ws, "scenes", Outcome::kAccepted, "a hello");
      send_text(*ws, {{"type", "open"}, {"scene", target_}});
      expect_text(log, *ws, "scene", Outcome::kAccepted, "an open");
      // A reset rather than a close: a linger time of zero.
      tcp::socket& socket = beast::get_lowest_layer(*ws).socket();
      const linger reset{.l_onoff = 1, .l_linger = 0};
      setsockopt(socket.native_handle(), SOL_SOCKET, SO_LINGER, &reset, sizeof reset);
      beast::error_code ignored;
      socket.close(ignored);
    }
  }

  const int index_;
  const HostilePorts ports_;
  const std::string target_;
  const Scene& scene_;
  const double deadline_s_;
  const std::chrono::milliseconds timeout_;
  uint64_t actions_ = 0;
  asio::io_context io_;
  // The gRPC connection of the action under way.
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::RenderService::Stub> stub_;
};

HostileClient::HostileClient(int index, const HostilePorts& ports,
                             const std::string& target_scene_id, const Scene& scene,
                             double deadline_s)
    : impl_(std::make_unique<Impl>(index, ports, target_scene_id, scene, deadline_s)) {}
HostileClient::~HostileClient() = default;

void HostileClient::act(HostileLogs& logs) { impl_->act(logs); }

std::vector<PortCheck> check_every_port(const HostilePorts& ports, double deadline_s) {
  const auto timeout = std::chrono::milliseconds(int64_t(deadline_s * 1000));
  std::vector<PortCheck> checks;
  const auto timed = [&](const char* name, const std::function<absl::Status()>& check) {
    const Clock::time_point start = Clock::now();
    absl::Status status = check();
    checks.push_back({name, std::move(status),
                      std::chrono::duration<double, std::milli>(Clock::now() - start).count()});
  };
  const auto health = [&](int port) {
    return [&, port]() -> absl::Status {
      absl::StatusOr<client::ServingStatus> serving =
          client::check_health(client::make_channel(absl::StrCat("127.0.0.1:", port), 1 << 20),
                               std::chrono::system_clock::now() + timeout, true);
      if (!serving.ok()) return serving.status();
      if (*serving != client::ServingStatus::kServing) {
        return absl::UnavailableError(absl::StrCat("health status ", int(*serving)));
      }
      return absl::OkStatus();
    };
  };
  asio::io_context io;
  const auto get = [&](int port, const std::string& target) {
    return [&, port, target]() -> absl::Status {
      beast::tcp_stream stream(io);
      stream.expires_after(timeout);
      beast::error_code ec =
          await(io, [&](auto done) { stream.async_connect(loopback(port), done); });
      const bhttp::request<bhttp::empty_body> request = get_request(port, target);
      if (!ec) ec = await(io, [&](auto done) { bhttp::async_write(stream, request, done); });
      beast::flat_buffer buffer;
      bhttp::response<bhttp::string_body> response;
      if (!ec)
        ec = await(io, [&](auto done) { bhttp::async_read(stream, buffer, response, done); });
      if (ec) return absl::UnavailableError(absl::StrCat("GET ", target, ": ", ec.message()));
      if (response.result() != bhttp::status::ok) {
        return absl::UnavailableError(
            absl::StrCat("GET ", target, ": HTTP ", response.result_int()));
      }
      return absl::OkStatus();
    };
  };
  timed("grpc", health(ports.grpc));
  timed("health", health(ports.health));
  timed("metrics", get(ports.metrics, "/metrics"));
  timed("http", get(ports.http, "/"));
  return checks;
}

}  // namespace caustica
