// The health of caustica-server as load balancers and Kubernetes probes see it: the default gRPC
// health service of the main server, and of an optional plaintext server that carries nothing
// else (--health-listen), so that probes work while the main port needs TLS or tokens.
#pragma once

#include <grpcpp/generic/async_generic_service.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/server.h>

#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace caustica::server {

// Sets the serving status of several servers' health services at once. Every server built after
// grpc::EnableDefaultHealthCheckService(true) has its own health service, which starts SERVING.
// track() is for start-up, before other threads use the object; set_serving and shutdown may then
// be called from any thread.
class HealthStatus {
 public:
  // Follows `server`'s health service from now on; a server without one is ignored.
  void track(grpc::Server& server);
  // SERVING or NOT_SERVING for every service on every tracked server.
  void set_serving(bool serving);
  // NOT_SERVING for good: later set_serving calls are ignored (gRPC's health service does so).
  void shutdown();

 private:
  std::vector<grpc::HealthCheckServiceInterface*> services_;
};

// A plaintext server that serves the default health service and nothing else, not even server
// reflection; every other method is UNIMPLEMENTED.
class HealthServer {
 public:
  // Listens on `listen` (host:port; port 0 picks a free one).
  static absl::StatusOr<std::unique_ptr<HealthServer>> start(const std::string& listen);

  grpc::Server& server() { return *server_; }
  int port() const { return port_; }
  // Closes the port at once, cancelling health checks in progress.
  void shutdown();

 private:
  HealthServer() = default;
  // gRPC builds no server without a service of its own (the health service is added only after
  // that check), so this one stands in, and must outlive the server.
  grpc::CallbackGenericService unimplemented_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
};

}  // namespace caustica::server
