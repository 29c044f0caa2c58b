// The server's version against the client's: GetVersion over the wire, and the warnings a
// client gives when the two differ (proto/wire/api_version.h).
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include "client/connection.h"
#include "proto/wire/api_version.h"
#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

using ::testing::HasSubstr;

TEST_F(ServerTest, GetVersionReportsTheReleaseAndTheApiOfTheBuild) {
  grpc::ClientContext context;
  v1::VersionInfo version;
  ASSERT_TRUE(stub_->GetVersion(&context, {}, &version).ok());
  EXPECT_EQ(version.server_version(), wire::release_version());
  EXPECT_EQ(version.api_version(), wire::api_version());
  EXPECT_THAT(version.api_version(), ::testing::MatchesRegex("v1-[0-9a-f]{8}"));
  EXPECT_EQ(wire::version_mismatch(version), "");
}

TEST(Version, MismatchesAreNamedWithBothSides) {
  v1::VersionInfo other_api = wire::own_version();
  other_api.set_api_version("v1-00000000");
  other_api.set_server_version("9.9.9");
  const std::string api = wire::version_mismatch(other_api);
  EXPECT_THAT(
      api, HasSubstr("the server speaks API v1-00000000 and this client " + wire::api_version()));
  EXPECT_THAT(api, HasSubstr("server 9.9.9, client " + std::string(wire::release_version())));

  v1::VersionInfo other_release = wire::own_version();
  other_release.set_server_version("9.9.9");
  EXPECT_THAT(wire::version_mismatch(other_release),
              HasSubstr("the server is release 9.9.9 and this client " +
                        std::string(wire::release_version()) + " (the same API"));

  EXPECT_THAT(wire::version_mismatch(v1::VersionInfo()), HasSubstr("(none reported)"));
}

// A server of another release and API: it answers GetVersion alone.
class OtherVersionService final : public v1::RenderService::Service {
 public:
  explicit OtherVersionService(bool answers) : answers_(answers) {}
  grpc::Status GetVersion(grpc::ServerContext*, const v1::GetVersionRequest*,
                          v1::VersionInfo* response) override {
    if (!answers_) return {grpc::StatusCode::UNIMPLEMENTED, "GetVersion"};
    response->set_server_version("9.9.9");
    response->set_api_version("v1-00000000");
    return grpc::Status::OK;
  }

 private:
  bool answers_;
};

// What the client writes to stderr while connecting to a server with `service`.
std::string warnings_connecting_to(v1::RenderService::Service& service) {
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  std::ostringstream captured;
  std::streambuf* const stderr_buffer = std::cerr.rdbuf(captured.rdbuf());
  client::ConnectOptions options;
  options.server = "127.0.0.1:" + std::to_string(port);
  const auto connection = client::Connection::open(options);
  std::cerr.rdbuf(stderr_buffer);
  EXPECT_TRUE(connection.ok()) << connection.status();
  server->Shutdown();
  return captured.str();
}

TEST(Version, TheClientWarnsWhenTheServerSpeaksAnotherApi) {
  OtherVersionService other(true);
  EXPECT_THAT(warnings_connecting_to(other),
              HasSubstr("caustica: warning: the server speaks API v1-00000000 and this client " +
                        wire::api_version()));
  OtherVersionService older(false);
  EXPECT_THAT(warnings_connecting_to(older),
              HasSubstr("caustica: warning: the server does not report its version"));
}

}  // namespace
}  // namespace caustica::testing
