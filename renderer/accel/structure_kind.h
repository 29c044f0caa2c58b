// The names of the ray-tracing structures a scene may choose (accel/structure.h builds them).
// Header-only and free of dependencies, so the scene model can carry the choice as a setting
// without depending on the structures themselves.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace caustica {

enum class StructureKind : uint32_t {
  // The binary LBVH over the triangles' curve order, its small subtrees rebuilt by binned SAH,
  // collapsed to 4-wide nodes.
  kLbvh4 = 0,
  // A binned SAH BVH built breadth-first from the root (Zeidan 2011, ch. 4), collapsed to 4-wide
  // nodes.
  kBinnedSah = 1,
  // A kd-tree built breadth-first (Zhou et al. 2008) with an exact SAH sweep per small node.
  kKdSah = 4,
  // The same kd-tree, its small nodes split by Fabianowski's scene-interior ray origin heuristic.
  kKdSiroh = 5,
};

inline constexpr StructureKind kStructureKinds[] = {StructureKind::kLbvh4,
                                                    StructureKind::kBinnedSah,
                                                    StructureKind::kKdSah, StructureKind::kKdSiroh};
inline constexpr StructureKind kDefaultStructure = StructureKind::kLbvh4;

// The name a user writes: "lbvh4", "binned-sah", "kd-sah", "kd-siroh".
constexpr const char* structure_kind_name(StructureKind kind) {
  switch (kind) {
    case StructureKind::kLbvh4:
      return "lbvh4";
    case StructureKind::kBinnedSah:
      return "binned-sah";
    case StructureKind::kKdSah:
      return "kd-sah";
    case StructureKind::kKdSiroh:
      return "kd-siroh";
  }
  return "unknown";
}

inline std::optional<StructureKind> parse_structure_kind(std::string_view name) {
  for (StructureKind kind : kStructureKinds) {
    if (name == structure_kind_name(kind)) return kind;
  }
  return std::nullopt;
}

// "lbvh4, binned-sah, kd-sah, kd-siroh": for error messages and --help.
inline std::string structure_kind_list() {
  std::string out;
  for (StructureKind kind : kStructureKinds) {
    if (!out.empty()) out += ", ";
    out += structure_kind_name(kind);
  }
  return out;
}

// "unknown structure 'NAME' (expected lbvh4, binned-sah)", with `also_accepted` ("all, ") before
// the kinds where a tool takes more names.
inline std::string unknown_structure_message(std::string_view name,
                                             std::string_view also_accepted = "") {
  return "unknown structure '" + std::string(name) + "' (expected " + std::string(also_accepted) +
         structure_kind_list() + ")";
}

}  // namespace caustica
