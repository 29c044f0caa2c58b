// /metrics of a real server (--metrics-listen): scraped over HTTP with curl after a few calls,
// checked by Prometheus' own promtool, and read back for the calls, stages and gauges it must
// show.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <regex>
#include <string>

#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

using ::testing::HasSubstr;

// Runs a shell command; its stdout and exit code.
std::pair<std::string, int> run(const std::string& command) {
  std::string out;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return {"", -1};
  char buffer[4096];
  for (size_t n; (n = fread(buffer, 1, sizeof(buffer), pipe)) > 0;) out.append(buffer, n);
  const int status = pclose(pipe);
  return {out, WIFEXITED(status) ? WEXITSTATUS(status) : -1};
}

// The value of the sample `name` (with its labels, as written) in exposition `text`; -1 if absent.
double sample(const std::string& text, const std::string& name) {
  const size_t at = text.find("\n" + name + " ");
  if (at == std::string::npos) return -1;
  return std::stod(text.substr(at + name.size() + 2));
}

class MetricsTest : public ServerTest {
 protected:
  std::vector<std::string> server_args() const override {
    return {"--metrics-listen", "127.0.0.1:0"};
  }

  int metrics_port() const { return server_->logged_port("metrics"); }
};

TEST_F(MetricsTest, MetricsShowCallsStagesAndMemoryAndPassPromtool) {
  const int port = metrics_port();
  ASSERT_GT(port, 0) << server_->log();
  const std::string id = upload_scene(*stub_, cornell_box(32, 24, 2000, 16, 1));
  v1::Frame frame;
  ASSERT_TRUE(render_frame(*stub_, id, 2, frame_format(v1::RGBA32F_LINEAR), &frame).ok());
  {
    grpc::ClientContext context;
    v1::GetSceneRequest request;
    request.set_scene_id("s-00000000");
    v1::SceneInfo info;
    EXPECT_EQ(stub_->GetScene(&context, request, &info).error_code(), grpc::StatusCode::NOT_FOUND);
  }

  const std::string url = "http://127.0.0.1:" + std::to_string(port) + "/metrics";
  const auto [text, curl_code] = run("curl -sf " + url);
  ASSERT_EQ(curl_code, 0) << "curl " << url;
  const auto [lint, promtool_code] = run("curl -sf " + url + " | promtool check metrics 2>&1");
  EXPECT_EQ(promtool_code, 0) << lint;

  EXPECT_EQ(sample(text, R"(caustica_requests_total{code="OK",method="UploadScene"})"), 1);
  EXPECT_EQ(sample(text, R"(caustica_requests_total{code="OK",method="RenderFrame"})"), 1);
  EXPECT_EQ(sample(text, R"(caustica_requests_total{code="NOT_FOUND",method="GetScene"})"), 1);
  EXPECT_EQ(sample(text, R"(caustica_request_duration_seconds_count{method="RenderFrame"})"), 1);
  EXPECT_GT(sample(text, R"(caustica_request_duration_seconds_sum{method="RenderFrame"})"), 0);
  // Two passes rendered, each after tracing its photons.
  EXPECT_EQ(sample(text, R"(caustica_stage_duration_seconds_count{stage="render"})"), 2);
  EXPECT_EQ(sample(text, R"(caustica_stage_duration_seconds_count{stage="photon_trace"})"), 2);
  EXPECT_GE(sample(text, R"(caustica_stage_duration_seconds_count{stage="queue"})"), 2);
  EXPECT_EQ(sample(text, "caustica_scenes"), 1);
  EXPECT_GT(sample(text, "caustica_memory_used_bytes"), 0);
  EXPECT_GE(sample(text, "caustica_memory_peak_bytes"), sample(text, "caustica_memory_used_bytes"));
  EXPECT_EQ(sample(text, "caustica_memory_budget_bytes"), double(size_t{8} << 30));
  EXPECT_EQ(sample(text, "caustica_active_streams"), 0);
  // One device: its own gauges carry what the totals do.
  EXPECT_EQ(sample(text, R"(caustica_device_memory_used_bytes{device="0"})"),
            sample(text, "caustica_memory_used_bytes"));
  EXPECT_EQ(sample(text, R"(caustica_device_memory_budget_bytes{device="0"})"),
            double(size_t{8} << 30));
  EXPECT_EQ(sample(text, R"(caustica_device_queue_waiting{device="0"})"), 0);
  EXPECT_THAT(text, HasSubstr("# TYPE caustica_request_duration_seconds histogram"));
}

TEST(Metrics, AnAddressThatCannotBeBoundIsNamed) {
  // Port 1 needs privileges nobody running the tests should have; a second bind of a taken
  // port would do as well.
  std::unique_ptr<ServerProcess> blocker =
      ServerProcess::start({"--metrics-listen", "127.0.0.1:0"});
  ASSERT_NE(blocker, nullptr);
  std::smatch m;
  const std::string log = blocker->log();
  ASSERT_TRUE(std::regex_search(log, m, std::regex("metrics on port ([0-9]+)")));
  const std::string taken = "127.0.0.1:" + std::string(m[1]);
  const auto [out, code] = run(std::string("'") + CAUSTICA_SERVER_BIN +
                               "' --listen 127.0.0.1:0 --metrics-listen " + taken + " 2>&1");
  EXPECT_EQ(code, 1);
  EXPECT_THAT(out, HasSubstr("--metrics-listen: cannot listen on " + taken));
}

}  // namespace
}  // namespace caustica::testing
