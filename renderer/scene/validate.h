// The checks every scene passes before it reaches the renderer, whatever produced it (the JSON
// loader, the server's protocol decoder, a test): finite geometry, indices in range, physical
// colours, lights with positive size, a usable camera, sizes under scene_limits.h, and at least
// one triangle and one light.
#pragma once

#include "absl/status/status.h"
#include "renderer/scene/scene.h"

namespace caustica {

// InvalidArgumentError naming the first problem found: fields as the JSON format spells them
// (camera.fov, settings.photons, lights[2].intensity), materials by name, meshes by name with the
// vertex or triangle index.
absl::Status validate_scene(const Scene& scene);

}  // namespace caustica
