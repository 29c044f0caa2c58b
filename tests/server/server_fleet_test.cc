// `caustica animate --servers` against real servers on loopback: the keyframes spread over the
// replicas, one replica is SIGKILLed half-way and another starts during the run, and still every
// frame is written and equals what a single server renders for the same keyframe.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/subprocess.h"
#include "tests/server/server_harness.h"

namespace caustica::testing {
namespace {

namespace fs = std::filesystem;
using std::chrono::steady_clock;

constexpr int kKeyframes = 48;

// A light circling under the ceiling, one keyframe per step; a few passes each so that the run
// lasts long enough for a replica to die and another to join while keyframes remain. A quarter of
// the way the glass sphere rises, halfway the camera steps 200 mm closer, at three quarters the
// ceiling's light dims, and each stays so: the replicas that render the later keyframes must see
// them so too.
fs::path write_orbit_script(const fs::path& dir) {
  std::ostringstream script;
  script << "{\"keyframes\": [";
  for (int i = 0; i < kKeyframes; ++i) {
    const double angle = 2 * M_PI * i / kKeyframes;
    const char* change =
        i == kKeyframes / 2
            ? ", \"camera\": {\"position\": [278, 273, -600], \"look_at\": [278, 273, 0], "
              "\"fov\": 39.3077}"
        : i == kKeyframes / 4
            ? ", \"meshes\": [{\"mesh\": \"glass sphere\", \"transform\": {\"translate\": "
              "[0, 60, 0]}}]"
        : i == 3 * kKeyframes / 4
            ? ", \"emitters\": [{\"material\": \"light\", \"radiance\": [4, 4, 3]}]"
            : "";
    script << (i ? "," : "")
           << absl::StrFormat(
                  "{\"lights\": [{\"type\": \"point\", \"name\": \"orbit\", \"position\": [%.3f, "
                  "380, %.3f], \"intensity\": [60000, 52000, 42000]}], \"passes\": 3%s}",
                  278 + 170 * std::cos(angle), 280 + 170 * std::sin(angle), change);
  }
  script << "]}";
  const fs::path path = dir / "orbit.json";
  std::ofstream(path) << script.str();
  return path;
}

// A loopback port nothing listens on now, for a server started later.
int free_port() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  socklen_t length = sizeof(address);
  EXPECT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&address), length), 0);
  EXPECT_EQ(getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length), 0);
  close(fd);
  return ntohs(address.sin_port);
}

int frame_files(const fs::path& dir) {
  int count = 0;
  std::error_code error;
  for (auto it = fs::directory_iterator(dir, error); !error && it != fs::directory_iterator();
       it.increment(error)) {
    ++count;
  }
  return count;
}

std::vector<std::string> animate_args(const fs::path& script, const fs::path& out) {
  return {CAUSTICA_CLIENT_BIN,
          "--json",
          "--timeout",
          "60",
          "animate",
          (fs::path(CAUSTICA_SCENES_DIR) / "cornell-caustics" / "scene.json").string(),
          "--script",
          script.string(),
          "-o",
          out.string(),
          "--format",
          "pfm",
          "--width",
          "48",
          "--height",
          "48",
          "--photons",
          "20000"};
}

// The JSON line of the CLI's output (stderr notes are the other lines).
nlohmann::json result_json(const std::string& output) {
  std::istringstream lines(output);
  for (std::string line; std::getline(lines, line);) {
    if (!line.empty() && line[0] == '{') return nlohmann::json::parse(line, nullptr, false);
  }
  return nlohmann::json();
}

