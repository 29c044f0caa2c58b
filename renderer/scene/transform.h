// Meshes and lights moved by an affine map (affine.h): JSON "transform" objects and glTF node
// hierarchies.
#pragma once

#include "renderer/scene/affine.h"
#include "renderer/scene/scene.h"

namespace caustica {

// Moves positions and normals; a mirroring map also flips the winding, so that geometric normals
// keep pointing out of the surface.
void transform_mesh(const Affine& transform, Mesh* mesh);
// Moves a light's position and turns its direction (renormalised).
void transform_light(const Affine& transform, Light* light);

}  // namespace caustica
