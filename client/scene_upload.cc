// Streaming a scene to UploadScene (see scene_upload.h).
#include "client/scene_upload.h"

#include "client/rpc_status.h"
#include "proto/wire/scene_wire.h"

namespace caustica::client {

absl::StatusOr<v1::SceneInfo> upload_scene(v1::RenderService::StubInterface& stub,
                                           grpc::ClientContext& context, const Scene& scene,
                                           const std::string& name,
                                           const UploadProgress& progress) {
  v1::SceneInfo info;
  std::unique_ptr<grpc::ClientWriterInterface<v1::SceneChunk>> writer =
      stub.UploadScene(&context, &info);
  v1::SceneChunk header;
  *header.mutable_header() = wire::encode_scene_header(scene, name);
  // A failed Write means the server already ended the call; Finish() says why.
  if (writer->Write(header)) {
    const uint64_t total = wire::upload_bytes(scene);
    uint64_t sent = 0;
    if (progress) progress(0, total);
    const bool all_sent =
        wire::for_each_chunk(scene, wire::kMaxChunkBytes, [&](v1::SceneChunk& chunk) {
          if (!writer->Write(chunk)) return false;
          sent += chunk.mesh().data().size();
          if (progress) progress(sent, total);
          return true;
        });
    if (all_sent) writer->WritesDone();
  }
  if (absl::Status status = to_absl(writer->Finish()); !status.ok()) return status;
  return info;
}

}  // namespace caustica::client
