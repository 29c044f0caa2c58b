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
  app.add_option("--devices", options.devices,
                 "which devices of --device to serve on: all (every visible GPU; one on the "
                 "CPU), a count N (the first N GPUs; N CPU devices) or a comma list of GPU "
                 "ordinals such as 0,1 (repeats allowed: 0,0 is two devices on GPU 0)")
      ->capture_default_str();
  app.add_flag("--split-frames", options.split_frames,
               "place every scene on every device so that one frame uses them all; without it "
               "each scene lives on the device with the most free memory budget");
  app.add_option("--max-scenes", options.max_scenes, "most resident scenes")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--memory-budget", memory_budget,
                 "device memory for the scenes on each device: bytes or 512M, 8G, ...")
      ->capture_default_str();
  app.add_option("--max-message-mb", options.max_message_mb, "largest gRPC message in MiB")
      ->check(CLI::Range(1, 2047))
      ->capture_default_str();
  app.add_option("--transport-memory-mb", options.transport_memory_mb,
                 "MiB gRPC's transport may hold for all connections together (read buffers, "
                 "messages being received); past it, buffers idle connections keep are released; "
                 "at least twice --max-message-mb (default: 1024, or that where it is more)")
      ->check(CLI::Range(2, 1 << 20));
  app.add_option("--log-level", options.log_level, "debug, info, warning or error")
      ->capture_default_str();
  app.add_option("--shutdown-grace", options.shutdown_grace_s,
                 "seconds running calls may take to finish after SIGTERM/SIGINT")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--max-connection-age", options.max_connection_age_s,
                 "seconds after which a client connection is asked to reconnect (GOAWAY), so "
                 "that clients of a fleet find new replicas; 0: never")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--max-connection-age-grace", options.max_connection_age_grace_s,
                 "seconds the calls of such a connection may still run before it is closed")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--metrics-listen", options.metrics_listen,
                 "host:port to serve Prometheus metrics on (/metrics); port 0 picks a free port; "
                 "off by default");
  app.add_option("--metrics-port-file", options.metrics_port_file,
                 "write the bound port of --metrics-listen to this file");
  app.add_option("--data-dir", options.data_dir,
                 "keep scenes in this directory (created if missing) and restore them at start; "
                 "without it scenes live only as long as the process");
  CLI::Option* tls_cert =
      app.add_option("--tls-cert", options.tls_cert,
                     "PEM certificate chain to serve TLS with on --listen (with --tls-key)")
          ->type_name("FILE");
  CLI::Option* tls_key = app.add_option("--tls-key", options.tls_key,
                                        "PEM private key of --tls-cert (not passphrase-protected)")
                             ->type_name("FILE");
  tls_cert->needs(tls_key);
  tls_key->needs(tls_cert);
  app.add_option("--tls-client-ca", options.tls_client_ca,
                 "PEM CA certificates: clients must present a certificate signed by one of them "
                 "(mutual TLS; needs --tls-cert)")
      ->type_name("FILE")
      ->needs(tls_cert);
  app.add_option("--tokens", options.tokens_file,
                 "token file, one 'token,tenant' line per client token (# comments); callers "
                 "then need 'authorization: Bearer <token>', except for health checks. Without "
                 "it every caller is the single default tenant")
      ->type_name("FILE");
  app.add_flag("--insecure", options.insecure,
               "allow plaintext (no --tls-cert) on a --listen address that is not loopback "
               "(127.0.0.0/8, ::1, localhost)");
  app.add_option("--health-listen", options.health_listen,
                 "host:port of an extra plaintext port that serves only gRPC health checks, for "
                 "probes while --listen needs TLS or tokens; port 0 picks a free port; off by "
                 "default");
  app.add_option("--health-port-file", options.health_port_file,
                 "write the bound port of --health-listen to this file");
  app.add_option("--http-listen", options.http_listen,
                 "host:port of the browser viewer (plaintext HTTP and WebSocket; docs/viewer.md); "
                 "loopback unless --insecure; port 0 picks a free port; off by default");
  app.add_option("--http-port-file", options.http_port_file,
                 "write the bound port of --http-listen to this file");
  app.add_option("--tenant-max-scenes", options.max_tenant_scenes,
                 "most scenes one tenant may hold, uploads included; 0: up to --max-scenes")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option(
         "--tenant-memory-share", options.tenant_memory_share,
         "the share of the memory budget of all devices together one tenant's scenes may hold, "
         "in (0, 1]")
      ->check(CLI::Range(0.0, 1.0) & CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--tenant-max-streams", options.max_tenant_streams,
                 "most frame streams (StreamFrames, PlayAnimation) one tenant may have open; 0: "
                 "no limit")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--scene-idle-ttl", options.scene_idle_ttl_s,
                 "delete a scene no call has used for this many seconds; 0: keep scenes until "
                 "deleted")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
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
