// mesh move SCENE MESH: places a mesh by a scene file's kind of transform (UpdateGeometry); mesh
// reshape SCENE MESH --from FILE: streams a model file's vertices into it (StreamGeometry). Both
// print the rebuild report.
#include <memory>
#include <string>
#include <tuple>

#include "client/commands.h"
#include "client/result_output.h"
#include "client/rpc_status.h"
#include "client/scene_upload.h"
#include "proto/wire/scene_wire.h"
#include "renderer/scene/mesh_file.h"
#include "renderer/scene/transform.h"

namespace caustica::client {

absl::StatusOr<v1::UpdateGeometryRequest> mesh_move_request(const MeshMoveOptions& o) {
  if (o.translate.empty() && o.rotate.empty() && o.scale.empty()) {
    return absl::InvalidArgumentError("give --translate, --rotate or --scale (or several)");
  }
  Vec3f parts[3] = {Vec3f(0.0f), Vec3f(0.0f), Vec3f(1.0f)};
  const std::tuple<const char*, const std::string*, bool> flags[] = {
      {"translate", &o.translate, false}, {"rotate", &o.rotate, false}, {"scale", &o.scale, true}};
  for (int i = 0; i < 3; ++i) {
    const auto& [flag, text, scalar] = flags[i];
    if (text->empty()) continue;
    absl::StatusOr<v1::Vec3> v = parse_vec3_flag(flag, *text, scalar);
    if (!v.ok()) return v.status();
    parts[i] = Vec3f(v->x(), v->y(), v->z());
  }
  const Vec3f &t = parts[0], &r = parts[1], &s = parts[2];
  if (s.x == 0 || s.y == 0 || s.z == 0) {
    return absl::InvalidArgumentError("--scale: must not be zero: it would flatten the mesh");
  }
  const Affine transform = placement(t, r, s);
  v1::UpdateGeometryRequest request;
  request.set_scene_id(o.scene);
  *request.add_meshes() = wire::encode_mesh_change({o.mesh, transform, std::nullopt, std::nullopt});
  if (o.expect_epoch) request.set_expected_geometry_epoch(*o.expect_epoch);
  return request;
}

absl::Status run_mesh_move(const GlobalOptions& global, const MeshMoveOptions& options,
                           std::ostream& out) {
  absl::StatusOr<v1::UpdateGeometryRequest> request = mesh_move_request(options);
  if (!request.ok()) return request.status();
  return send_update(global, options.scene, &v1::RenderService::Stub::UpdateGeometry, *request,
                     out);
}

absl::Status run_mesh_reshape(const GlobalOptions& global, const MeshReshapeOptions& o,
                              std::ostream& out) {
  absl::StatusOr<MeshFile> file = load_mesh_file(o.file);
  if (!file.ok()) return file.status();
  if (file->meshes.size() != 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--from: ", o.file.string(), " has ", file->meshes.size(),
        " meshes; the new vertices come from a file of one mesh, in the order the scene's has"));
  }
  Mesh& from = file->meshes[0];
  MeshChange change{o.mesh, std::nullopt, std::move(from.positions), std::nullopt};
  if (!from.normals.empty()) change.normals = std::move(from.normals);
  const std::vector<v1::GeometryChunk> chunks =
      geometry_chunks(o.scene, change, o.expect_epoch, wire::kMaxChunkBytes);
  absl::StatusOr<std::unique_ptr<Connection>> connection = Connection::open(global.connect);
  if (!connection.ok()) return connection.status();
  if (absl::Status pinned = (*connection)->pin_to_scene(o.scene); !pinned.ok()) return pinned;
  std::unique_ptr<grpc::ClientContext> context = (*connection)->new_context();
  v1::RebuildReport report;
  std::unique_ptr<grpc::ClientWriter<v1::GeometryChunk>> writer =
      (*connection)->stub().StreamGeometry(context.get(), &report);
  // A failed Write means the server already ended the call; Finish() says why.
  bool all_sent = true;
  for (const v1::GeometryChunk& chunk : chunks) {
    if (!(all_sent = writer->Write(chunk))) break;
  }
  if (all_sent) writer->WritesDone();
  if (absl::Status status = to_absl(writer->Finish()); !status.ok()) return status;
  print_rebuild(global, report, out);
  return absl::OkStatus();
}

}  // namespace caustica::client
