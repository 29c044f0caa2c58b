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
  // The LBVH's top levels over the curve order, each subtree below a cut rebuilt by binned SAH
  // (Zeidan 2011, ch. 4), collapsed to 4-wide nodes.
  kHybrid = 2,
  // The binary tree lbvh4 collapses, kept binary in 32-byte nodes that store only the planes a
  // child does not inherit from its parent (Fabianowski 2011, ch. 6).
  kSiblingPair = 3,
  // A kd-tree built breadth-first (Zhou et al. 2008) with an exact SAH sweep per small node.
  kKdSah = 4,
  // The same kd-tree, its small nodes split by Fabianowski's scene-interior ray origin heuristic.
  kKdSiroh = 5,
  // No stored structure: every batch of rays divided with the triangles breadth-first over space
  // and brute-forced in small nodes (Ravichandran and Narayanan 2013); answers batches only.
  kDacrt = 6,
  // A compressed 8-wide BVH (Ylitie et al. 2017) over an H-PLOC tree (Benthin et al. 2024).
  kBvh8 = 7,
};

inline constexpr StructureKind kStructureKinds[] = {
    StructureKind::kLbvh4,       StructureKind::kBinnedSah, StructureKind::kHybrid,
    StructureKind::kSiblingPair, StructureKind::kKdSah,     StructureKind::kKdSiroh,
    StructureKind::kDacrt,       StructureKind::kBvh8};
inline constexpr StructureKind kDefaultStructure = StructureKind::kLbvh4;

// The name a user writes: "lbvh4", "binned-sah", "hybrid", "sibling-pair", "kd-sah", "kd-siroh",
// "dacrt", "bvh8".
constexpr const char* structure_kind_name(StructureKind kind) {
  switch (kind) {
    case StructureKind::kLbvh4:
      return "lbvh4";
    case StructureKind::kBinnedSah:
      return "binned-sah";
    case StructureKind::kHybrid:
      return "hybrid";
    case StructureKind::kSiblingPair:
      return "sibling-pair";
    case StructureKind::kKdSah:
      return "kd-sah";
    case StructureKind::kKdSiroh:
      return "kd-siroh";
    case StructureKind::kDacrt:
      return "dacrt";
    case StructureKind::kBvh8:
      return "bvh8";
  }
  return "unknown";
}

// Whether the structure answers batches of rays only (ray_queries.h), with no view that traces one
// ray at a time: what the path integrator needs.
constexpr bool answers_batches_only(StructureKind kind) { return kind == StructureKind::kDacrt; }

// Whether a geometry change may refit the structure (refit_structure, structure.h): its boxes
// recomputed from the moved triangles up, its topology kept. The 4-wide BVHs can; dacrt keeps
// nothing to refit, a kd-tree's planes cut space rather than bound triangles, and bvh8's and
// sibling-pair's boxes are stored relative to their parents' and are built anew.
constexpr bool refits(StructureKind kind) {
  return kind == StructureKind::kLbvh4 || kind == StructureKind::kBinnedSah ||
         kind == StructureKind::kHybrid;
}

inline std::optional<StructureKind> parse_structure_kind(std::string_view name) {
  for (StructureKind kind : kStructureKinds) {
    if (name == structure_kind_name(kind)) return kind;
  }
  return std::nullopt;
}

// The kinds ' names, comma-separated ("lbvh4, binned-sah, ..."): for error messages and --help.
inline std::string structure_kind_list() {
  std::string out;
  for (StructureKind kind : kStructureKinds) {
    if (!out.empty()) out += ", ";
    out += structure_kind_name(kind);
  }
  return out;
}

// "unknown structure 'NAME' (expected lbvh4, binned-sah, ...)", with `also_accepted` ("all, ")
// before the kinds where a tool takes more names.
inline std::string unknown_structure_message(std::string_view name,
                                             std::string_view also_accepted = "") {
  return "unknown structure '" + std::string(name) + "' (expected " + std::string(also_accepted) +
         structure_kind_list() + ")";
}

}  // namespace caustica
