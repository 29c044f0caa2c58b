#include "server/server_main.h"

#include <grpcpp/resource_quota.h>
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>
#include <pthread.h>
#include <signal.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <thread>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "proto/wire/api_version.h"
#include "server/auth.h"
#include "server/log.h"

namespace caustica::server {
namespace {

// --transport-memory-mb, or its default where it is 0.
size_t transport_memory_bytes(const ServerOptions& options) {
  const size_t mb = options.transport_memory_mb != 0
                        ? options.transport_memory_mb
                        : std::max<size_t>(1024, 2 * options.max_message_mb);
  return mb << 20;
}

// Written beside the target and renamed, so a reader never sees a half-written port.
absl::Status write_port_file(const std::string& path, int port,
                             std::string_view flag = "--port-file") {
  const std::string temporary = path + ".tmp";
  {
    std::ofstream out(temporary, std::ios::trunc);
    out << port << "\n";
    if (!out) {
      return absl::InternalError(absl::StrCat(std::string(flag), ": cannot write ", temporary));
    }
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) {
    return absl::InternalError(
        absl::StrCat(std::string(flag), ": cannot write ", path, ": ", error.message()));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<size_t> parse_byte_size(std::string_view text) {
  const std::string lower = absl::AsciiStrToLower(absl::StripAsciiWhitespace(std::string(text)));
  std::string_view rest = lower;
  double value = 0;
  const auto [end, error] = std::from_chars(rest.data(), rest.data() + rest.size(), value);
  auto refuse = [&] {
    return absl::InvalidArgumentError(
        absl::StrCat("'", std::string(text),
                     "' is not a size (expected bytes or a number with K, M, G or T, e.g. 512M)"));
  };
  if (error != std::errc() || !std::isfinite(value) || value < 0) return refuse();
  std::string_view unit = rest.substr(static_cast<size_t>(end - rest.data()));
  if (unit.ends_with("ib")) {
    unit.remove_suffix(2);
  } else if (unit.ends_with("b")) {
    unit.remove_suffix(1);
  }
  int shift = 0;
  if (unit == "k") {
    shift = 10;
  } else if (unit == "m") {
    shift = 20;
  } else if (unit == "g") {
    shift = 30;
  } else if (unit == "t") {
    shift = 40;
  } else if (!unit.empty()) {
    return refuse();
  }
  const double bytes = std::ldexp(value, shift);
  if (bytes >= 0x1p63) return refuse();
  return static_cast<size_t>(bytes);
}

absl::StatusOr<std::vector<int>> parse_devices(std::string_view text, DeviceKind kind,
                                               int visible) {
  const std::string value(absl::StripAsciiWhitespace(std::string(text)));
  const bool cuda = kind == DeviceKind::kCuda;
  auto refuse = [&](const std::string& why) {
    return absl::InvalidArgumentError(
        absl::StrCat("--devices '", std::string(text), "': ", why,
                     " (expected all, a count N or a comma list of GPU ordinals such as 0,1)"));
  };
  // A plain non-negative decimal, without sign, blanks or exponent.
  auto number = [](std::string_view digits) -> std::optional<int> {
    int n = 0;
    const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), n);
    if (digits.empty() || error != std::errc() || end != digits.data() + digits.size() || n < 0) {
      return std::nullopt;
    }
    return n;
  };
  auto visible_text = [&] {
    return absl::StrCat(visible, visible == 1 ? " GPU is" : " GPUs are", " visible");
  };
  if (value.empty()) return refuse("is empty");
  if (value == "all") {
    // Without a GPU, make_backend explains why (no driver, no device) better than a count of 0.
    if (!cuda || visible <= 0) return std::vector<int>{0};
    if (static_cast<size_t>(visible) > kMaxDevices) {
      return refuse(absl::StrCat(visible_text(), ", more than the ", kMaxDevices,
                                 " one server renders on; name them"));
    }
    std::vector<int> all(static_cast<size_t>(visible));
    for (int i = 0; i < visible; ++i) all[static_cast<size_t>(i)] = i;
    return all;
  }
  if (value.find(',') == std::string::npos) {
    const std::optional<int> count = number(value);
    if (!count) return refuse(absl::StrCat("'", value, "' is not a count"));
    if (*count == 0) return refuse("a count must be at least 1");
    if (static_cast<size_t>(*count) > kMaxDevices) {
      return refuse(absl::StrCat("at most ", kMaxDevices, " devices"));
    }
    if (cuda && *count > visible) {
      return refuse(absl::StrCat("asks for ", *count, " GPUs but ", visible_text()));
    }
    std::vector<int> first(static_cast<size_t>(*count), 0);
    if (cuda) {
      for (int i = 0; i < *count; ++i) first[static_cast<size_t>(i)] = i;
    }
    return first;
  }
  std::vector<int> ordinals;
  for (const std::string& part : std::vector<std::string>(absl::StrSplit(value, ','))) {
    const std::string item(absl::StripAsciiWhitespace(part));
    if (item.empty()) return refuse("an entry of the list is empty");
    const std::optional<int> ordinal = number(item);
    if (!ordinal) return refuse(absl::StrCat("'", item, "' is not a device ordinal"));
    if (cuda && *ordinal >= visible) {
      return refuse(absl::StrCat("no GPU ", *ordinal, ": ", visible_text(),
                                 visible > 0 ? absl::StrCat(" (0 to ", visible - 1, ")") : ""));
    }
    ordinals.push_back(cuda ? *ordinal : 0);
  }
  if (ordinals.size() > kMaxDevices)
    return refuse(absl::StrCat("at most ", kMaxDevices, " devices"));
  return ordinals;
}

absl::StatusOr<std::unique_ptr<Server>> Server::start(const ServerOptions& options) {
  absl::StatusOr<LogLevel> level = parse_log_level(options.log_level);
  if (!level.ok())
    return absl::InvalidArgumentError(absl::StrCat("--log-level: ", level.status().message()));
  set_log_level(*level);
  absl::StatusOr<DeviceKind> device = parse_device_kind(options.device);
  if (!device.ok())
    return absl::Status(device.status().code(),
                        absl::StrCat("--device: ", device.status().message()));
  if (options.max_scenes == 0)
    return absl::InvalidArgumentError("--max-scenes: must be at least 1");
  if (options.max_message_mb == 0 || options.max_message_mb > 2047) {
    return absl::InvalidArgumentError("--max-message-mb: must be in [1, 2047]");
  }
  // Below two messages' worth, one upload and one frame in flight would already press the
  // quota, and gRPC then cancels calls to free memory.
  if (options.transport_memory_mb != 0 &&
      options.transport_memory_mb < 2 * options.max_message_mb) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--transport-memory-mb: ", options.transport_memory_mb,
        " is less than twice --max-message-mb (", options.max_message_mb, ")"));
  }
  if (!(options.tenant_memory_share > 0 && options.tenant_memory_share <= 1)) {
    return absl::InvalidArgumentError("--tenant-memory-share: must be in (0, 1]");
  }
  if (!(options.max_connection_age_s >= 0) || !std::isfinite(options.max_connection_age_s)) {
    return absl::InvalidArgumentError("--max-connection-age: must be a number of seconds >= 0");
  }
  if (!(options.max_connection_age_grace_s >= 0) ||
      !std::isfinite(options.max_connection_age_grace_s)) {
    return absl::InvalidArgumentError(
        "--max-connection-age-grace: must be a number of seconds >= 0");
  }
  if (!(options.scene_idle_ttl_s >= 0) || !std::isfinite(options.scene_idle_ttl_s)) {
    return absl::InvalidArgumentError("--scene-idle-ttl: must be a number of seconds >= 0");
  }
  absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> credentials = listen_credentials(
      options.listen, TlsFiles{options.tls_cert, options.tls_key, options.tls_client_ca},
      options.insecure);
  if (!credentials.ok()) return credentials.status();
  if (!options.http_listen.empty() && !options.insecure &&
      !is_loopback_listen_address(options.http_listen)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--http-listen: ", options.http_listen,
        " is not loopback and the viewer is plaintext HTTP; pass --insecure to serve it anyway"));
  }
  auto authenticator = std::make_shared<const Authenticator>();
  if (!options.tokens_file.empty()) {
    absl::StatusOr<TokenTable> tokens = TokenTable::load(options.tokens_file);
    if (!tokens.ok()) {
      return absl::InvalidArgumentError(absl::StrCat("--tokens: ", tokens.status().message()));
    }
    authenticator = std::make_shared<const Authenticator>(*std::move(tokens));
  }
  std::shared_ptr<SceneStore> store;
  if (!options.data_dir.empty()) {
    absl::StatusOr<std::unique_ptr<SceneStore>> opened = SceneStore::open(options.data_dir);
    if (!opened.ok()) return opened.status();
    store = *std::move(opened);
  }
  absl::StatusOr<std::vector<int>> ordinals =
      parse_devices(options.devices, *device, device_count(*device));
  if (!ordinals.ok()) return ordinals.status();
  std::vector<std::shared_ptr<Backend>> backends;
  for (int ordinal : *ordinals) {
    absl::StatusOr<std::shared_ptr<Backend>> backend =
        make_backend(*device, options.memory_budget_bytes, ordinal);
    if (!backend.ok()) return backend.status();
    backends.push_back(*std::move(backend));
  }

  std::unique_ptr<Server> server(new Server());
  server->options_ = options;
  const size_t max_message_bytes = options.max_message_mb << 20;
  server->service_ = std::make_unique<RenderService>(
      backends, ServiceOptions{.max_scenes = options.max_scenes,
                               .max_message_bytes = max_message_bytes,
                               .store = store,
                               .max_tenant_scenes = options.max_tenant_scenes,
                               .tenant_memory_share = options.tenant_memory_share,
                               .max_tenant_streams = options.max_tenant_streams,
                               .scene_idle_ttl_s = options.scene_idle_ttl_s,
                               .split_frames = options.split_frames});

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options.listen, *credentials, &server->port_);
  builder.RegisterService(server->service_.get());
  // Installed without a token file too, so that handlers always find a verdict (the default
  // tenant then).
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> interceptors;
  interceptors.push_back(std::make_unique<AuthInterceptorFactory>(authenticator));
  builder.experimental().SetInterceptorCreators(std::move(interceptors));
  builder.SetMaxReceiveMessageSize(static_cast<int>(max_message_bytes));
  builder.SetMaxSendMessageSize(static_cast<int>(max_message_bytes));
  // gRPC keeps the read buffers a large message made a connection grow for as long as the
  // connection lives, and gives them back only under its resource quota's pressure, which an
  // unsized quota never feels (docs/server.md, "Running it").
  grpc::ResourceQuota quota("caustica-server transport");
  quota.Resize(transport_memory_bytes(options));
  builder.SetResourceQuota(quota);
  if (options.max_connection_age_s > 0) {
    const auto ms = [](double seconds) {
      return static_cast<int>(std::min(seconds * 1000, double{INT_MAX}));
    };
    builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_AGE_MS, ms(options.max_connection_age_s));
    builder.AddChannelArgument(GRPC_ARG_MAX_CONNECTION_AGE_GRACE_MS,
                               ms(options.max_connection_age_grace_s));
  }
  server->server_ = builder.BuildAndStart();
  if (!server->server_ || server->port_ == 0) {
    return absl::UnavailableError(absl::StrCat("--listen: cannot listen on ", options.listen));
  }
  server->health_.track(*server->server_);
  server->heap_trimmer_ =
      std::make_unique<HeapTrimmer>(std::chrono::seconds(2), kServerTrimFreeBytes);
  if (!options.health_listen.empty()) {
    absl::StatusOr<std::unique_ptr<HealthServer>> health =
        HealthServer::start(options.health_listen);
    if (!health.ok()) {
      server->shutdown();
      return health.status();
    }
    server->health_server_ = *std::move(health);
    server->health_.track(server->health_server_->server());
    if (!options.health_port_file.empty()) {
      if (absl::Status written = write_port_file(options.health_port_file, server->health_port(),
                                                 "--health-port-file");
          !written.ok()) {
        server->shutdown();
        return written;
      }
    }
    log_line(LogLevel::kInfo, absl::StrFormat("caustica-server: health on port %d (%s), plaintext",
                                              server->health_port(), options.health_listen));
  }
  if (store) {
    // Ready only once every stored scene is back; calls meanwhile are UNAVAILABLE.
    // Both ports' health follows, so the health port is tracked before the thread starts.
    server->set_serving(false);
    server->restore_thread_ = std::thread([running = server.get()] {
      running->service_->restore_scenes();
      running->set_serving(true);  // ignored once shutdown has begun
    });
  }
  // Metrics listen before the port file appears, so whoever waits for it can scrape at once.
  if (!options.metrics_listen.empty()) {
    absl::StatusOr<int> metrics_port = server->service_->metrics().serve(options.metrics_listen);
    absl::Status written =
        metrics_port.ok() && !options.metrics_port_file.empty()
            ? write_port_file(options.metrics_port_file, *metrics_port, "--metrics-port-file")
            : metrics_port.status();
    if (!written.ok()) {
      server->shutdown();
      return written;
    }
    log_line(LogLevel::kInfo, absl::StrFormat("caustica-server: metrics on port %d (%s), /metrics",
                                              *metrics_port, options.metrics_listen));
  }
  if (!options.http_listen.empty()) {
    absl::StatusOr<std::unique_ptr<viewer::ViewerHttpServer>> viewer =
        viewer::ViewerHttpServer::start(options.http_listen, server->server_->InProcessChannel({}));
    absl::Status written =
        viewer.ok() && !options.http_port_file.empty()
            ? write_port_file(options.http_port_file, (*viewer)->port(), "--http-port-file")
            : viewer.status();
    if (!written.ok()) {
      server->shutdown();
      return written;
    }
    server->viewer_ = *std::move(viewer);
    server->service_->set_viewer_port(server->http_port());
    log_line(is_loopback_listen_address(options.http_listen) ? LogLevel::kInfo : LogLevel::kWarning,
             absl::StrFormat("caustica-server: viewer on port %d (%s), plaintext HTTP%s",
                             server->http_port(), options.http_listen,
                             is_loopback_listen_address(options.http_listen)
                                 ? ""
                                 : " (--insecure): anyone on the network can read the tokens"));
  }
  if (!options.port_file.empty()) {
    if (absl::Status written = write_port_file(options.port_file, server->port_); !written.ok()) {
      server->shutdown();
      return written;
    }
  }
  const bool serves_tls = !options.tls_cert.empty();
  if (!serves_tls && !is_loopback_listen_address(options.listen)) {
    log_line(LogLevel::kWarning,
             absl::StrCat("caustica-server: plaintext on ", options.listen,
                          " (--insecure): anyone on the network can read and alter the calls",
                          authenticator->requires_tokens() ? ", tokens included" : ""));
  }
  log_line(LogLevel::kInfo,
           absl::StrCat("caustica-server: ",
                        !serves_tls                     ? "plaintext"
                        : options.tls_client_ca.empty() ? "TLS"
                                                        : "TLS with client certificates",
                        "; ",
                        authenticator->requires_tokens()
                            ? absl::StrCat("bearer tokens from ", options.tokens_file)
                            : std::string("no --tokens: every caller is the default tenant")));
  log_line(LogLevel::kInfo,
           absl::StrFormat("caustica-server %s (API %s) listening on port %d (%s); %d %s "
                           "device%s, memory budget %d bytes each; %s; at most %d scenes",
                           wire::release_version(), wire::api_version(), server->port_,
                           options.listen, backends.size(), device_kind_name(*device),
                           backends.size() == 1 ? "" : "s", options.memory_budget_bytes,
                           options.split_frames ? "every scene on every device (--split-frames)"
                                                : "each scene on one device",
                           options.max_scenes));
  for (size_t i = 0; i < backends.size(); ++i) {
    const DeviceInfo info = backends[i]->info();
    log_line(
        LogLevel::kInfo,
        absl::StrFormat("caustica-server: device %d: %s %d, %s, %d compute units", i,
                        device_kind_name(*device), info.ordinal, info.name, info.compute_units));
  }
  return server;
}

