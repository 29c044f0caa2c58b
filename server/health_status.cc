// Serving status across servers, and the health-only server (see health_status.h).
#include "server/health_status.h"

#include <grpcpp/impl/server_builder_option.h>
#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_builder.h>

#include <chrono>

#include "absl/strings/str_cat.h"

namespace caustica::server {
namespace {

// Drops the builder plugins that every ServerBuilder receives process-wide (server reflection
// among them), so that the health port answers health checks only.
class NoPluginsOption : public grpc::ServerBuilderOption {
 public:
  void UpdateArguments(grpc::ChannelArguments*) override {}
  void UpdatePlugins(std::vector<std::unique_ptr<grpc::ServerBuilderPlugin>>* plugins) override {
    plugins->clear();
  }
};

}  // namespace

void HealthStatus::track(grpc::Server& server) {
  if (grpc::HealthCheckServiceInterface* service = server.GetHealthCheckService()) {
    services_.push_back(service);
  }
}

void HealthStatus::set_serving(bool serving) {
  for (grpc::HealthCheckServiceInterface* service : services_) service->SetServingStatus(serving);
}

void HealthStatus::shutdown() {
  for (grpc::HealthCheckServiceInterface* service : services_) service->Shutdown();
}

absl::StatusOr<std::unique_ptr<HealthServer>> HealthServer::start(const std::string& listen) {
  std::unique_ptr<HealthServer> health(new HealthServer());
  grpc::EnableDefaultHealthCheckService(true);
  grpc::ServerBuilder builder;
  builder.SetOption(std::make_unique<NoPluginsOption>());
  builder.AddListeningPort(listen, grpc::InsecureServerCredentials(), &health->port_);
  builder.RegisterCallbackGenericService(&health->unimplemented_);
  health->server_ = builder.BuildAndStart();
  if (!health->server_ || health->port_ == 0) {
    return absl::UnavailableError(absl::StrCat("--health-listen: cannot listen on ", listen));
  }
  return health;
}

void HealthServer::shutdown() {
  server_->Shutdown(std::chrono::system_clock::now());
  server_->Wait();
}

}  // namespace caustica::server
