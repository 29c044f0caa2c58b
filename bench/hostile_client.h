// The hostile half of the soak's --hostile mode: clients that, between their well-formed cycles,
// send what no well-behaved client sends to every port a caustica-server opens (gRPC, health,
// metrics, the viewer's HTTP and WebSocket), and judge each answer against what the server
// promises (docs/reliability.md, "Hostile clients").
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "renderer/scene/scene.h"

namespace caustica {

// The ports of the server under attack.
struct HostilePorts {
  int grpc = 0, health = 0, metrics = 0, http = 0;
};

// The --max-message-mb the soak gives its server in hostile mode; the oversized calls exceed it.
inline constexpr int kHostileMaxMessageMb = 64;

// Each client's actions go round these in turn.
enum HostileClass {
  kHostileStrings,     // every string field of a call with control bytes, non-ASCII, a megabyte
  kMalformedBytes,     // truncated, garbage and oversized bytes on every port
  kWebSocketRefusals,  // a hello with a bad token, a message announced far over the limit
  kSlowConnections,    // headers sent slowly and idle sockets on every port, held a while
  kAbruptDisconnects,  // streams, uploads and viewer sockets dropped mid-call
  kHostileClasses
};
inline constexpr std::array<const char*, kHostileClasses> kHostileClassNames = {
    "strings", "malformed_bytes", "websocket_refusals", "slow_and_idle", "disconnects"};

// What one client's actions of one class met. Every probe (one call or one connection) ends one of
// four ways: the refusal the server promises for it, another acceptable end (an answer, a
// connection taken, the client's own cancel), turned away by a documented limit, or unexpected.
struct HostileLog {
  uint64_t actions = 0;
  uint64_t probes = 0;
  uint64_t refused = 0;
  uint64_t accepted = 0;
  uint64_t busy = 0;
  uint64_t unexpected = 0;
  std::vector<std::string> first_unexpected;

  void merge(const HostileLog& other);
};
using HostileLogs = std::array<HostileLog, kHostileClasses>;

class HostileClient {
 public:
  // The calls aim at `target_scene_id` so that they get past the scene lookup; they may change
  // that scene, so its frames are never judged. `scene` is what the cut-off uploads begin to send.
  // Every call, read and connection gives up after `deadline_s`.
  HostileClient(int index, const HostilePorts& ports, const std::string& target_scene_id,
                const Scene& scene, double deadline_s);
  ~HostileClient();
  HostileClient(const HostileClient&) = delete;
  HostileClient& operator=(const HostileClient&) = delete;

  // One action of the next class in turn; the first is the client's index's, so that clients
  // started together spread over the classes.
  void act(HostileLogs& logs);

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

// How one port answered a plain request, and how long that took.
struct PortCheck {
  const char* port;  // "grpc", "health", "metrics" or "http"
  absl::Status status;
  double ms = 0;
};

// Health/Check on the gRPC and health ports, GET /metrics on the metrics port and GET / on the
// viewer's, each on a new connection.
std::vector<PortCheck> check_every_port(const HostilePorts& ports, double deadline_s);

}  // namespace caustica
