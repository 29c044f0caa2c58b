// A StreamGeometry call's messages put back together into the UpdateGeometryRequest they carry:
// the chunks' vertices land in the request's meshes' positions and normals. Chunks follow an
// upload's rules (MeshChunk): in order, at most 1 MiB of whole vertices each, with their CRC-32;
// errors name the field.
#pragma once

#include <array>
#include <vector>

#include "absl/status/statusor.h"
#include "caustica/v1/render_service.pb.h"

namespace caustica::server {

class GeometryAssembler {
 public:
  absl::Status add(const v1::GeometryChunk& chunk);
  // The request with every chunk's vertices; INVALID_ARGUMENT when none came.
  absl::StatusOr<v1::UpdateGeometryRequest> finish();

 private:
  bool has_request_ = false;
  v1::UpdateGeometryRequest request_;
  std::vector<std::array<size_t, 2>> received_;  // bytes of positions and normals, per mesh
};

}  // namespace caustica::server
