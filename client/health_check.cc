// Health/Check over a generic stub (see health_check.h).
#include "client/health_check.h"

#include <grpcpp/client_context.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/support/byte_buffer.h>

#include <future>
#include <string>
#include <vector>

#include "client/rpc_status.h"

namespace caustica::client {
namespace {

// HealthCheckResponse is `ServingStatus status = 1;`: tag byte 0x08, then the enum as a varint.
// Proto3 leaves a zero value out, so an empty message reads as UNKNOWN.
ServingStatus parse_health_response(const std::string& bytes) {
  uint64_t status = 0;
  size_t i = 0;
  while (i < bytes.size()) {
    const uint8_t tag = static_cast<uint8_t>(bytes[i++]);
    if ((tag & 7) != 0) break;  // only varint fields are expected; stop at anything else
    uint64_t value = 0;
    for (int shift = 0; i < bytes.size() && shift < 64; shift += 7) {
      const uint8_t b = static_cast<uint8_t>(bytes[i++]);
      value |= uint64_t{b & 0x7fu} << shift;
      if ((b & 0x80) == 0) break;
    }
    if ((tag >> 3) == 1) status = value;
  }
  return status <= 3 ? static_cast<ServingStatus>(status) : ServingStatus::kUnknown;
}

}  // namespace

absl::StatusOr<ServingStatus> check_health(const std::shared_ptr<grpc::Channel>& channel,
                                           std::chrono::system_clock::time_point deadline,
                                           bool wait_for_ready) {
  grpc::TemplatedGenericStub<grpc::ByteBuffer, grpc::ByteBuffer> stub(channel);
  grpc::ClientContext context;
  context.set_deadline(deadline);
  context.set_wait_for_ready(wait_for_ready);
  // HealthCheckRequest{service: ""} encodes to zero bytes.
  const grpc::Slice empty;
  const grpc::ByteBuffer request(&empty, 1);
  grpc::ByteBuffer response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                 [&done](grpc::Status status) { done.set_value(std::move(status)); });
  const grpc::Status status = done.get_future().get();
  if (!status.ok()) return to_absl(status);

  std::vector<grpc::Slice> slices;
  if (!response.Dump(&slices).ok()) return absl::InternalError("unreadable health response");
  std::string bytes;
  for (const grpc::Slice& slice : slices) {
    bytes.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
  }
  return parse_health_response(bytes);
}

}  // namespace caustica::client
