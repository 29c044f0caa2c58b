// Small fixed-size vectors used by every module on both backends.
#pragma once

#include <cmath>
#include <cstdint>

#include "renderer/base/hd.h"

namespace caustica {

using std::isfinite;

// min/max in one instruction on each backend. On x86 that is the compare form (minss/maxss),
// since fminf/fmaxf become library calls there (their NaN rules have no one-instruction form). On
// a GPU it is fminf/fmaxf: the compare form costs a compare and a select, which ptxas may not
// merge because the two differ when an argument is NaN. For numbers they agree exactly.
CAUSTICA_HDI float min_f(float a, float b) {
#if defined(__CUDA_ARCH__)
  return fminf(a, b);
#else
  return a < b ? a : b;
#endif
}
// The smaller of two counts, for device code, where std::min is host-only.
CAUSTICA_HDI uint32_t min_u32(uint32_t a, uint32_t b) { return a < b ? a : b; }
CAUSTICA_HDI float max_f(float a, float b) {
#if defined(__CUDA_ARCH__)
  return fmaxf(a, b);
#else
  return a > b ? a : b;
#endif
}

constexpr float kPi = 3.14159265358979323846f;
constexpr float kInvPi = 0.31830988618379067154f;

struct Vec2f {
  float x = 0, y = 0;
};

struct Vec4f {
  float x = 0, y = 0, z = 0, w = 0;
};

struct Vec3f {
  float x = 0, y = 0, z = 0;

  CAUSTICA_HD constexpr Vec3f() = default;
  CAUSTICA_HD constexpr Vec3f(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
  CAUSTICA_HD constexpr explicit Vec3f(float s) : x(s), y(s), z(s) {}

  // Reading by selects, not (&x)[i]: an index known only at run time (the watertight triangle
  // test's axis permutation) would otherwise force the vector into local memory on a GPU. Keep
  // const vectors where an index varies, so that this overload is the one called.
  CAUSTICA_HDI float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  CAUSTICA_HDI float& operator[](int i) { return (&x)[i]; }
  CAUSTICA_HDI Vec3f operator-() const { return {-x, -y, -z}; }
  CAUSTICA_HDI Vec3f& operator+=(const Vec3f& o) {
    x += o.x;
    y += o.y;
    z += o.z;
    return *this;
  }
  CAUSTICA_HDI Vec3f& operator*=(const Vec3f& o) {
    x *= o.x;
    y *= o.y;
    z *= o.z;
    return *this;
  }
  CAUSTICA_HDI Vec3f& operator*=(float s) {
    x *= s;
    y *= s;
    z *= s;
    return *this;
  }
  CAUSTICA_HDI bool operator==(const Vec3f& o) const { return x == o.x && y == o.y && z == o.z; }
};

CAUSTICA_HDI Vec3f operator+(Vec3f a, Vec3f b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
CAUSTICA_HDI Vec3f operator-(Vec3f a, Vec3f b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
CAUSTICA_HDI Vec3f operator*(Vec3f a, Vec3f b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
CAUSTICA_HDI Vec3f operator/(Vec3f a, Vec3f b) { return {a.x / b.x, a.y / b.y, a.z / b.z}; }
CAUSTICA_HDI Vec3f operator*(Vec3f a, float s) { return {a.x * s, a.y * s, a.z * s}; }
CAUSTICA_HDI Vec3f operator*(float s, Vec3f a) { return {a.x * s, a.y * s, a.z * s}; }
CAUSTICA_HDI Vec3f operator/(Vec3f a, float s) { return a * (1.0f / s); }

// Two fused multiply-adds, written out: the build turns off FMA contraction (for the watertight
// triangle test), so a plain a.x * b.x + ... took five instructions, and dot products were 13% of
// the gather's (every photon's distance, every node's box distance, every side test). fmaf rounds
// the same on both backends.
CAUSTICA_HDI float dot(Vec3f a, Vec3f b) { return fmaf(a.z, b.z, fmaf(a.y, b.y, a.x * b.x)); }
CAUSTICA_HDI Vec3f cross(Vec3f a, Vec3f b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
CAUSTICA_HDI float length_squared(Vec3f a) { return dot(a, a); }
CAUSTICA_HDI float length(Vec3f a) { return sqrtf(dot(a, a)); }
CAUSTICA_HDI Vec3f normalize(Vec3f a) { return a * (1.0f / length(a)); }
CAUSTICA_HDI Vec3f min(Vec3f a, Vec3f b) {
  return {min_f(a.x, b.x), min_f(a.y, b.y), min_f(a.z, b.z)};
}
CAUSTICA_HDI Vec3f max(Vec3f a, Vec3f b) {
  return {max_f(a.x, b.x), max_f(a.y, b.y), max_f(a.z, b.z)};
}
CAUSTICA_HDI Vec3f abs(Vec3f a) { return {fabsf(a.x), fabsf(a.y), fabsf(a.z)}; }
CAUSTICA_HDI float max_component(Vec3f a) { return max_f(a.x, max_f(a.y, a.z)); }
CAUSTICA_HDI float average(Vec3f a) { return (a.x + a.y + a.z) * (1.0f / 3.0f); }
CAUSTICA_HDI int max_dimension(Vec3f a) {
  return (a.x > a.y) ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
}
CAUSTICA_HDI bool is_finite(Vec3f a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }
CAUSTICA_HDI bool is_black(Vec3f a) { return a.x == 0 && a.y == 0 && a.z == 0; }
// Mirror direction of `d` (pointing towards the surface) about normal `n`.
CAUSTICA_HDI Vec3f reflect(Vec3f d, Vec3f n) { return d - n * (2.0f * dot(d, n)); }

}  // namespace caustica
