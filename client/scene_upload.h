// Scene upload: a loaded scene streamed to UploadScene as its header and then mesh chunks of at
// most wire::kMaxChunkBytes, as the API requires for meshes larger than one message; and a
// mesh's new vertices so chunked for StreamGeometry.
#pragma once

#include <grpcpp/client_context.h>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.grpc.pb.h"
#include "renderer/scene/scene.h"

namespace caustica::client {

// Called after every chunk sent with the mesh bytes sent so far and the total.
using UploadProgress = std::function<void(uint64_t bytes_sent, uint64_t bytes_total)>;

// Uploads `scene` under `name` and returns the server's SceneInfo (id, counts, build timings).
absl::StatusOr<v1::SceneInfo> upload_scene(v1::RenderService::StubInterface& stub,
                                           grpc::ClientContext& context, const Scene& scene,
                                           const std::string& name,
                                           const UploadProgress& progress = nullptr);

// The StreamGeometry messages that replace `change`'s mesh's vertices: the request, then its
// positions and normals in chunks of at most `max_chunk_bytes`.
std::vector<v1::GeometryChunk> geometry_chunks(const std::string& scene, const MeshChange& change,
                                               std::optional<uint64_t> expect_epoch,
                                               size_t max_chunk_bytes);

}  // namespace caustica::client
