// caustica-server: flag parsing only; the server is run_server (server_main.h).
#include <CLI/CLI.hpp>
#include <string>

#include "proto/wire/api_version.h"
#include "server/log.h"
#include "server/server_main.h"

int main(int argc, char** argv) {
  caustica::server::ServerOptions options;
  std::string memory_budget = "8G";
  CLI::App app{"Caustica render server: resident scenes, photon-mapped frames over gRPC."};
  app.set_version_flag("--version", std::string("caustica-server ") +
                                        caustica::wire::release_version() + " (API " +
                                        caustica::wire::api_version() + ")");
  app.add_option("--listen", options.listen, "host:port to listen on; port 0 picks a free port")
      ->capture_default_str();
  app.add_option("--port-file", options.port_file, "write the bound port to this file");
  app.add_option("--device", options.device, "auto, cpu or cuda")
      ->check(CLI::IsMember({"auto", "cpu", "cuda"}))
      ->capture_default_str();
  app.add_option("--max-scenes", options.max_scenes, "most resident scenes")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--memory-budget", memory_budget,
                 "device memory for all scenes together: bytes or 512M, 8G, ...")
      ->capture_default_str();
  app.add_option("--max-message-mb", options.max_message_mb, "largest gRPC message in MiB")
      ->check(CLI::Range(1, 2047))
      ->capture_default_str();
  app.add_option("--log-level", options.log_level, "debug, info, warning or error")
      ->capture_default_str();
  app.add_option("--shutdown-grace", options.shutdown_grace_s,
                 "seconds running calls may take to finish after SIGTERM/SIGINT")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--metrics-listen", options.metrics_listen,
                 "host:port to serve Prometheus metrics on (/metrics); port 0 picks a free port; "
                 "off by default");
  CLI11_PARSE(app, argc, argv);

  absl::StatusOr<size_t> budget = caustica::server::parse_byte_size(memory_budget);
  if (!budget.ok()) {
    caustica::server::log_line(
        caustica::server::LogLevel::kError,
        std::string("--memory-budget: ") + std::string(budget.status().message()));
    return 1;
  }
  options.memory_budget_bytes = *budget;
  return caustica::server::run_server(options);
}
