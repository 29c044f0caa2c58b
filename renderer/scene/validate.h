// The checks every scene passes before it reaches the renderer, whatever produced it (the JSON
// loader, the server's protocol decoder, a test): finite geometry, indices in range, physical
// colours, lights with positive size, a usable camera, sizes under scene_limits.h, and at least
// one triangle and one light.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "renderer/scene/scene.h"

namespace caustica {

// InvalidArgumentError naming the first problem found: fields as the JSON format spells them
// (camera.fov, settings.photons, lights[2].intensity), materials by name, meshes by name with the
// vertex or triangle index.
absl::Status validate_scene(const Scene& scene);

// The parts of validate_scene an update of an already valid scene needs, so that changing the
// lights or the camera does not copy the meshes to check them again.
absl::Status validate_camera(const Camera& camera);
absl::Status validate_settings(const RenderSettings& settings);
// `emitting_triangles`: the scene's area-light triangles, which count as light too, as does an
// environment.
absl::Status validate_lights(const std::vector<Light>& lights, size_t emitting_triangles,
                             bool environment = false);
// The environment (its map an index under `textures`), and a change to it.
absl::Status validate_environment(const Environment& environment, size_t textures);
absl::Status validate_environment_change(const EnvironmentChange& change);
// The scene's triangle count, all meshes together, against kMaxSceneTriangles: on its own so that
// a count can be checked before the triangles exist (and tested without allocating them).
absl::Status validate_triangle_total(size_t triangles);
// One vertex tangent (Mesh::tangents): finite, its w the bitangent's sign, 1 or -1. The message
// names the value and the problem; the caller names the vertex.
absl::Status check_tangent(const Vec4f& tangent);

// OK when `mesh` is closed, as one that encloses a medium must be: every edge, its ends compared
// by position, borders exactly two triangles running along it in opposite directions. Else
// INVALID_ARGUMENT naming `field`, the medium and the first edge that is not.
absl::Status check_closed(const Mesh& mesh, const std::string& field, const std::string& medium);

}  // namespace caustica
