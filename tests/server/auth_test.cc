// Token files, the Authenticator's verdicts, the interceptor's verdicts as handlers read them (an
// in-process server), and the listening port's credentials: TLS files and the loopback rule.
#include "server/auth.h"

#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <string>

#include "caustica/v1/render_service.grpc.pb.h"
#include "tests/server/server_harness.h"

namespace caustica::server {
namespace {

using ::testing::HasSubstr;

constexpr char kAliceToken[] = "alice-0123456789abcdef";
constexpr char kAliceSecondToken[] = "alice-rotated-0123456789";
constexpr char kBobToken[] = "bob-0123456789abcdef";

TokenTable alice_and_bob() {
  absl::StatusOr<TokenTable> table =
      TokenTable::parse(absl::StrCat("# token,tenant\n", kAliceToken, ",alice\n", kAliceSecondToken,
                                     ",alice\n", kBobToken, ",bob\n"),
                        "tokens.csv");
  EXPECT_TRUE(table.ok()) << table.status();
  return table.ok() ? *std::move(table) : TokenTable();
}

// The error message of parsing `text` as tokens.csv ("" when it parses).
std::string parse_error(const std::string& text) {
  absl::StatusOr<TokenTable> table = TokenTable::parse(text, "tokens.csv");
  if (table.ok()) return "";
  EXPECT_EQ(table.status().code(), absl::StatusCode::kInvalidArgument);
  return std::string(table.status().message());
}

TEST(TokenTable, ParsesCommentsBlankLinesSpacesAndCrLf) {
  absl::StatusOr<TokenTable> table = TokenTable::parse(
      "# clients of the render farm\n"
      "\n"
      "  0123456789abcdef0123 , team-a \r\n"
      "   # an indented comment\n"
      "fedcba9876543210fedc,team-b.v2\n"
      "ABCDEFGHIJKLMNOPQRST,team_a",  // no newline at the end
      "tokens.csv");
  ASSERT_TRUE(table.ok()) << table.status();
  EXPECT_EQ(table->size(), 3u);
  EXPECT_EQ(table->tenant_of("0123456789abcdef0123"), "team-a");
  EXPECT_EQ(table->tenant_of("fedcba9876543210fedc"), "team-b.v2");
  EXPECT_EQ(table->tenant_of("ABCDEFGHIJKLMNOPQRST"), "team_a");
  EXPECT_EQ(table->tenant_of("0123456789abcdef012"), std::nullopt);
  EXPECT_EQ(table->tenant_of(""), std::nullopt);
}

TEST(TokenTable, ErrorsNameTheFileAndLine) {
  const std::string good = "0123456789abcdef0123,alice\n";
  EXPECT_THAT(parse_error("# header\n" + good + "no-comma-in-this-line\n"),
              HasSubstr("tokens.csv:3: missing field"));
  EXPECT_THAT(parse_error(good + " ,alice\n"), HasSubstr("tokens.csv:2: empty token"));
  EXPECT_THAT(parse_error(good + "short-token,alice\n"),
              HasSubstr("tokens.csv:2: token too short: 11 characters, at least 16"));
  EXPECT_THAT(parse_error(good + "\n" + "0123456789abcdef0123 , bob\n"),
              HasSubstr("tokens.csv:3: duplicate token (first on line 1)"));
  EXPECT_THAT(parse_error(good + "0123456789abcdef9999,team a\n"),
              HasSubstr("tokens.csv:2: tenant 'team a' is not a valid name"));
  EXPECT_THAT(parse_error(good + "0123456789abcdef9999,\n"),
              HasSubstr("tokens.csv:2: tenant '' is not a valid name"));
  EXPECT_THAT(parse_error(good + "0123456789abcdef9999,..\n"),
              HasSubstr("tokens.csv:2: tenant '..' is not a valid name"));
  EXPECT_THAT(parse_error(good + "0123456789abcdef9999," + std::string(65, 't') + "\n"),
              HasSubstr("tokens.csv:2: tenant"));
  EXPECT_EQ(parse_error(good + "0123456789abcdef9999," + std::string(64, 't') + "\n"), "");
  EXPECT_THAT(parse_error(good + "0123456789abcdef9999,alice,admins\n"),
              HasSubstr("tokens.csv:2: too many fields"));
  EXPECT_THAT(parse_error(good + "0123456789abcdef\t9999,alice\n"),
              HasSubstr("tokens.csv:2: token: byte 0x09 at offset 16 is not visible ASCII"));
  EXPECT_THAT(parse_error("# nothing but comments\n\n"), HasSubstr("tokens.csv: no tokens"));
}

TEST(TokenTable, LoadNamesAFileItCannotRead) {
  absl::StatusOr<TokenTable> missing = TokenTable::load("/nonexistent/tokens.csv");
  ASSERT_FALSE(missing.ok());
  EXPECT_THAT(std::string(missing.status().message()),
              HasSubstr("cannot read /nonexistent/tokens.csv"));

  const std::filesystem::path dir = testing::make_temp_dir("caustica-auth-test");
  std::ofstream(dir / "tokens.csv") << kAliceToken << ",alice\nshort,bob\n";
  absl::StatusOr<TokenTable> bad = TokenTable::load(dir / "tokens.csv");
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(std::string(bad.status().message()),
              HasSubstr((dir / "tokens.csv").string() + ":2: token too short"));
  std::filesystem::remove_all(dir);
}

TEST(TenantName, AllowsOnlyTheSafeCharacters) {
  for (const char* good : {"a", "team-a", "Team_B.2", "...x", "0"}) {
    EXPECT_TRUE(is_valid_tenant_name(good)) << good;
  }
  for (const char* bad : {"", ".", "..", "a/b", "a b", "ä", "a,b", "a:b"}) {
    EXPECT_FALSE(is_valid_tenant_name(bad)) << bad;
  }
}

void expect_unauthenticated(const absl::StatusOr<std::string>& verdict, const std::string& what) {
  ASSERT_FALSE(verdict.ok()) << "tenant " << *verdict;
  EXPECT_EQ(verdict.status().code(), absl::StatusCode::kUnauthenticated);
  EXPECT_THAT(std::string(verdict.status().message()), HasSubstr(what));
}

TEST(Authenticator, VerdictsOnTheAuthorizationHeader) {
  const Authenticator authenticator(alice_and_bob());
  EXPECT_TRUE(authenticator.requires_tokens());
  expect_unauthenticated(authenticator.tenant_of(std::nullopt), "missing 'authorization' header");
  expect_unauthenticated(authenticator.tenant_of("Basic YWxpY2U6c2VjcmV0"), "not a Bearer token");
  expect_unauthenticated(authenticator.tenant_of(kAliceToken), "not a Bearer token");
  expect_unauthenticated(authenticator.tenant_of("Bearer"), "no token after 'Bearer'");
  expect_unauthenticated(authenticator.tenant_of("Bearer wrong-0123456789abcdef"), "unknown token");
  // A prefix or extension of a good token is just another unknown token.
  expect_unauthenticated(authenticator.tenant_of(absl::StrCat("Bearer ", kAliceToken, "x")),
                         "unknown token");
  EXPECT_EQ(authenticator.tenant_of(absl::StrCat("Bearer ", kAliceToken)).value(), "alice");
  EXPECT_EQ(authenticator.tenant_of(absl::StrCat("Bearer ", kAliceSecondToken)).value(), "alice");
  EXPECT_EQ(authenticator.tenant_of(absl::StrCat("bearer  ", kBobToken)).value(), "bob");
}

TEST(Authenticator, ReadsTheMetadataAndRefusesTwoHeaders) {
  const Authenticator authenticator(alice_and_bob());
  const std::string alice = absl::StrCat("Bearer ", kAliceToken);
  const std::string bob = absl::StrCat("Bearer ", kBobToken);
  std::multimap<grpc::string_ref, grpc::string_ref> metadata = {{"user-agent", "test"}};
  expect_unauthenticated(authenticator.tenant_of(metadata), "missing 'authorization' header");
  metadata.emplace("authorization", alice);
  EXPECT_EQ(authenticator.tenant_of(metadata).value(), "alice");
  metadata.emplace("authorization", bob);
  expect_unauthenticated(authenticator.tenant_of(metadata), "more than one 'authorization'");
}

TEST(Authenticator, WithoutTokensEveryCallerIsTheDefaultTenant) {
  const Authenticator development;
  EXPECT_FALSE(development.requires_tokens());
  EXPECT_EQ(development.tenant_of(std::nullopt).value(), kDefaultTenant);
  EXPECT_EQ(development.tenant_of("Bearer anything").value(), kDefaultTenant);
  EXPECT_EQ(development.tenant_of("Basic x").value(), kDefaultTenant);
}

TEST(Authenticator, OnlyHealthChecksAreExempt) {
  EXPECT_TRUE(is_exempt_from_tokens("/grpc.health.v1.Health/Check"));
  EXPECT_TRUE(is_exempt_from_tokens("/grpc.health.v1.Health/Watch"));
  EXPECT_FALSE(is_exempt_from_tokens("/caustica.v1.RenderService/ListScenes"));
  EXPECT_FALSE(
      is_exempt_from_tokens("/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo"));
}

// GetVersion answers with what caller_tenant says, as handlers are to use it; ListScenes ignores
// the verdict and answers a scene, as a handler without the check would.
class VerdictEchoService : public v1::RenderService::Service {
 public:
  grpc::Status GetVersion(grpc::ServerContext* context, const v1::GetVersionRequest*,
                          v1::VersionInfo* info) override {
    absl::StatusOr<std::string> tenant = caller_tenant(*context);
    if (!tenant.ok()) {
      return grpc::Status(static_cast<grpc::StatusCode>(tenant.status().code()),
                          std::string(tenant.status().message()));
    }
    info->set_server_version("tenant:" + *tenant);
    return grpc::Status::OK;
  }
  grpc::Status ListScenes(grpc::ServerContext*, const v1::ListScenesRequest*,
                          v1::ListScenesResponse* response) override {
    response->add_scenes()->set_name("secret");
    return grpc::Status::OK;
  }
};

class InterceptorTest : public ::testing::Test {
 protected:
  void start(std::shared_ptr<const Authenticator> authenticator) {
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.RegisterService(&service_);
    std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> factories;
    factories.push_back(std::make_unique<AuthInterceptorFactory>(std::move(authenticator)));
    builder.experimental().SetInterceptorCreators(std::move(factories));
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    stub_ = v1::RenderService::NewStub(grpc::CreateChannel("127.0.0.1:" + std::to_string(port),
                                                           grpc::InsecureChannelCredentials()));
  }
  void TearDown() override {
    if (server_) server_->Shutdown();
  }

