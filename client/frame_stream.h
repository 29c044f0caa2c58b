// Reading a server stream of frames (StreamFrames, PlayAnimation) into whole frames.
#pragma once

#include <grpcpp/client_context.h>
#include <grpcpp/support/sync_stream.h>

#include <functional>

#include "absl/status/status.h"
#include "caustica/v1/render_service.pb.h"

namespace caustica::client {

// Called with every whole frame; an error stops the stream.
using FrameHandler = std::function<absl::Status(v1::Frame& frame)>;

// Reads `reader` to its end, reassembling pieces (FrameAssembler) and calling `on_frame` with
// every whole frame. An error from the assembler or `on_frame` cancels the call and is returned;
// otherwise the call's own status, or DATA_LOSS when it ended inside a frame.
absl::Status receive_frames(grpc::ClientContext& context,
                            grpc::ClientReaderInterface<v1::Frame>& reader,
                            const FrameHandler& on_frame);

}  // namespace caustica::client