void Server::shutdown() {
  if (stopped_) return;
  stopped_ = true;
  if (viewer_) viewer_->stop();  // first: its sessions are clients of the service below
  service_->begin_shutdown();
  health_.shutdown();  // health checks answer NOT_SERVING from now on, on both ports
  // gRPC's own shutdown also waits for clients to close their connections, which idle clients
  // never do before the deadline; so wait for our calls here and then give gRPC only a moment to
  // flush their last messages before it closes every connection.
  const auto grace_end =
      std::chrono::steady_clock::now() +
      std::chrono::milliseconds(static_cast<int64_t>(options_.shutdown_grace_s * 1000));
  while (service_->calls_in_flight() > 0 && std::chrono::steady_clock::now() < grace_end) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  server_->Shutdown(std::chrono::system_clock::now() + std::chrono::milliseconds(200));
  server_->Wait();
  if (restore_thread_.joinable()) restore_thread_.join();
  // Last, so that probes see NOT_SERVING rather than a refused connection while calls finish.
  if (health_server_) health_server_->shutdown();
}

Server::~Server() { shutdown(); }

int run_server(const ServerOptions& options) {
  // Blocked before any thread starts, so every gRPC and TBB thread inherits the mask and the
  // signals wait for sigwait below instead of running a handler in some arbitrary thread.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  absl::StatusOr<std::unique_ptr<Server>> server = Server::start(options);
  if (!server.ok()) {
    log_line(LogLevel::kError, absl::StrCat("caustica-server: ", server.status().message()));
    return 1;
  }
  int signal_number = 0;
  sigwait(&signals, &signal_number);
  log_line(LogLevel::kInfo,
           absl::StrCat("caustica-server: ", strsignal(signal_number), ", shutting down"));
  (*server)->shutdown();
  log_line(LogLevel::kInfo, "caustica-server: stopped");
  return 0;
}

}  // namespace caustica::server