TEST(ServerFleet, AnimationSurvivesAKilledReplicaAndUsesANewOne) {
  std::vector<std::unique_ptr<ServerProcess>> servers;
  for (int i = 0; i < 3; ++i) {
    servers.push_back(ServerProcess::start());
    ASSERT_NE(servers.back(), nullptr);
  }
  const int late_port = free_port();
  const std::string late_address = "127.0.0.1:" + std::to_string(late_port);
  const fs::path dir = make_temp_dir("caustica-fleet-test");
  const fs::path script = write_orbit_script(dir);
  const fs::path out = dir / "fleet";

  std::vector<std::string> endpoints;
  for (const auto& server : servers) endpoints.push_back(server->address());
  endpoints.push_back(late_address);  // not up yet: the client keeps probing it
  std::vector<std::string> args = animate_args(script, out);
  args.insert(args.end(), {"--servers", absl::StrJoin(endpoints, ",")});
  const fs::path log = dir / "fleet.log";
  absl::StatusOr<pid_t> client = client::spawn_process(args, log);
  ASSERT_TRUE(client.ok()) << client.status();

  const auto give_up = steady_clock::now() + std::chrono::seconds(90);
  std::optional<int> exit_code;
  const auto wait_for_frames = [&](int frames) {
    while (!(exit_code = client::poll_exit(*client)) && frame_files(out) < frames &&
           steady_clock::now() < give_up) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  };
  wait_for_frames(2);
  std::unique_ptr<ServerProcess> late = ServerProcess::start({"--listen", late_address});
  ASSERT_NE(late, nullptr);
  wait_for_frames(kKeyframes / 2);
  ASSERT_FALSE(exit_code) << "the animation ended before half-way:\n" << read_text_file(log);
  servers[1]->kill_now();
  while (!exit_code && steady_clock::now() < give_up) {
    exit_code = client::poll_exit(*client);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (!exit_code) client::terminate_process(*client, std::chrono::milliseconds(0));
  const std::string output = read_text_file(log);
  ASSERT_EQ(exit_code, 0) << output;

  // Every keyframe's frame is there, and the JSON says who rendered what.
  EXPECT_EQ(frame_files(out), kKeyframes) << output;
  const nlohmann::json result = result_json(output);
  ASSERT_TRUE(result.is_object()) << output;
  ASSERT_EQ(result["frames"].size(), static_cast<size_t>(kKeyframes)) << output;
  ASSERT_EQ(result["replicas"].size(), 4u) << output;
  int total = 0;
  for (const nlohmann::json& replica : result["replicas"]) total += replica["frames"].get<int>();
  EXPECT_EQ(total, kKeyframes) << output;
  const nlohmann::json& killed = result["replicas"][1];
  EXPECT_EQ(killed["server"], servers[1]->address());
  EXPECT_GE(killed["losses"].get<int>(), 1) << output;
  const nlohmann::json& joined = result["replicas"][3];
  EXPECT_EQ(joined["server"], late_address);
  EXPECT_GT(joined["frames"].get<int>(), 0) << "the replica started during the run took no work\n"
                                            << output;
  for (int i = 0; i < kKeyframes; ++i) {
    EXPECT_EQ(result["frames"][i]["keyframe"].get<int>(), i);
  }

  // The same script on one server: byte-identical frames.
  const fs::path single = dir / "single";
  std::vector<std::string> single_args = animate_args(script, single);
  single_args.insert(single_args.begin() + 1, {"--server", servers[0]->address()});
  std::vector<std::string> quoted;
  for (const std::string& arg : single_args) quoted.push_back("'" + arg + "'");
  const CommandRun reference = run_command(absl::StrJoin(quoted, " "));
  ASSERT_EQ(reference.exit_code, 0) << reference.output;
  for (int i = 0; i < kKeyframes; ++i) {
    const std::string name = absl::StrFormat("frame_%04d.pfm", i);
    const std::string fleet_bytes = read_text_file(out / name);
    ASSERT_FALSE(fleet_bytes.empty()) << name;
    EXPECT_TRUE(fleet_bytes == read_text_file(single / name))
        << name << " differs from the single server's, rendered by "
        << result["frames"][i]["server"];
  }
  if (!HasFailure()) fs::remove_all(dir);
}

// Plain commands with --server A,B: an uploaded scene is found on whichever replica holds it,
// and once that replica is gone the error names it.
TEST(ServerFleet, SceneCallsFindTheReplicaThatHoldsTheScene) {
  auto a = ServerProcess::start();
  ASSERT_NE(a, nullptr);
  auto b = ServerProcess::start();
  ASSERT_NE(b, nullptr);
  const std::string servers = a->address() + "," + b->address();
  const auto cli = [&](const std::string& args) {
    return run_command(std::string("'") + CAUSTICA_CLIENT_BIN + "' --timeout 30 --server " +
                       servers + " " + args);
  };
  const std::string scene = (fs::path(CAUSTICA_SCENES_DIR) / "cornell-box" / "scene.json").string();
  const CommandRun uploaded = cli("scene upload '" + scene + "' --name routed");
  ASSERT_EQ(uploaded.exit_code, 0) << uploaded.output;
  const std::string id = uploaded.output.substr(0, uploaded.output.find('\n'));
  ASSERT_TRUE(id.starts_with("s-")) << uploaded.output;
  const bool on_a = get_scene_status(*a->stub(), id).ok();
  ServerProcess& holder = on_a ? *a : *b;
  ServerProcess& other = on_a ? *b : *a;
  ASSERT_TRUE(get_scene_status(*holder.stub(), id).ok());

  // Each call goes to the holder, whichever replica round-robin would have picked.
  for (int i = 0; i < 3; ++i) {
    const CommandRun info = cli("scene info " + id);
    EXPECT_EQ(info.exit_code, 0) << info.output;
    EXPECT_NE(info.output.find("routed"), std::string::npos) << info.output;
  }
  const CommandRun lights = cli("light set " + id + " --point 278,400,279 --intensity 5000");
  EXPECT_EQ(lights.exit_code, 0) << lights.output;
  const CommandRun list = cli("--json scene list");
  EXPECT_EQ(list.exit_code, 0) << list.output;
  EXPECT_NE(list.output.find(id), std::string::npos) << list.output;

  const CommandRun missing = cli("scene info s-00000000");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.output.find("NOT_FOUND"), std::string::npos) << missing.output;
  EXPECT_NE(missing.output.find(a->address()), std::string::npos) << missing.output;
  EXPECT_NE(missing.output.find(b->address()), std::string::npos) << missing.output;

  const std::string gone = holder.address();
  holder.kill_now();
  const CommandRun lost = cli("scene info " + id);
  EXPECT_EQ(lost.exit_code, 1);
  EXPECT_NE(lost.output.find("UNAVAILABLE"), std::string::npos) << lost.output;
  EXPECT_NE(lost.output.find(gone), std::string::npos) << lost.output;
  // Stateless calls still succeed on the replica that is left.
  const CommandRun stats = cli("stats");
  EXPECT_EQ(stats.exit_code, 0) << stats.output;
  EXPECT_TRUE(other.running());
}

