// Starting, waiting for and stopping the embedded caustica-server (see embedded_server.h).
#include "client/embedded_server.h"

#include <fcntl.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <sys/file.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "client/health_check.h"
#include "client/subprocess.h"

namespace caustica::client {
namespace {

constexpr char kServerName[] = "caustica-server";
constexpr auto kPollInterval = std::chrono::milliseconds(20);

std::filesystem::path running_executable() {
  std::error_code error;
  return std::filesystem::read_symlink("/proc/self/exe", error);
}

absl::StatusOr<std::filesystem::path> make_temp_dir() {
  const char* tmp = std::getenv("TMPDIR");
  std::string pattern = absl::StrCat(tmp != nullptr && *tmp ? tmp : "/tmp", "/caustica-XXXXXX");
  if (mkdtemp(pattern.data()) == nullptr) {
    return absl::InternalError(absl::StrCat("cannot create a temporary directory ", pattern));
  }
  return std::filesystem::path(pattern);
}

// The port once the server wrote it whole; the server may be midway through writing.
std::optional<int> read_port(const std::filesystem::path& port_file) {
  std::ifstream in(port_file);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  int port = 0;
  if (!absl::SimpleAtoi(absl::StripAsciiWhitespace(text), &port) || port <= 0 || port > 65535) {
    return std::nullopt;
  }
  return port;
}

}  // namespace

absl::StatusOr<std::filesystem::path> find_server_binary() {
  if (const char* env = std::getenv("CAUSTICA_SERVER_BIN"); env != nullptr && *env) {
    if (access(env, X_OK) != 0) {
      return absl::NotFoundError(
          absl::StrCat("CAUSTICA_SERVER_BIN=", env, " is not an executable file"));
    }
    return std::filesystem::path(env);
  }
  const std::filesystem::path dir = running_executable().parent_path();
  for (const std::filesystem::path& candidate :
       {dir / kServerName, dir.parent_path() / "server" / kServerName}) {
    if (access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return absl::NotFoundError(absl::StrCat(
      "no server given (--server) and nothing serving on localhost:50051, and ", kServerName,
      " to start one was not found next to ", dir.string(), " (set CAUSTICA_SERVER_BIN)"));
}

std::optional<std::filesystem::path> default_data_dir() {
  if (const char* dir = std::getenv("CAUSTICA_DATA_DIR")) {
    if (*dir == '\0') return std::nullopt;
    return std::filesystem::path(dir);
  }
  if (const char* state = std::getenv("XDG_STATE_HOME"); state != nullptr && *state == '/') {
    return std::filesystem::path(state) / "caustica";
  }
  if (const char* home = std::getenv("HOME"); home != nullptr && *home == '/') {
    return std::filesystem::path(home) / ".local" / "state" / "caustica";
  }
  return std::nullopt;
}

namespace {

// Whether a running caustica-server holds `dir` (its lock file is locked).
bool data_dir_in_use(const std::filesystem::path& dir) {
  const int fd = ::open((dir / "lock").c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0) return false;
  const bool locked = ::flock(fd, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);  // releases the lock if this took it
  return locked;
}

}  // namespace

absl::StatusOr<std::unique_ptr<EmbeddedServer>> EmbeddedServer::start(
    const EmbeddedServerOptions& options) {
  std::filesystem::path binary = options.binary;
  if (binary.empty()) {
    absl::StatusOr<std::filesystem::path> found = find_server_binary();
    if (!found.ok()) return found.status();
    binary = *found;
  }
  absl::StatusOr<std::filesystem::path> dir = make_temp_dir();
  if (!dir.ok()) return dir.status();
  const std::filesystem::path port_file = *dir / "port";
  std::vector<std::string> argv = {binary.string(), "--listen", "127.0.0.1:0", "--port-file",
                                   port_file.string()};
  std::filesystem::path data_dir = options.data_dir.value_or(default_data_dir().value_or(""));
  if (!data_dir.empty() && data_dir_in_use(data_dir)) {
    std::cerr << "caustica: note: another command's server is using " << data_dir.string()
              << "; this command's scenes are not kept\n";
    data_dir.clear();
  }
  if (!data_dir.empty()) {
    argv.push_back("--data-dir");
    argv.push_back(data_dir.string());
  }
  // The server writes these before --port-file, so they are complete once that appears.
  const std::array<std::pair<const char*, int EmbeddedServer::*>, 3> side_ports = {
      {{"health", &EmbeddedServer::health_port_},
       {"metrics", &EmbeddedServer::metrics_port_},
       {"http", &EmbeddedServer::http_port_}}};
  if (options.every_port) {
    for (const auto& [name, member] : side_ports) {
      argv.insert(argv.end(), {absl::StrCat("--", name, "-listen"), "127.0.0.1:0",
                               absl::StrCat("--", name, "-port-file"),
                               (*dir / absl::StrCat(name, "-port")).string()});
    }
  }
  argv.insert(argv.end(), options.extra_args.begin(), options.extra_args.end());
  absl::StatusOr<pid_t> pid = spawn_process(argv, *dir / "server.log", options.environment);
  if (!pid.ok()) {
    std::filesystem::remove_all(*dir);
    return pid.status();
  }
  // From here the destructor stops the process and removes the directory on every error path.
  std::unique_ptr<EmbeddedServer> server(new EmbeddedServer(*pid, *dir));
  server->data_dir_ = data_dir;

  const auto give_up = std::chrono::steady_clock::now() + options.startup_timeout;
  std::optional<int> port;
  while (!(port = read_port(port_file))) {
    if (std::optional<int> exit = poll_exit(server->pid_)) {
      server->pid_ = -1;
      return absl::UnavailableError(absl::StrCat(binary.string(), " exited with status ", *exit,
                                                 " before listening:\n", server->log_tail()));
    }
    if (std::chrono::steady_clock::now() > give_up) {
      return absl::DeadlineExceededError(
          absl::StrCat(binary.string(), " did not write its port within ",
                       options.startup_timeout.count(), " s:\n", server->log_tail()));
    }
    std::this_thread::sleep_for(kPollInterval);
  }
  server->address_ = absl::StrCat("127.0.0.1:", *port);
  server->port_ = *port;
  if (options.every_port) {
    for (const auto& [name, member] : side_ports) {
      std::optional<int> side = read_port(*dir / absl::StrCat(name, "-port"));
      if (!side) {
        return absl::InternalError(absl::StrCat(binary.string(), " wrote no --", name,
                                                "-port-file:\n", server->log_tail()));
      }
      server.get()->*member = *side;
    }
  }
  if (absl::Status s = server->wait_until_serving(give_up); !s.ok()) return s;
  return server;
}

absl::Status EmbeddedServer::wait_until_serving(std::chrono::steady_clock::time_point give_up) {
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_ENABLE_HTTP_PROXY, 0);  // loopback: never through $http_proxy
  const std::shared_ptr<grpc::Channel> channel =
      grpc::CreateCustomChannel(address_, grpc::InsecureChannelCredentials(), args);
  absl::Status last = absl::OkStatus();
  while (std::chrono::steady_clock::now() < give_up) {
    if (poll_exit(pid_)) {
      pid_ = -1;
      return absl::UnavailableError(
          absl::StrCat("caustica-server exited while starting:\n", log_tail()));
    }
    const auto deadline = std::chrono::system_clock::now() + std::chrono::seconds(2);
    absl::StatusOr<ServingStatus> health = check_health(channel, deadline, true);
    if (health.ok() && *health == ServingStatus::kServing) return absl::OkStatus();
    last = health.ok() ? absl::UnavailableError("health reports not serving") : health.status();
    std::this_thread::sleep_for(kPollInterval);
  }
  return absl::DeadlineExceededError(absl::StrCat("caustica-server on ", address_,
                                                  " did not become healthy (", last.message(),
                                                  "):\n", log_tail()));
}

std::string EmbeddedServer::log_tail() const {
  constexpr std::streamoff kTail = 2000;
  std::ifstream in(dir_ / "server.log", std::ios::binary | std::ios::ate);
  if (!in) return "(no server log)";
  const std::streamoff size = in.tellg();
  in.seekg(std::max<std::streamoff>(0, size - kTail));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

EmbeddedServer::~EmbeddedServer() {
  if (pid_ > 0) terminate_process(pid_, std::chrono::seconds(10));
  std::error_code ignored;
  std::filesystem::remove_all(dir_, ignored);
}

}  // namespace caustica::client
