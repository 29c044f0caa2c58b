#include "renderer/estimator/estimator.h"

#include "renderer/estimator/knn_estimator.h"
#include "renderer/estimator/sppm_estimator.h"
#include "renderer/estimator/vkde_estimator.h"

namespace caustica {

std::unique_ptr<Estimator> make_estimator(Backend& backend, const EstimatorOptions& options) {
  switch (options.kind) {
    case EstimatorKind::kSppm:
      return std::make_unique<SppmEstimator>(backend, options);
    case EstimatorKind::kVkde:
      return std::make_unique<VkdeEstimator>(options);
    case EstimatorKind::kKnn:
      break;
  }
  return std::make_unique<KnnEstimator>(options);
}

}  // namespace caustica
