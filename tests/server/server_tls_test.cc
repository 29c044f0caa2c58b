// TLS, mutual TLS, bearer tokens and the plaintext health port, end to end: the real
// caustica-server with certificates made by the openssl tool for each test, called through gRPC
// and through the caustica CLI.
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <regex>
#include <string>
#include <thread>

#include "client/health_check.h"
#include "client/subprocess.h"
#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

using ::testing::HasSubstr;

constexpr char kToken[] = "tls-test-token-0123456789";

// A call's status; `token` (when not empty) goes in the authorization header. The deadline is
// short because a refused handshake only retries until it.
grpc::Status get_version(const std::shared_ptr<grpc::Channel>& channel,
                         const std::string& token = "") {
  grpc::ClientContext context;
  set_deadline(context, 5);
  if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
  v1::VersionInfo info;
  return v1::RenderService::NewStub(channel)->GetVersion(&context, {}, &info);
}

grpc::Status list_scenes(const std::shared_ptr<grpc::Channel>& channel,
                         const std::string& token = "") {
  grpc::ClientContext context;
  set_deadline(context, 5);
  if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
  v1::ListScenesResponse response;
  return v1::RenderService::NewStub(channel)->ListScenes(&context, {}, &response);
}

std::shared_ptr<grpc::Channel> channel_to(const std::string& address,
                                          std::shared_ptr<grpc::ChannelCredentials> credentials) {
  return grpc::CreateChannel(address, credentials);
}

class TlsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = make_temp_dir("caustica-tls-test");
    std::optional<TestCertificates> certs = make_test_certificates(dir_);
    ASSERT_TRUE(certs.has_value());
    certs_ = *certs;
    tokens_ = dir_ / "tokens.csv";
    std::ofstream(tokens_) << "# test clients\n" << kToken << ",alice\n";
  }
  void TearDown() override {
    if (!HasFailure()) std::filesystem::remove_all(dir_);
  }

  std::vector<std::string> tls_args() const {
    return {"--tls-cert", certs_.server_cert.string(), "--tls-key", certs_.server_key.string()};
  }
  // TLS trusting the test CA, with the client certificate when `client_certificate`.
  std::shared_ptr<grpc::ChannelCredentials> tls(bool client_certificate = false) const {
    grpc::SslCredentialsOptions options;
    options.pem_root_certs = read_text_file(certs_.ca);
    if (client_certificate) {
      options.pem_cert_chain = read_text_file(certs_.client_cert);
      options.pem_private_key = read_text_file(certs_.client_key);
    }
    return grpc::SslCredentials(options);
  }

  std::filesystem::path dir_;
  TestCertificates certs_;
  std::filesystem::path tokens_;
};

TEST_F(TlsTest, ATlsServerAnswersClientsThatTrustItsCa) {
  std::unique_ptr<ServerProcess> server = ServerProcess::start(tls_args(), tls());
  ASSERT_NE(server, nullptr);
  EXPECT_TRUE(get_version(server->channel()).ok());
  EXPECT_TRUE(list_scenes(server->channel()).ok());
  EXPECT_TRUE(health_serving(server->channel()));
  EXPECT_THAT(server->log(), HasSubstr("caustica-server: TLS;"));
}

TEST_F(TlsTest, PlaintextAndUntrustingClientsCannotTalkToATlsServer) {
  std::unique_ptr<ServerProcess> server = ServerProcess::start(tls_args(), tls());
  ASSERT_NE(server, nullptr);
  const grpc::Status plaintext =
      get_version(channel_to(server->address(), grpc::InsecureChannelCredentials()));
  EXPECT_FALSE(plaintext.ok());
  EXPECT_EQ(plaintext.error_code(), grpc::StatusCode::UNAVAILABLE) << plaintext.error_message();
  // The default roots do not include the test CA.
  const grpc::Status untrusting = get_version(
      channel_to(server->address(), grpc::SslCredentials(grpc::SslCredentialsOptions())));
  EXPECT_EQ(untrusting.error_code(), grpc::StatusCode::UNAVAILABLE) << untrusting.error_message();
}

