// The embedded default: without --server, and with nothing serving on localhost:50051, the CLI
// starts its own caustica-server on a free loopback port for the length of one command, so that
// `caustica render scene.json -o out.png` works on a laptop with nothing set up. It keeps scenes
// in a data directory (default_data_dir), so that a scene uploaded by one command is there for
// the next.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace caustica::client {

// Where caustica-server is: $CAUSTICA_SERVER_BIN, else next to the running executable (an
// install), else ../server/ beside it (the build tree, where client/ and server/ are siblings).
absl::StatusOr<std::filesystem::path> find_server_binary();

// $CAUSTICA_DATA_DIR (set but empty: none), else $XDG_STATE_HOME/caustica, else
// ~/.local/state/caustica; none without a home directory.
std::optional<std::filesystem::path> default_data_dir();

struct EmbeddedServerOptions {
  std::filesystem::path binary = {};  // empty: find_server_binary()
  // The server's --data-dir: nullopt takes default_data_dir(), an empty path keeps none. When
  // another embedded server holds it (another command running now), this one keeps none and says
  // so on stderr.
  std::optional<std::filesystem::path> data_dir = std::nullopt;
  std::vector<std::string> extra_args;        // appended to --listen and --port-file
  std::vector<std::string> environment = {};  // "NAME=value", over the client's own environment
  // Also open the health, metrics and viewer HTTP ports on free loopback ports, for clients that
  // test every port the server can open.
  bool every_port = false;
  std::chrono::seconds startup_timeout{60};
};

class EmbeddedServer {
 public:
  // Starts the server with --listen 127.0.0.1:0 --port-file, waits for the port it chose (and
  // with every_port the others') and for its health to report SERVING. Errors carry the tail of
  // the server's log.
  static absl::StatusOr<std::unique_ptr<EmbeddedServer>> start(
      const EmbeddedServerOptions& options);

  // Stops the server with SIGTERM (SIGKILL after a grace period) and removes its files.
  ~EmbeddedServer();
  EmbeddedServer(const EmbeddedServer&) = delete;
  EmbeddedServer& operator=(const EmbeddedServer&) = delete;

  const std::string& address() const { return address_; }  // "127.0.0.1:PORT"
  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  // With every_port, the other ports chosen; else 0.
  int health_port() const { return health_port_; }
  int metrics_port() const { return metrics_port_; }
  int http_port() const { return http_port_; }
  // Where its scenes are kept; empty: nowhere (they go with the command).
  const std::filesystem::path& data_dir() const { return data_dir_; }

 private:
  EmbeddedServer(pid_t pid, std::filesystem::path dir) : pid_(pid), dir_(std::move(dir)) {}
  absl::Status wait_until_serving(std::chrono::steady_clock::time_point give_up);
  std::string log_tail() const;

  pid_t pid_;
  std::filesystem::path dir_;  // temporary: port file and server log
  std::string address_;
  int port_ = 0, health_port_ = 0, metrics_port_ = 0, http_port_ = 0;
  std::filesystem::path data_dir_;
};

}  // namespace caustica::client
