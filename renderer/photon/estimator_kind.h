// The density estimators a pass can gather the photons with, named in the scene's settings
// (settings.estimator). A leaf header, as density_kernel.h is for the kernels; the estimators
// themselves sit behind the seam of estimator/estimator.h.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

namespace caustica {

// kKnn: the k nearest photons of fresh maps every pass, the passes averaged (knn_estimate.h).
// kSppm: stochastic progressive photon mapping (Hachisuka and Jensen 2009), one visible point per
// pixel and pass whose radius shrinks as photons arrive, so the image converges.
// kVkde: variable kernel density estimation (Fabianowski 2011), every photon's own anisotropic
// kernel from its photon differentials, gathered by point from a hierarchy over their supports.
enum class EstimatorKind : uint32_t { kKnn = 0, kSppm = 1, kVkde = 2 };
inline constexpr EstimatorKind kEstimatorKinds[] = {EstimatorKind::kKnn, EstimatorKind::kSppm,
                                                    EstimatorKind::kVkde};

constexpr const char* estimator_kind_name(EstimatorKind kind) {
  switch (kind) {
    case EstimatorKind::kSppm:
      return "sppm";
    case EstimatorKind::kVkde:
      return "vkde";
    case EstimatorKind::kKnn:
      break;
  }
  return "knn";
}

inline std::optional<EstimatorKind> parse_estimator_kind(std::string_view name) {
  for (EstimatorKind kind : kEstimatorKinds)
    if (name == estimator_kind_name(kind)) return kind;
  return std::nullopt;
}

// How SPPM's radii shrink: kPixel, Hachisuka and Jensen's rule from each pixel's photon count;
// kGlobal, Knaus and Zwicker's (2011) one sequence r_i^2 = r_1^2 prod (j + alpha) / (j + 1) for
// every pixel, each pass an independent estimate.
enum class SppmRadius : uint32_t { kPixel = 0, kGlobal = 1 };

}  // namespace caustica
