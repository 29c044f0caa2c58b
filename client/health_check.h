// grpc.health.v1.Health/Check from the client side. Debian's gRPC ships the server half of the
// health service but neither health.proto nor its stubs, so the call goes through a generic stub
// with the two tiny messages encoded by hand.
#pragma once

#include <grpcpp/channel.h>

#include <chrono>
#include <memory>

#include "absl/status/statusor.h"

namespace caustica::client {

// HealthCheckResponse.ServingStatus.
enum class ServingStatus { kUnknown = 0, kServing = 1, kNotServing = 2, kServiceUnknown = 3 };

// The overall health of the server behind `channel` (service ""). `wait_for_ready` keeps the call
// waiting for a connection until `deadline` instead of failing at once with UNAVAILABLE.
absl::StatusOr<ServingStatus> check_health(const std::shared_ptr<grpc::Channel>& channel,
                                           std::chrono::system_clock::time_point deadline,
                                           bool wait_for_ready);

}  // namespace caustica::client
