// caustica-server as a library: options, the running server (start, port, shutdown) and
// run_server, which main() calls: it serves until SIGTERM or SIGINT and then shuts down
// gracefully (running calls finish or are cancelled after a grace period; exit code 0).
#pragma once

#include <grpcpp/grpcpp.h>

#include <cstddef>
#include <memory>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "server/health_status.h"
#include "server/heap.h"
#include "server/render_service.h"
#include "server/viewer/viewer_http.h"

namespace caustica::server {

struct ServerOptions {
  std::string listen = "127.0.0.1:50051";  // host:port; port 0 picks a free one
  std::string port_file;                   // when set, the bound port is written here
  std::string device = "auto";             // auto | cpu | cuda
  // Which devices of that kind to serve on (parse_devices): all, a count or a list of ordinals.
  std::string devices = "all";
  // Every scene on every device, so that one frame uses them all; else each scene lives on the
  // one device with the most free budget when it arrives.
  bool split_frames = false;
  size_t max_scenes = 16;
  size_t memory_budget_bytes = size_t{8} << 30;  // per device
  size_t max_message_mb = 64;
  // What gRPC's transport may hold for all connections together (read buffers, messages being
  // received); past it, idle connections' buffers are released first. 0: the larger of 1024 and
  // twice max_message_mb.
  size_t transport_memory_mb = 0;
  std::string log_level = "info";
  double shutdown_grace_s = 5;  // how long running calls may finish before they are cancelled
  // Connections older than this are asked to go away (GOAWAY), so that clients behind a load
  // balancer or a DNS name spread onto replicas added since; running calls get
  // max_connection_age_grace_s to finish. 0: connections live as long as their clients.
  double max_connection_age_s = 0;
  double max_connection_age_grace_s = 30;
  std::string metrics_listen;      // host:port for Prometheus' /metrics; empty: none
  std::string metrics_port_file;   // when set, metrics_listen's bound port is written here
  std::string data_dir;            // durable scenes (scene_store.h); empty: none
  size_t max_tenant_scenes = 0;    // per tenant; 0: up to max_scenes
  double tenant_memory_share = 1;  // of memory_budget_bytes, per tenant
  size_t max_tenant_streams = 0;   // per tenant; 0: no limit
  double scene_idle_ttl_s = 0;     // 0: scenes stay until deleted
  // TLS on --listen: PEM certificate chain and key; empty: plaintext, which needs a loopback
  // --listen or `insecure`. With tls_client_ca, clients must present a certificate it signed.
  std::string tls_cert;
  std::string tls_key;
  std::string tls_client_ca;
  std::string tokens_file;       // `token,tenant` lines; empty: every caller is the default tenant
  bool insecure = false;         // allow plaintext on an address other machines can reach
  std::string health_listen;     // host:port of a plaintext, health-only server; empty: none
  std::string health_port_file;  // when set, health_listen's bound port is written here
  // The browser viewer (docs/viewer.md): plaintext HTTP under the same loopback-or-insecure rule
  // as --listen; empty: none. Its bound port is written to http_port_file when set.
  std::string http_listen;
  std::string http_port_file;
};

// "8G", "512M", "64k", "1.5G" (binary units, case-insensitive, optional trailing B or iB) or a
// plain byte count.
absl::StatusOr<size_t> parse_byte_size(std::string_view text);

// The most devices one server renders on.
inline constexpr size_t kMaxDevices = 64;

// --devices for `kind` on a machine with `visible` GPUs (device_count()): one ordinal per backend
// to make. "all" is every visible GPU (one backend on the CPU); "N" the first N GPUs (N backends
// on the CPU); "0,1" those ordinals, repeats allowed ("0,0": two backends on GPU 0). On the CPU a
// list's ordinals are all 0, only its length counts. INVALID_ARGUMENT naming --devices and the
// value otherwise.
absl::StatusOr<std::vector<int>> parse_devices(std::string_view text, DeviceKind kind, int visible);

class Server {
 public:
  static absl::StatusOr<std::unique_ptr<Server>> start(const ServerOptions& options);
  ~Server();

  int port() const { return port_; }
  // 0 without --health-listen.
  int health_port() const { return health_server_ ? health_server_->port() : 0; }
  // 0 without --http-listen.
  int http_port() const { return viewer_ ? viewer_->port() : 0; }
  // SERVING or NOT_SERVING on the health services of both ports; it starts SERVING.
  void set_serving(bool serving) { health_.set_serving(serving); }
  // Stops accepting calls, ends streams between passes (UNAVAILABLE) and waits for running calls
  // at most the grace period before cancelling them. Returns once every handler has returned.
  void shutdown();

 private:
  Server() = default;
  ServerOptions options_;
  std::unique_ptr<RenderService> service_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<HealthServer> health_server_;       // --health-listen
  std::unique_ptr<viewer::ViewerHttpServer> viewer_;  // --http-listen
  HealthStatus health_;
  int port_ = 0;
  bool stopped_ = false;
  // Restores --data-dir's scenes while the server already answers (NOT_SERVING meanwhile).
  std::thread restore_thread_;
  // Gives freed heap pages back, so that resident memory follows what is in use.
  std::unique_ptr<HeapTrimmer> heap_trimmer_;
};

// Serves until SIGTERM/SIGINT. Returns the process exit code (0 after a signal, 1 when the server
// could not start, with the reason on stderr).
int run_server(const ServerOptions& options);

}  // namespace caustica::server
