#include "server/geometry_stream.h"

#include <cstring>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "proto/wire/scene_wire.h"
#include "renderer/scene/scene_limits.h"

namespace caustica::server {
namespace {

constexpr size_t kVertexBytes = 3 * sizeof(float);

absl::Status invalid(const std::string& field, const std::string& problem) {
  return absl::InvalidArgumentError(absl::StrCat(field, ": ", problem));
}

}  // namespace

absl::Status GeometryAssembler::add(const v1::GeometryChunk& chunk) {
  if (chunk.has_request()) {
    if (has_request_) return invalid("request", "comes a second time");
    has_request_ = true;
    request_ = chunk.request();
    received_.assign(size_t(request_.meshes_size()), {0, 0});
    return absl::OkStatus();
  }
  if (!chunk.has_mesh()) return invalid("payload", "is neither a request nor a mesh chunk");
  if (!has_request_) return invalid("mesh", "arrives before the request");
  const v1::MeshChunk& c = chunk.mesh();
  if (c.mesh() >= uint32_t(request_.meshes_size())) {
    return invalid("mesh.mesh", absl::StrCat(c.mesh(), " is out of range (the request has ",
                                             request_.meshes_size(), " meshes)"));
  }
  if (c.array() != v1::MeshChunk::POSITIONS && c.array() != v1::MeshChunk::NORMALS) {
    return invalid("mesh.array", absl::StrCat(v1::MeshChunk::Array_Name(c.array()),
                                              " does not change: only POSITIONS and NORMALS do"));
  }
  const bool positions = c.array() == v1::MeshChunk::POSITIONS;
  v1::MeshUpdate& mesh = *request_.mutable_meshes(int(c.mesh()));
  const std::string where =
      absl::StrCat("meshes[", c.mesh(), "].", positions ? "positions" : "normals");
  google::protobuf::RepeatedField<float>& values =
      positions ? *mesh.mutable_positions() : *mesh.mutable_normals();
  size_t& received = received_[c.mesh()][positions ? 0 : 1];
  if (received == 0 && !values.empty()) {
    return invalid(where, "comes both in the request and in chunks");
  }
  const std::string& data = c.data();
  if (data.empty()) return invalid(where, "a chunk is empty");
  if (data.size() > wire::kMaxChunkBytes) {
    return invalid(where, absl::StrCat("a chunk of ", data.size(), " bytes exceeds the ",
                                       wire::kMaxChunkBytes, "-byte limit"));
  }
  if (data.size() % kVertexBytes != 0) {
    return invalid(where, absl::StrCat("a chunk of ", data.size(),
                                       " bytes is not a whole number of 12-byte vertices"));
  }
  if (wire::chunk_crc32(data) != c.crc32()) {
    return invalid(where, absl::StrFormat("checksum %08x does not match the data (%08x)", c.crc32(),
                                          wire::chunk_crc32(data)));
  }
  if (c.offset() != received) {
    return invalid(where,
                   absl::StrCat("offset ", c.offset(), " but ", received, " bytes arrived so far"));
  }
  if (received + data.size() > kMaxVerticesPerMesh * kVertexBytes) {
    return absl::ResourceExhaustedError(absl::StrCat(where, ": more than ", kMaxVerticesPerMesh,
                                                     " vertices, the most a mesh may have"));
  }
  const int old_size = values.size();
  values.Resize(old_size + int(data.size() / sizeof(float)), 0.0f);
  std::memcpy(values.mutable_data() + old_size, data.data(), data.size());
  received += data.size();
  return absl::OkStatus();
}

absl::StatusOr<v1::UpdateGeometryRequest> GeometryAssembler::finish() {
  if (!has_request_) return invalid("request", "never came: it must be the first message");
  return std::move(request_);
}

}  // namespace caustica::server