  // GetVersion with `authorization` (none when empty): its status, and the tenant on success.
  grpc::Status version(const std::string& authorization, std::string* tenant) {
    grpc::ClientContext context;
    testing::set_deadline(context, 10);
    if (!authorization.empty()) context.AddMetadata("authorization", authorization);
    v1::VersionInfo info;
    const grpc::Status status = stub_->GetVersion(&context, {}, &info);
    *tenant = info.server_version();
    return status;
  }

  VerdictEchoService service_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<v1::RenderService::Stub> stub_;
};

TEST_F(InterceptorTest, HandlersReadTheVerdictOfTheirCall) {
  start(std::make_shared<const Authenticator>(alice_and_bob()));
  std::string tenant;
  grpc::Status status = version("", &tenant);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_THAT(status.error_message(), HasSubstr("missing 'authorization' header"));
  status = version("Basic x", &tenant);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_THAT(status.error_message(), HasSubstr("not a Bearer token"));
  status = version("Bearer wrong-0123456789abcdef", &tenant);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_THAT(status.error_message(), HasSubstr("unknown token"));
  // Interleaved tenants: each call sees its own verdict.
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(version(absl::StrCat("Bearer ", kAliceToken), &tenant).ok());
    EXPECT_EQ(tenant, "tenant:alice");
    ASSERT_TRUE(version(absl::StrCat("Bearer ", kBobToken), &tenant).ok());
    EXPECT_EQ(tenant, "tenant:bob");
  }
}

TEST_F(InterceptorTest, ARefusedCallEndsUnauthenticatedEvenWhenTheHandlerIgnoresTheVerdict) {
  start(std::make_shared<const Authenticator>(alice_and_bob()));
  grpc::ClientContext context;
  testing::set_deadline(context, 10);
  context.AddMetadata("authorization", "Bearer wrong-0123456789abcdef");
  v1::ListScenesResponse response;
  const grpc::Status status = stub_->ListScenes(&context, {}, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_THAT(status.error_message(), HasSubstr("unknown token"));
  EXPECT_EQ(response.scenes_size(), 0);

  grpc::ClientContext allowed;
  testing::set_deadline(allowed, 10);
  allowed.AddMetadata("authorization", absl::StrCat("Bearer ", kBobToken));
  ASSERT_TRUE(stub_->ListScenes(&allowed, {}, &response).ok());
  ASSERT_EQ(response.scenes_size(), 1);
  EXPECT_EQ(response.scenes(0).name(), "secret");
}

TEST_F(InterceptorTest, WithoutTokensHandlersSeeTheDefaultTenant) {
  start(std::make_shared<const Authenticator>());
  std::string tenant;
  ASSERT_TRUE(version("", &tenant).ok());
  EXPECT_EQ(tenant, "tenant:");
  ASSERT_TRUE(version("Bearer whatever", &tenant).ok());
  EXPECT_EQ(tenant, "tenant:");
}

TEST(CallerTenant, IsAnErrorWithoutTheInterceptor) {
  const grpc::ServerContext context;
  const absl::StatusOr<std::string> tenant = caller_tenant(context);
  ASSERT_FALSE(tenant.ok());
  EXPECT_EQ(tenant.status().code(), absl::StatusCode::kInternal);
}

TEST(LoopbackRule, WhichListenAddressesAreLoopback) {
  for (const char* loopback :
       {"127.0.0.1:0", "127.1.2.3:50051", "localhost:50051", "LOCALHOST:1", "[::1]:50051",
        "[::ffff:127.0.0.1]:1", "unix:/tmp/caustica.sock", "unix-abstract:caustica"}) {
    EXPECT_TRUE(is_loopback_listen_address(loopback)) << loopback;
  }
  for (const char* network : {"0.0.0.0:0", "[::]:50051", ":50051", "10.0.0.1:50051", "128.0.0.1:1",
                              "example.com:50051", "::1:50051", "[::1:1"}) {
    EXPECT_FALSE(is_loopback_listen_address(network)) << network;
  }
}

TEST(LoopbackRule, PlaintextNeedsLoopbackOrInsecure) {
  EXPECT_TRUE(listen_credentials("127.0.0.1:0", {}, false).ok());
  absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> refused =
      listen_credentials("0.0.0.0:0", {}, false);
  ASSERT_FALSE(refused.ok());
  EXPECT_THAT(std::string(refused.status().message()), HasSubstr("--insecure"));
  EXPECT_THAT(std::string(refused.status().message()), HasSubstr("0.0.0.0:0"));
  EXPECT_TRUE(listen_credentials("0.0.0.0:0", {}, true).ok());
}

std::string credentials_error(const TlsFiles& files) {
  absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> credentials =
      listen_credentials("0.0.0.0:0", files, false);
  return credentials.ok() ? "" : std::string(credentials.status().message());
}

TEST(TlsFiles, AreReadAndCheckedWithErrorsNamingFlagAndFile) {
  const std::filesystem::path dir = testing::make_temp_dir("caustica-auth-tls");
  const std::optional<testing::TestCertificates> certs = testing::make_test_certificates(dir);
  ASSERT_TRUE(certs.has_value());
  const std::string cert = certs->server_cert.string(), key = certs->server_key.string();
  // TLS needs no --insecure on any address.
  EXPECT_EQ(credentials_error({cert, key, ""}), "");
  EXPECT_EQ(credentials_error({cert, key, certs->ca.string()}), "");

  EXPECT_THAT(credentials_error({"/nonexistent/server.pem", key, ""}),
              HasSubstr("--tls-cert: cannot read /nonexistent/server.pem"));
  EXPECT_THAT(credentials_error({cert, "/nonexistent/server.key", ""}),
              HasSubstr("--tls-key: cannot read /nonexistent/server.key"));
  EXPECT_THAT(credentials_error({cert, key, "/nonexistent/ca.pem"}),
              HasSubstr("--tls-client-ca: cannot read /nonexistent/ca.pem"));
  EXPECT_THAT(credentials_error({cert, certs->client_key.string(), ""}),
              HasSubstr("--tls-key: " + certs->client_key.string() + " is not the key"));
  EXPECT_THAT(credentials_error({key, key, ""}), HasSubstr("--tls-cert: " + key + " holds no"));
  EXPECT_THAT(credentials_error({cert, cert, ""}), HasSubstr("--tls-key: " + cert + " holds no"));
  EXPECT_THAT(credentials_error({cert, key, key}), HasSubstr("--tls-client-ca: " + key));
  EXPECT_THAT(credentials_error({cert, "", ""}), HasSubstr("--tls-cert: needs --tls-key"));
  EXPECT_THAT(credentials_error({"", key, ""}), HasSubstr("--tls-key: needs --tls-cert"));
  EXPECT_THAT(credentials_error({"", "", certs->ca.string()}),
              HasSubstr("--tls-client-ca: needs --tls-cert"));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace caustica::server
