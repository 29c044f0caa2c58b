// The caustica binary's flags that are checked while parsing, before any server is involved.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <string>

#include "renderer/accel/structure_kind.h"
#include "tests/client/client_run.h"

namespace {

using ::caustica::testing::CommandRun;
using ::caustica::testing::run_client;
using ::caustica::testing::run_command;
using ::testing::HasSubstr;

TEST(ClientOptions, UnknownStructureIsRefusedListingTheNames) {
  for (const char* args :
       {"scene upload scene.json --structure kd-tree", "render s-1 -o out.png --structure kd-tree",
        "stream s-1 -o out --structure kd-tree"}) {
    const CommandRun run = run_client(args);
    EXPECT_NE(run.exit_code, 0) << args;
    EXPECT_THAT(run.output, HasSubstr("--structure"));
    EXPECT_THAT(run.output, HasSubstr("unknown structure 'kd-tree' (expected " +
                                      caustica::structure_kind_list() + ")"))
        << args;
  }
}

TEST(ClientOptions, UnknownIntegratorIsRefusedNamingBoth) {
  for (const char* args : {"render s-1 -o out.png --integrator bdpt",
                           "animate s-1 --script s.json -o out "
                           "--integrator bdpt"}) {
    const CommandRun run = run_client(args);
    EXPECT_NE(run.exit_code, 0) << args;
    EXPECT_THAT(run.output, HasSubstr("unknown integrator 'bdpt' (expected photon or path)"))
        << args;
  }
  const CommandRun help = run_client("render --help");
  EXPECT_THAT(help.output, HasSubstr("--integrator"));
}

TEST(ClientOptions, UnknownEstimatorIsRefusedNamingEvery) {
  const CommandRun run = run_client("render s-1 -o out.png --estimator ppm");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_THAT(run.output, HasSubstr("unknown estimator 'ppm' (expected knn, sppm or vkde)"));
  EXPECT_THAT(run_client("stream --help").output, HasSubstr("--estimator"));
}

TEST(ClientOptions, HelpListsTheStructures) {
  for (const char* args : {"scene upload --help", "render --help"}) {
    const CommandRun run = run_client(args);
    EXPECT_EQ(run.exit_code, 0) << args;
    EXPECT_THAT(run.output, HasSubstr("--structure"));
    EXPECT_THAT(run.output, HasSubstr(caustica::structure_kind_list())) << args;
  }
}

}  // namespace

namespace {

TEST(ClientOptions, HelpListsTheTokenAndTlsFlags) {
  const CommandRun run = run_client("--help");
  EXPECT_EQ(run.exit_code, 0);
  for (const char* flag : {"--token", "CAUSTICA_TOKEN", "--tls-ca", "--tls-cert", "--tls-key"}) {
    EXPECT_THAT(run.output, HasSubstr(flag));
  }
}

TEST(ClientOptions, TlsFilesMustExistAndComeInPairs) {
  const CommandRun missing = run_client("--tls-ca /nonexistent/ca.pem scene list");
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_THAT(missing.output, HasSubstr("--tls-ca"));
  EXPECT_THAT(missing.output, HasSubstr("/nonexistent/ca.pem"));
  // Any existing file passes the parser's check; the pairing is refused before connecting.
  const CommandRun cert_alone = run_client("--tls-cert /dev/null scene list");
  EXPECT_NE(cert_alone.exit_code, 0);
  EXPECT_THAT(cert_alone.output, HasSubstr("--tls-key"));
  const CommandRun key_alone = run_client("scene list --tls-key /dev/null");
  EXPECT_NE(key_alone.exit_code, 0);
  EXPECT_THAT(key_alone.output, HasSubstr("--tls-cert"));
}

// gRPC aborts the client on a metadata value outside visible ASCII, such as a token read from a
// file with its line ending; the client refuses it before connecting, naming the byte.
TEST(ClientOptions, TokensOutsideVisibleAsciiAreRefusedBeforeAnyCall) {
  const CommandRun from_environment =
      run_command(std::string("CAUSTICA_TOKEN=\"$(printf 'abc\\r')\" '") + CAUSTICA_CLIENT_BIN +
                  "' --server 127.0.0.1:1 scene list");
  EXPECT_EQ(from_environment.exit_code, 1) << from_environment.output;
  EXPECT_THAT(from_environment.output,
              HasSubstr("--token ($CAUSTICA_TOKEN): byte 0x0d at offset 3 is not visible ASCII"));
  const CommandRun from_flag = run_client("--server 127.0.0.1:1 --token 'caf\xc3\xa9' scene list");
  EXPECT_EQ(from_flag.exit_code, 1) << from_flag.output;
  EXPECT_THAT(from_flag.output, HasSubstr("byte 0xc3 at offset 3 is not visible ASCII"));
}

TEST(ClientOptions, VersionNamesTheReleaseAndTheApi) {
  const CommandRun run = run_client("--version");
  EXPECT_EQ(run.exit_code, 0);
  EXPECT_THAT(run.output, ::testing::MatchesRegex("caustica [0-9]+\\.[0-9]+\\.[0-9]+ \\(API "
                                                  "v1-[0-9a-f]{8}\\)\n"));
}

}  // namespace