TEST_F(TlsTest, MutualTlsRequiresAClientCertificateSignedByTheCa) {
  std::vector<std::string> args = tls_args();
  args.insert(args.end(), {"--tls-client-ca", certs_.ca.string()});
  std::unique_ptr<ServerProcess> server = ServerProcess::start(args, tls(true));
  ASSERT_NE(server, nullptr);
  EXPECT_TRUE(get_version(server->channel()).ok());
  EXPECT_TRUE(list_scenes(server->channel()).ok());
  const grpc::Status without = get_version(channel_to(server->address(), tls(false)));
  EXPECT_EQ(without.error_code(), grpc::StatusCode::UNAVAILABLE) << without.error_message();
  // A client certificate from another CA.
  grpc::SslCredentialsOptions other;
  other.pem_root_certs = read_text_file(certs_.ca);
  const std::filesystem::path stranger_dir = dir_ / "stranger";
  std::filesystem::create_directory(stranger_dir);
  std::optional<TestCertificates> stranger = make_test_certificates(stranger_dir);
  ASSERT_TRUE(stranger.has_value());
  other.pem_cert_chain = read_text_file(stranger->client_cert);
  other.pem_private_key = read_text_file(stranger->client_key);
  const grpc::Status foreign =
      get_version(channel_to(server->address(), grpc::SslCredentials(other)));
  EXPECT_FALSE(foreign.ok());
  EXPECT_THAT(server->log(), HasSubstr("TLS with client certificates"));
}

