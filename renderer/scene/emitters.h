// Area lights changed after load: UpdateLights' emitter changes applied to a scene's materials.
#pragma once

#include <vector>

#include "absl/status/statusor.h"
#include "renderer/scene/scene.h"

namespace caustica {

// `materials` with `changes` applied in order. INVALID_ARGUMENT naming `emitters[i]` when a
// change names no material of the scene or one that is not emissive, or gives a radiance that is
// not finite and >= 0 in every channel. Nothing is applied unless every change is valid.
absl::StatusOr<std::vector<Material>> apply_emitter_changes(
    const std::vector<Material>& materials, const std::vector<EmitterChange>& changes);

}  // namespace caustica
