// HealthStatus over the main server and the health-only server: one call sets both, shutdown is
// final, and the health-only server answers nothing but health.
#include "server/health_status.h"

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "client/health_check.h"
#include "tests/server/server_harness.h"

namespace caustica::server {
namespace {

using client::ServingStatus;

ServingStatus status_of(const std::string& address) {
  absl::StatusOr<ServingStatus> status =
      client::check_health(grpc::CreateChannel(address, grpc::InsecureChannelCredentials()),
                           std::chrono::system_clock::now() + std::chrono::seconds(10), false);
  EXPECT_TRUE(status.ok()) << status.status();
  return status.ok() ? *status : ServingStatus::kUnknown;
}

TEST(HealthStatus, SetsBothServersAndShutdownIsFinal) {
  grpc::EnableDefaultHealthCheckService(true);
  grpc::ServerBuilder builder;
  int main_port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &main_port);
  grpc::CallbackGenericService unimplemented;  // the main server's stand-in for real services
  builder.RegisterCallbackGenericService(&unimplemented);
  std::unique_ptr<grpc::Server> main_server = builder.BuildAndStart();
  ASSERT_NE(main_server, nullptr);
  absl::StatusOr<std::unique_ptr<HealthServer>> health_server = HealthServer::start("127.0.0.1:0");
  ASSERT_TRUE(health_server.ok()) << health_server.status();
  const std::string main_address = "127.0.0.1:" + std::to_string(main_port);
  const std::string health_address = "127.0.0.1:" + std::to_string((*health_server)->port());

  HealthStatus health;
  health.track(*main_server);
  health.track((*health_server)->server());
  EXPECT_EQ(status_of(main_address), ServingStatus::kServing);
  EXPECT_EQ(status_of(health_address), ServingStatus::kServing);
  health.set_serving(false);
  EXPECT_EQ(status_of(main_address), ServingStatus::kNotServing);
  EXPECT_EQ(status_of(health_address), ServingStatus::kNotServing);
  health.set_serving(true);
  EXPECT_EQ(status_of(main_address), ServingStatus::kServing);
  EXPECT_EQ(status_of(health_address), ServingStatus::kServing);
  health.shutdown();
  health.set_serving(true);
  EXPECT_EQ(status_of(main_address), ServingStatus::kNotServing);
  EXPECT_EQ(status_of(health_address), ServingStatus::kNotServing);

  (*health_server)->shutdown();
  main_server->Shutdown();
}

TEST(HealthServer, RefusesAnAddressItCannotListenOn) {
  absl::StatusOr<std::unique_ptr<HealthServer>> health = HealthServer::start("256.0.0.1:0");
  ASSERT_FALSE(health.ok());
  EXPECT_EQ(health.status().message(), "--health-listen: cannot listen on 256.0.0.1:0");
}

}  // namespace
}  // namespace caustica::server
