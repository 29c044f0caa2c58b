#include "renderer/scene/emitters.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace caustica {
namespace {

const char* type_name(MaterialType type) {
  switch (type) {
    case MaterialType::kDiffuse:
      return "diffuse";
    case MaterialType::kMirror:
      return "mirror";
    case MaterialType::kDielectric:
      return "dielectric";
    case MaterialType::kEmissive:
      return "emissive";
    case MaterialType::kMetallicRoughness:
      return "metallic_roughness";
    case MaterialType::kPhong:
      return "phong";
  }
  static_assert(kLastMaterialType == MaterialType::kPhong,
                "type_name names every material type: add the new one above");
  return "unknown";
}

}  // namespace

absl::StatusOr<std::vector<Material>> apply_emitter_changes(
    const std::vector<Material>& materials, const std::vector<EmitterChange>& changes) {
  std::vector<Material> out = materials;
  for (size_t i = 0; i < changes.size(); ++i) {
    const EmitterChange& change = changes[i];
    const std::string field = absl::StrCat("emitters[", i, "]");
    auto found = std::find_if(out.begin(), out.end(),
                              [&](const Material& m) { return m.name == change.material; });
    if (found == out.end()) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ".material: the scene has no material '", change.material, "'"));
    }
    if (!is_emitter(*found)) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ".material: '", change.material, "' is ", type_name(found->type),
                       " and emits nothing: only emitting materials are area lights"));
    }
    if (change.radiance) {
      const Vec3f r = *change.radiance;
      for (float c : {r.x, r.y, r.z}) {
        if (!std::isfinite(c) || c < 0) {
          return absl::InvalidArgumentError(
              absl::StrFormat("%s.radiance: (%g, %g, %g) is not finite and >= 0 in every channel",
                              field, r.x, r.y, r.z));
        }
      }
      // Another kind emits while its radiance is nonzero; `off` darkens it and keeps it a light.
      if (is_black(r) && found->type != MaterialType::kEmissive) {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ".radiance: (0, 0, 0) would make ", type_name(found->type),
                         " material '", change.material, "' no light; turn it off instead"));
      }
      found->radiance = r;
    }
    if (change.off) found->off = *change.off;
  }
  return out;
}

}  // namespace caustica
