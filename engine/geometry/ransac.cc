#include "engine/geometry/ransac.h"

#include "engine/core/options.h"

namespace glam {

void RansacOptions::Check() const {
  CheckGreater("RansacOptions.max_iterations", max_iterations, 0);
  CheckInRange("RansacOptions.min_iterations", min_iterations, 0, max_iterations);
  CheckInRange("RansacOptions.confidence", confidence, 0.0, 1.0 - 1e-12);
  CheckGreater("RansacOptions.inlier_threshold", inlier_threshold, 0.0);
  CheckGreaterEqual("RansacOptions.min_inliers", min_inliers, 0);
}

int RansacIterationsNeeded(double inlier_ratio, int sample_size, double confidence,
                           int max_iterations) {
  if (!(inlier_ratio > 0.0)) return max_iterations;
  const double all_inlier = std::pow(std::min(inlier_ratio, 1.0), sample_size);
  if (all_inlier >= 1.0 - 1e-12) return 1;
  const double denom = std::log1p(-all_inlier);
  if (!(denom < 0.0)) return max_iterations;  // all_inlier underflowed
  const double n = std::ceil(std::log1p(-confidence) / denom);
  return n >= max_iterations ? max_iterations : std::max(1, static_cast<int>(n));
}

}  // namespace glam
