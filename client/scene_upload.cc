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

std::vector<v1::GeometryChunk> geometry_chunks(const std::string& scene, const MeshChange& change,
                                               std::optional<uint64_t> expect_epoch,
                                               size_t max_chunk_bytes) {
  std::vector<v1::GeometryChunk> chunks(1);
  v1::UpdateGeometryRequest& request = *chunks[0].mutable_request();
  request.set_scene_id(scene);
  if (expect_epoch) request.set_expected_geometry_epoch(*expect_epoch);
  MeshChange named = change;
  named.positions.reset();
  named.normals.reset();
  *request.add_meshes() = wire::encode_mesh_change(named);
  const std::pair<v1::MeshChunk::Array, const std::optional<std::vector<Vec3f>>*> arrays[] = {
      {v1::MeshChunk::POSITIONS, &change.positions}, {v1::MeshChunk::NORMALS, &change.normals}};
  for (const auto& [array, vertices] : arrays) {
    if (!*vertices) continue;
    const std::string_view bytes(reinterpret_cast<const char*>((*vertices)->data()),
                                 (*vertices)->size() * sizeof(Vec3f));
    v1::GeometryChunk chunk;
    wire::for_each_array_chunk(0, array, bytes, max_chunk_bytes, *chunk.mutable_mesh(), [&] {
      chunks.push_back(chunk);
      return true;
    });
  }
  return chunks;
}

}  // namespace caustica::client
