// A stored photon: where it landed, the flux it carries and the way it came (for the side test).
#pragma once

#include "renderer/base/vec.h"

namespace caustica {

struct Photon {
  Vec3f position;
  Vec3f power;     // flux in W per channel
  Vec3f incoming;  // unit direction back towards where the photon came from
};

}  // namespace caustica
