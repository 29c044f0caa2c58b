// `caustica view` against the real binaries: on a server with a viewer it uploads the scene,
// keeps it and prints the page's URL, which serves the page; a server without a viewer is a clear
// error; without --server it starts its own server with the viewer and stops it on Ctrl-C.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "absl/strings/str_cat.h"
#include "client/subprocess.h"
#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

std::string cli() { return std::string("'") + CAUSTICA_CLIENT_BIN + "'"; }
std::string scene_file() {
  return std::string("'") + CAUSTICA_SCENES_DIR + "/cornell-box/scene.json'";
}

class ViewCommand : public ServerTest {
 protected:
  std::vector<std::string> server_args() const override { return {"--http-listen", "127.0.0.1:0"}; }
};

TEST_F(ViewCommand, UploadsKeepsAndPrintsAPageThatServes) {
  const CommandRun run = run_command(cli() + " --json --server " + server_->address() + " view " +
                                     scene_file() + " --width 32 --height 32 --no-open");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const size_t at = run.output.find("http://127.0.0.1:");
  ASSERT_NE(at, std::string::npos) << run.output;
  const std::string url = run.output.substr(at, run.output.find('"', at) - at);
  const std::vector<v1::SceneInfo> scenes = list_scenes(*stub_);
  ASSERT_EQ(scenes.size(), 1u) << "the scene stays for the viewer";
  grpc::ClientContext context;
  set_deadline(context);
  v1::Stats stats;
  ASSERT_TRUE(stub_->GetStats(&context, v1::GetStatsRequest(), &stats).ok());
  ASSERT_GT(stats.viewer_port(), 0u);
  EXPECT_EQ(url, absl::StrCat("http://127.0.0.1:", stats.viewer_port(),
                              "/?scene=", scenes[0].scene_id()));
  const CommandRun page = run_command("curl -sf '" + url + "'");
  EXPECT_EQ(page.exit_code, 0) << page.output;
  EXPECT_NE(page.output.find("<html"), std::string::npos) << page.output.substr(0, 200);
}

TEST(ViewCommandErrors, AServerWithoutAViewerIsNamed) {
  auto server = ServerProcess::start();
  ASSERT_NE(server, nullptr);
  const CommandRun run = run_command(cli() + " --server " + server->address() + " view " +
                                     scene_file() + " --no-open");
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.output.find("serves no viewer: start it with --http-listen"), std::string::npos)
      << run.output;
  EXPECT_TRUE(list_scenes(*server->stub()).empty()) << "nothing uploaded";
}

TEST(ViewCommandEmbedded, ServesUntilCtrlCThenStopsItsServer) {
  const std::filesystem::path dir = make_temp_dir("caustica-view");
  const std::filesystem::path log = dir / "view.log";
  setenv("CAUSTICA_DATA_DIR", "", 1);
  absl::StatusOr<pid_t> view = client::spawn_process(
      {CAUSTICA_CLIENT_BIN, "view", std::string(CAUSTICA_SCENES_DIR) + "/cornell-box/scene.json",
       "--width", "32", "--height", "32", "--no-open"},
      log);
  ASSERT_TRUE(view.ok()) << view.status();
  std::string url;
  for (int i = 0; i < 600 && url.empty(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const std::string text = read_text_file(log);
    const size_t at = text.find("http://");
    if (at != std::string::npos && text.find("until Ctrl-C") != std::string::npos) {
      url = text.substr(at, text.find('\n', at) - at);
    }
  }
  ASSERT_FALSE(url.empty()) << read_text_file(log);
  const CommandRun page = run_command("curl -sf '" + url + "'");
  EXPECT_EQ(page.exit_code, 0);
  EXPECT_NE(page.output.find("<html"), std::string::npos);
  kill(*view, SIGINT);
  EXPECT_EQ(client::wait_exit(*view), 0) << read_text_file(log);
  EXPECT_NE(run_command("curl -sf --max-time 2 '" + url + "'").exit_code, 0)
      << "the command's server is gone with it";
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace caustica::testing
