// Meshes and lights moved by an affine map (affine.h), and the scene format's placements.
#pragma once

#include "renderer/scene/affine.h"
#include "renderer/scene/scene.h"

namespace caustica {

// Moves positions and normals; a mirroring map also flips the winding, so that geometric normals
// keep pointing out of the surface.
void transform_mesh(const Affine& transform, Mesh* mesh);
// Moves a light's position and turns its direction (renormalised).
void transform_light(const Affine& transform, Light* light);

// A placement in the scene format's order (docs/scene-format.md, "Mesh"): scale, then rotate
// about x, y and z (degrees, in that order), then translate.
Affine placement(Vec3f translate, Vec3f rotate_deg, Vec3f scale);

}  // namespace caustica
