// A stored photon: where it landed, the flux it carries and the way it came (for the side test).
#pragma once

#include "renderer/base/vec.h"

namespace caustica {

struct Photon {
  Vec3f position;
  Vec3f power;     // flux in W per channel
  Vec3f incoming;  // unit direction back towards where the photon came from
};

// The area a stored photon stands for where it landed, spanned by two vectors in its surface's
// plane (its position differentials times their spacing, differentials.h): the parallelogram
// |span1 x span2| is the inverse of the photons' density there.
struct PhotonFootprint {
  Vec3f span1, span2;
};

}  // namespace caustica
