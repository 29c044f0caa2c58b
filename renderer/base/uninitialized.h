// Room for N values left unconstructed. An array of a type with default member initialisers (Aabb,
// Vec3f and what holds them) sets every entry when it is declared; where a loop uses only the
// first few, that is wasted work, and on a GPU local-memory traffic: zeroing a specular walk's
// pending branches wrote 2.9 KB per pixel, 3.2 GB a 1024x1024 pass.
#pragma once

#include "renderer/base/hd.h"

namespace caustica {

template <typename T, int N>
union Uninitialized {
  T item[N];
  CAUSTICA_HD Uninitialized() {}
};

}  // namespace caustica
