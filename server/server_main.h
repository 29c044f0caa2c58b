// caustica-server as a library: options, the running server (start, port, shutdown) and
// run_server, which main() calls: it serves until SIGTERM or SIGINT and then shuts down
// gracefully (running calls finish or are cancelled after a grace period; exit code 0).
#pragma once

#include <grpcpp/grpcpp.h>

#include <cstddef>
#include <memory>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "server/render_service.h"

namespace caustica::server {

struct ServerOptions {
  std::string listen = "127.0.0.1:50051";  // host:port; port 0 picks a free one
  std::string port_file;                   // when set, the bound port is written here
  std::string device = "auto";             // auto | cpu | cuda
  size_t max_scenes = 16;
  size_t memory_budget_bytes = size_t{8} << 30;
  size_t max_message_mb = 64;
  std::string log_level = "info";
  double shutdown_grace_s = 5;  // how long running calls may finish before they are cancelled
  std::string metrics_listen;   // host:port for Prometheus' /metrics; empty: none
};

// "8G", "512M", "64k", "1.5G" (binary units, case-insensitive, optional trailing B or iB) or a
// plain byte count.
absl::StatusOr<size_t> parse_byte_size(std::string_view text);

class Server {
 public:
  static absl::StatusOr<std::unique_ptr<Server>> start(const ServerOptions& options);
  ~Server();

  int port() const { return port_; }
  // Stops accepting calls, ends streams between passes (UNAVAILABLE) and waits for running calls
  // at most the grace period before cancelling them. Returns once every handler has returned.
  void shutdown();

 private:
  Server() = default;
  ServerOptions options_;
  std::unique_ptr<RenderService> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  bool stopped_ = false;
};

// Serves until SIGTERM/SIGINT. Returns the process exit code (0 after a signal, 1 when the server
// could not start, with the reason on stderr).
int run_server(const ServerOptions& options);

}  // namespace caustica::server
