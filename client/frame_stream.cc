// Reassembling a frame stream and handing on whole frames (see frame_stream.h).
#include "client/frame_stream.h"

#include "client/frame_assembler.h"
#include "client/rpc_status.h"

namespace caustica::client {

absl::Status receive_frames(grpc::ClientContext& context,
                            grpc::ClientReaderInterface<v1::Frame>& reader,
                            const FrameHandler& on_frame) {
  FrameAssembler assembler;
  v1::Frame piece;
  absl::Status failure;
  while (failure.ok() && reader.Read(&piece)) {
    absl::StatusOr<std::optional<v1::Frame>> frame = assembler.add(std::move(piece));
    piece.Clear();
    if (!frame.ok()) {
      failure = frame.status();
    } else if (*frame) {
      failure = on_frame(**frame);
    }
  }
  if (!failure.ok()) {
    // Nothing more is wanted from this call; the server stops rendering between passes.
    context.TryCancel();
    reader.Finish();
    return failure;
  }
  if (absl::Status status = to_absl(reader.Finish()); !status.ok()) return status;
  return assembler.finish();
}

}  // namespace caustica::client