// --max-connection-age: an idle client's connection is closed once it is that old (the channel
// falls back to IDLE and reconnects on its next call); without it, the connection stays.
TEST(ServerFleet, MaxConnectionAgeEndsOldConnections) {
  auto aging =
      ServerProcess::start({"--max-connection-age", "0.5", "--max-connection-age-grace", "1"});
  ASSERT_NE(aging, nullptr);
  auto lasting = ServerProcess::start();
  ASSERT_NE(lasting, nullptr);
  for (ServerProcess* server : {aging.get(), lasting.get()}) {
    EXPECT_EQ(list_scenes(*server->stub()).size(), 0u);
    EXPECT_EQ(server->channel()->GetState(false), GRPC_CHANNEL_READY);
  }
  // The age is jittered, the grace comes on top, and gRPC's GOAWAY handshake takes a while more
  // to close the connection.
  const auto give_up = steady_clock::now() + std::chrono::seconds(40);
  while (aging->channel()->GetState(false) == GRPC_CHANNEL_READY && steady_clock::now() < give_up) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_NE(aging->channel()->GetState(false), GRPC_CHANNEL_READY);
  EXPECT_EQ(lasting->channel()->GetState(false), GRPC_CHANNEL_READY);
  EXPECT_EQ(list_scenes(*aging->stub()).size(), 0u);  // and it reconnects
}

}  // namespace
}  // namespace caustica::testing
