// view SCENE: uploads the scene (or takes an id) and opens the server's browser viewer on it. With
// the embedded server, that server starts with its viewer and serves until Ctrl-C.
#include <signal.h>

#include <cctype>
#include <cstdlib>
#include <iostream>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/commands.h"
#include "client/result_output.h"
#include "client/scene_source.h"
#include "client/subprocess.h"

namespace caustica::client {
namespace {

// The host part of "host:port" ("[v6]:port" keeps its brackets, as a URL wants them).
std::string host_of(const std::string& address) {
  const size_t colon = address.rfind(':');
  return colon == std::string::npos ? address : address.substr(0, colon);
}

// Opens `url` in the desktop's browser when there is a desktop; never waits for it.
void open_in_browser(const std::string& url) {
  if (std::getenv("DISPLAY") == nullptr && std::getenv("WAYLAND_DISPLAY") == nullptr) return;
  if (!find_on_path("xdg-open")) return;
  absl::StatusOr<pid_t> opened =
      spawn_process({"xdg-open", url}, std::filesystem::path("/dev/null"));
  if (!opened.ok())
    std::cerr << "caustica: cannot open a browser: " << opened.status().message() << "\n";
}

// `value` for a URL's query, every byte but RFC 3986's unreserved ones as %XX: a token may hold
// '&', '#', '+' or '%', which the page's URLSearchParams would otherwise split or decode.
std::string query_value(const std::string& value) {
  std::string out;
  for (const unsigned char c : value) {
    if (std::isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~') {
      out += char(c);
    } else {
      absl::StrAppend(&out, absl::StrFormat("%%%02X", c));
    }
  }
  return out;
}

}  // namespace

std::string viewer_url(const std::string& host, uint32_t port, const std::string& scene_id,
                       const std::string& token) {
  std::string url = absl::StrCat("http://", host, ":", port, "/?scene=", query_value(scene_id));
  // The page removes the token from the address bar as soon as it has read it.
  if (!token.empty()) absl::StrAppend(&url, "&token=", query_value(token));
  return url;
}

absl::Status run_view(const GlobalOptions& global, const ViewOptions& options, std::ostream& out) {
  // Blocked before the embedded server and gRPC's threads start, so that Ctrl-C reaches the
  // sigwait below and the server is stopped cleanly.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  ConnectOptions connect = global.connect;
  connect.embedded.extra_args.insert(connect.embedded.extra_args.end(),
                                     {"--http-listen", "127.0.0.1:0"});
  absl::StatusOr<std::unique_ptr<Connection>> connection = Connection::open(connect);
  if (!connection.ok()) return connection.status();
  Connection& c = **connection;
  absl::StatusOr<v1::Stats> stats =
      c.call(&v1::RenderService::Stub::GetStats, v1::GetStatsRequest());
  if (!stats.ok()) return stats.status();
  if (stats->viewer_port() == 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("the server at ", c.address(),
                     " serves no viewer: start it with --http-listen HOST:PORT (docs/viewer.md)"));
  }
  // A file uploaded to the embedded server goes with it; one on a running server stays for the
  // viewer, which outlives this command.
  const bool keep = options.keep || !c.embedded();
  absl::StatusOr<std::unique_ptr<SceneSource>> source =
      SceneSource::open(c, options.scene, options.overrides, keep, global.progress);
  if (!source.ok()) return source.status();
  const std::string url = viewer_url(host_of(c.address()), stats->viewer_port(), (*source)->id(),
                                     c.embedded() ? "" : global.connect.token);
  if (global.json) {
    print_json(out, {{"scene_id", (*source)->id()}, {"url", url}, {"server", c.address()}});
  } else {
    out << "viewer       " << url << "\n";
  }
  out.flush();
  if (options.open) open_in_browser(url);
  if (!c.embedded()) return absl::OkStatus();
  if (!global.json) out << "serving      until Ctrl-C (the server started for this command)\n";
  out.flush();
  int signal_number = 0;
  sigwait(&signals, &signal_number);
  return absl::OkStatus();
}

}  // namespace caustica::client
