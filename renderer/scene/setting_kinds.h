// The settings that choose one of several kinds (settings.integrator, settings.estimator,
// settings.sppm_radius, settings.kernel): each enum with one table from which the scene reader,
// validation, the wire and the command-line tools take its names and numbers. A leaf header, so
// that the scene model names its choices without reaching into the code that implements them;
// the ray-tracing structures have their own table in accel/structure_kind.h. Adding a kind means a
// row here and a value in the proto (scene_wire.cc checks that the two agree).
#pragma once

#include <cstddef>
#include <cstdint>
#include <iterator>
#include <optional>
#include <string>
#include <string_view>

namespace caustica {

// One kind of a setting: its enum value, the name a user writes (scene files, the CLI, messages)
// and its number in the proto's enum, whose 0 means "unset: keep the current kind".
template <typename Enum>
struct SettingKind {
  Enum value;
  const char* name;
  uint32_t wire;
};

// Each enum's table (`kinds`), and what a kind of it is called in messages (`what`, as in
// "unknown estimator 'x'").
template <typename Enum>
struct SettingKinds;

// How a pass estimates the light reaching the camera: kPhoton, camera rays through their specular
// chains to diffuse hits gathered from the photon maps (render/whitted.h), or kPath, unbiased path
// tracing with next-event estimation (render/path_tracer.h), the reference the photon mapper is
// checked against.
enum class Integrator : uint32_t { kPhoton = 0, kPath = 1 };
template <>
struct SettingKinds<Integrator> {
  static constexpr const char* what = "integrator";
  static constexpr SettingKind<Integrator> kinds[] = {{Integrator::kPhoton, "photon", 1},
                                                      {Integrator::kPath, "path", 2}};
};

// The density estimators a pass can gather the photons with; the estimators themselves sit
// behind the seam of estimator/estimator.h.
// kKnn: the k nearest photons of fresh maps every pass, the passes averaged (knn_estimate.h).
// kSppm: stochastic progressive photon mapping (Hachisuka and Jensen 2009), one visible point per
// pixel and pass whose radius shrinks as photons arrive, so the image converges.
// kVkde: variable kernel density estimation (Fabianowski 2011), every photon's own anisotropic
// kernel from its photon differentials, gathered by point from a hierarchy over their supports.
enum class EstimatorKind : uint32_t { kKnn = 0, kSppm = 1, kVkde = 2 };
template <>
struct SettingKinds<EstimatorKind> {
  static constexpr const char* what = "estimator";
  static constexpr SettingKind<EstimatorKind> kinds[] = {{EstimatorKind::kKnn, "knn", 1},
                                                         {EstimatorKind::kSppm, "sppm", 2},
                                                         {EstimatorKind::kVkde, "vkde", 3}};
};
inline constexpr auto& kEstimatorKinds = SettingKinds<EstimatorKind>::kinds;

// How SPPM's radii shrink: kPixel, Hachisuka and Jensen's rule from each pixel's photon count;
// kGlobal, Knaus and Zwicker's (2011) one sequence r_i^2 = r_1^2 prod (j + alpha) / (j + 1) for
// every pixel, each pass an independent estimate.
enum class SppmRadius : uint32_t { kPixel = 0, kGlobal = 1 };
template <>
struct SettingKinds<SppmRadius> {
  static constexpr const char* what = "radius rule";
  static constexpr SettingKind<SppmRadius> kinds[] = {{SppmRadius::kPixel, "pixel", 1},
                                                      {SppmRadius::kGlobal, "global", 2}};
};

// The density kernels that weigh a photon by its distance (photon/density_kernel.h has their
// weights).
enum class DensityKernel : uint32_t { kUniform = 0, kCone = 1, kEpanechnikov = 2 };
template <>
struct SettingKinds<DensityKernel> {
  static constexpr const char* what = "kernel";
  static constexpr SettingKind<DensityKernel> kinds[] = {
      {DensityKernel::kUniform, "uniform", 1},
      {DensityKernel::kCone, "cone", 2},
      {DensityKernel::kEpanechnikov, "epanechnikov", 3}};
};

// The row of `value`; null for a value outside the table (a number cast from bad input).
template <typename Enum>
constexpr const SettingKind<Enum>* find_setting_kind(Enum value) {
  for (const SettingKind<Enum>& kind : SettingKinds<Enum>::kinds)
    if (kind.value == value) return &kind;
  return nullptr;
}

template <typename Enum>
constexpr bool is_known_kind(Enum value) {
  return find_setting_kind(value) != nullptr;
}

// The name of `value`, "unknown" outside the table.
template <typename Enum>
constexpr const char* kind_name(Enum value) {
  const SettingKind<Enum>* kind = find_setting_kind(value);
  return kind != nullptr ? kind->name : "unknown";
}

template <typename Enum>
std::optional<Enum> parse_kind(std::string_view name) {
  for (const SettingKind<Enum>& kind : SettingKinds<Enum>::kinds)
    if (name == kind.name) return kind.value;
  return std::nullopt;
}

// The proto's number of `value` (0, "unset", outside the table).
template <typename Enum>
constexpr uint32_t kind_wire(Enum value) {
  const SettingKind<Enum>* kind = find_setting_kind(value);
  return kind != nullptr ? kind->wire : 0;
}

// The kind of a proto number; nullopt for 0 ("unset") and for numbers of no kind.
template <typename Enum>
constexpr std::optional<Enum> kind_from_wire(uint32_t wire) {
  for (const SettingKind<Enum>& kind : SettingKinds<Enum>::kinds)
    if (wire != 0 && kind.wire == wire) return kind.value;
  return std::nullopt;
}

// The names for a refusal or --help: "knn, sppm or vkde".
template <typename Enum>
std::string kind_names() {
  const auto& kinds = SettingKinds<Enum>::kinds;
  std::string out;
  for (size_t i = 0; i < std::size(kinds); ++i) {
    out += i == 0 ? "" : i + 1 == std::size(kinds) ? " or " : ", ";
    out += kinds[i].name;
  }
  return out;
}

// "unknown estimator 'x' (expected knn, sppm or vkde)".
template <typename Enum>
std::string unknown_kind_message(std::string_view name) {
  return "unknown " + std::string(SettingKinds<Enum>::what) + " '" + std::string(name) +
         "' (expected " + kind_names<Enum>() + ")";
}

// Whether the proto numbers of `Enum`'s table are 1, 2, ... in the table's order, and so cover an
// enum of `proto_values` values (the proto's ARRAYSIZE, its 0 included) exactly.
template <typename Enum>
constexpr bool kinds_match_proto(size_t proto_values) {
  const auto& kinds = SettingKinds<Enum>::kinds;
  if (std::size(kinds) + 1 != proto_values) return false;
  for (size_t i = 0; i < std::size(kinds); ++i)
    if (kinds[i].wire != i + 1) return false;
  return true;
}

}  // namespace caustica
