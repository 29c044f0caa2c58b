// The Trowbridge-Reitz (GGX) distribution of microfacet normals, isotropic, with Smith's
// height-correlated masking-shadowing (Heitz 2014, "Understanding the Masking-Shadowing Function")
// and sampling of the normals a direction sees (Heitz 2018, "Sampling the GGX Distribution of
// Visible Normals"). Directions are in the shading frame, the macro normal along +z.
#pragma once

#include "renderer/base/sampling.h"
#include "renderer/material/bsdf.h"

namespace caustica {

// Below this alpha a surface is treated as smooth by the models that have a smooth special case;
// the distribution itself stays finite down to it.
constexpr float kMinMicrofacetAlpha = 1e-4f;

struct TrowbridgeReitz {
  float alpha;  // glTF's roughness squared

  // Microfacet normals per unit solid angle per unit macro-surface area: the integral of
  // D(wm) cos(wm) over the hemisphere is one.
  // The denominator's cos^2 a^2 + sin^2 (cos^2 (1 + tan^2 / a^2) a^2) is summed as two positive
  // terms: written cos^2 (a^2 - 1) + 1 it cancels to 0 near the normal for a small alpha, and D
  // became infinite (a path's weight then NaN) on the smoothest metal of a roughness map.
  CAUSTICA_HDI float D(Vec3f wm) const {
    const float cos2 = wm.z * wm.z;
    if (!(cos2 > 0.0f)) return 0.0f;
    const float a2 = alpha * alpha;
    const float t = cos2 * a2 + max_f(0.0f, 1.0f - cos2);
    return a2 / (kPi * t * t);
  }

  // Smith's auxiliary function: the masked microfacet area per visible area, minus nothing.
  CAUSTICA_HDI float lambda(Vec3f w) const {
    const float cos2 = w.z * w.z;
    if (!(cos2 > 0.0f)) return 0.0f;
    const float tan2 = max_f(0.0f, 1.0f - cos2) / cos2;
    return 0.5f * (sqrtf(1.0f + alpha * alpha * tan2) - 1.0f);
  }
  // The share of microfacets facing `w` that `w` sees.
  CAUSTICA_HDI float G1(Vec3f w) const { return 1.0f / (1.0f + lambda(w)); }
  // The share seen from both directions, their heights correlated.
  CAUSTICA_HDI float G(Vec3f wo, Vec3f wi) const { return 1.0f / (1.0f + lambda(wo) + lambda(wi)); }

  // The density of the normals `w` sees, over solid angle: D_w(wm) = G1(w) max(0, w.wm) D(wm) /
  // cos(w).
  CAUSTICA_HDI float visible_D(Vec3f w, Vec3f wm) const {
    const float c = abs_cos_theta(w);
    if (!(c > 0.0f)) return 0.0f;
    return G1(w) * max_f(0.0f, dot(w, wm)) * D(wm) / c;
  }

  // A normal drawn from visible_D(w, .) for `w` in the upper hemisphere: the visible projected
  // hemisphere of the stretched (alpha 1) configuration, sampled uniformly and unstretched.
  CAUSTICA_HDI Vec3f sample_visible_normal(Vec3f w, float u0, float u1) const {
    const Vec3f stretched = normalize(Vec3f(alpha * w.x, alpha * w.y, w.z));
    // A basis around the stretched direction, its first axis horizontal.
    const float horizontal = stretched.x * stretched.x + stretched.y * stretched.y;
    const Vec3f t1 = horizontal > 1e-12f
                         ? Vec3f(-stretched.y, stretched.x, 0.0f) * (1.0f / sqrtf(horizontal))
                         : Vec3f(1.0f, 0.0f, 0.0f);
    const Vec3f t2 = cross(stretched, t1);
    // A point on the unit disk, its second coordinate squeezed onto the part of the disk that
    // projects the hemisphere's visible half.
    const Vec2f p = sample_uniform_disk(u0, u1);
    const float h = sqrtf(max_f(0.0f, 1.0f - p.x * p.x));
    const float s = 0.5f * (1.0f + stretched.z);
    const float py = (1.0f - s) * h + s * p.y;
    const float pz = sqrtf(max_f(0.0f, 1.0f - p.x * p.x - py * py));
    const Vec3f n = t1 * p.x + t2 * py + stretched * pz;
    return normalize(Vec3f(alpha * n.x, alpha * n.y, max_f(1e-6f, n.z)));
  }

  // The density over solid angle of the reflection of `wo` about a normal drawn from visible_D:
  // D_wo(wm) / (4 wo.wm), with wm the half vector of wo and wi.
  CAUSTICA_HDI float reflection_pdf(Vec3f wo, Vec3f wi) const {
    if (!same_hemisphere(wo, wi) || wo.z <= 0.0f) return 0.0f;
    const Vec3f h = wo + wi;
    if (!(length_squared(h) > 0.0f)) return 0.0f;
    const Vec3f wm = normalize(h);
    const float o_dot_m = dot(wo, wm);
    if (!(o_dot_m > 0.0f)) return 0.0f;
    return visible_D(wo, wm) / (4.0f * o_dot_m);
  }
};

}  // namespace caustica