TEST_F(TlsTest, TokensDecideWhoIsServedExceptForHealthChecks) {
  std::vector<std::string> args = tls_args();
  args.insert(args.end(), {"--tokens", tokens_.string()});
  std::unique_ptr<ServerProcess> server = ServerProcess::start(args, tls());
  ASSERT_NE(server, nullptr);
  for (const auto& call : {get_version, list_scenes}) {
    const grpc::Status missing = call(server->channel(), "");
    EXPECT_EQ(missing.error_code(), grpc::StatusCode::UNAUTHENTICATED);
    EXPECT_THAT(missing.error_message(), HasSubstr("missing 'authorization' header"));
    const grpc::Status wrong = call(server->channel(), "wrong-token-0123456789");
    EXPECT_EQ(wrong.error_code(), grpc::StatusCode::UNAUTHENTICATED);
    EXPECT_THAT(wrong.error_message(), HasSubstr("unknown token"));
    const grpc::Status right = call(server->channel(), kToken);
    EXPECT_TRUE(right.ok()) << right.error_message();
  }
  grpc::ClientContext basic;
  set_deadline(basic, 5);
  basic.AddMetadata("authorization", "Basic YWxpY2U6c2VjcmV0");
  v1::VersionInfo info;
  const grpc::Status not_bearer = server->stub()->GetVersion(&basic, {}, &info);
  EXPECT_EQ(not_bearer.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_THAT(not_bearer.error_message(), HasSubstr("not a Bearer token"));
  EXPECT_TRUE(health_serving(server->channel()));  // no token needed
  EXPECT_THAT(server->log(), HasSubstr("refused /caustica.v1.RenderService/GetVersion"));
}

TEST_F(TlsTest, TheHealthPortAnswersPlaintextWhileTheMainPortNeedsTls) {
  std::vector<std::string> args = tls_args();
  args.insert(args.end(), {"--tokens", tokens_.string(), "--health-listen", "127.0.0.1:0"});
  std::unique_ptr<ServerProcess> server = ServerProcess::start(args, tls());
  ASSERT_NE(server, nullptr);
  std::smatch match;
  const std::string log = server->log();
  ASSERT_TRUE(std::regex_search(log, match, std::regex("health on port ([0-9]+)"))) << log;
  const std::string health_address = "127.0.0.1:" + match[1].str();
  const auto health = channel_to(health_address, grpc::InsecureChannelCredentials());
  EXPECT_TRUE(health_serving(health));
  EXPECT_FALSE(health_serving(channel_to(server->address(), grpc::InsecureChannelCredentials())));
  // The health port serves nothing else.
  EXPECT_EQ(get_version(health, kToken).error_code(), grpc::StatusCode::UNIMPLEMENTED);
  // The health server stops with the rest (health_status_test.cc checks NOT_SERVING on both).
  EXPECT_EQ(server->terminate(), 0) << server->log();
}

TEST_F(TlsTest, TheCliConnectsWithTlsAndAToken) {
  std::vector<std::string> args = tls_args();
  args.insert(args.end(), {"--tokens", tokens_.string()});
  std::unique_ptr<ServerProcess> server = ServerProcess::start(args, tls());
  ASSERT_NE(server, nullptr);
  const std::string client =
      std::string("'") + CAUSTICA_CLIENT_BIN + "' --server " + server->address() + " --timeout 30 ";
  const std::string with_tls = client + "--tls-ca '" + certs_.ca.string() + "' ";
  const std::string scene =
      (std::filesystem::path(CAUSTICA_SCENES_DIR) / "cornell-box" / "scene.json").string();
  const CommandRun upload = run_command("env -u CAUSTICA_TOKEN " + with_tls + "--token " + kToken +
                                        " scene upload '" + scene + "' --name tls-box");
  ASSERT_EQ(upload.exit_code, 0) << upload.output;

  const CommandRun listed =
      run_command(std::string("env CAUSTICA_TOKEN=") + kToken + " " + with_tls + "scene list");
  EXPECT_EQ(listed.exit_code, 0) << listed.output;
  EXPECT_THAT(listed.output, HasSubstr("tls-box"));

  const CommandRun no_token = run_command("env -u CAUSTICA_TOKEN " + with_tls + "scene list");
  EXPECT_EQ(no_token.exit_code, 1) << no_token.output;
  EXPECT_THAT(no_token.output, HasSubstr("UNAUTHENTICATED"));
  EXPECT_THAT(no_token.output, HasSubstr("missing 'authorization' header"));

  const CommandRun no_tls =
      run_command(std::string("env CAUSTICA_TOKEN=") + kToken + " " + client + "scene list");
  EXPECT_NE(no_tls.exit_code, 0) << no_tls.output;
}

// Runs caustica-server with `args` until it exits (at most 30 s); its exit code and log.
CommandRun run_server_to_exit(const std::vector<std::string>& args,
                              const std::filesystem::path& log) {
  std::vector<std::string> argv = {CAUSTICA_SERVER_BIN};
  argv.insert(argv.end(), args.begin(), args.end());
  absl::StatusOr<pid_t> pid = client::spawn_process(argv, log);
  if (!pid.ok()) return {-1, std::string(pid.status().message())};
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < give_up) {
    if (std::optional<int> status = client::poll_exit(*pid)) return {*status, read_text_file(log)};
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  client::terminate_process(*pid, std::chrono::seconds(5));
  return {-1, "still running after 30 s:\n" + read_text_file(log)};
}

TEST_F(TlsTest, TheServerRefusesToStartInsecurelyOrWithABadTokenFile) {
  const CommandRun everywhere =
      run_server_to_exit({"--listen", "0.0.0.0:0"}, dir_ / "everywhere.log");
  EXPECT_EQ(everywhere.exit_code, 1) << everywhere.output;
  EXPECT_THAT(everywhere.output, HasSubstr("--insecure"));

  std::ofstream(dir_ / "bad-tokens.csv") << kToken << ",alice\n" << kToken << ",bob\n";
  const CommandRun bad_tokens = run_server_to_exit(
      {"--listen", "127.0.0.1:0", "--tokens", (dir_ / "bad-tokens.csv").string()},
      dir_ / "bad-tokens.log");
  EXPECT_EQ(bad_tokens.exit_code, 1) << bad_tokens.output;
  EXPECT_THAT(bad_tokens.output, HasSubstr("--tokens: " + (dir_ / "bad-tokens.csv").string() +
                                           ":2: duplicate token (first on line 1)"));

  const CommandRun mismatched =
      run_server_to_exit({"--listen", "127.0.0.1:0", "--tls-cert", certs_.server_cert.string(),
                          "--tls-key", certs_.client_key.string()},
                         dir_ / "mismatched.log");
  EXPECT_EQ(mismatched.exit_code, 1) << mismatched.output;
  EXPECT_THAT(mismatched.output, HasSubstr("--tls-key: " + certs_.client_key.string()));
}

TEST_F(TlsTest, InsecureAllowsPlaintextOnAllInterfaces) {
  std::unique_ptr<ServerProcess> server =
      ServerProcess::start({"--listen", "0.0.0.0:0", "--insecure"});
  ASSERT_NE(server, nullptr);
  EXPECT_TRUE(get_version(server->channel()).ok());
  EXPECT_THAT(server->log(), HasSubstr("plaintext on 0.0.0.0:0 (--insecure)"));
}

}  // namespace
}  // namespace caustica::testing
