#include "engine/core/similarity_alignment.h"

#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <fmt/format.h>

#include "engine/core/error.h"

namespace glam {

SimilarityAlignmentResult AlignSimilarity(const std::vector<Eigen::Vector3d>& source,
                                          const std::vector<Eigen::Vector3d>& target,
                                          bool estimate_scale) {
  if (source.size() != target.size()) {
    throw InputError(fmt::format("AlignSimilarity: {} source points but {} target points",
                                 source.size(), target.size()));
  }
  if (source.size() < 3) {
    throw InputError(
        fmt::format("AlignSimilarity: need at least 3 point pairs, got {}", source.size()));
  }
  const Eigen::Index n = static_cast<Eigen::Index>(source.size());
  Eigen::Matrix3Xd src(3, n);
  Eigen::Matrix3Xd dst(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    src.col(i) = source[static_cast<size_t>(i)];
    dst.col(i) = target[static_cast<size_t>(i)];
  }
  if (!src.allFinite() || !dst.allFinite()) {
    throw InputError("AlignSimilarity: non-finite point coordinates");
  }
  // The rotation is determined only if the centred source spans at least a plane.
  const Eigen::Matrix3Xd centred = src.colwise() - src.rowwise().mean();
  const Eigen::Vector3d sv = Eigen::JacobiSVD<Eigen::Matrix3Xd>(centred).singularValues();
  if (!(sv(1) > 1e-9 * sv(0))) {
    throw InputError("AlignSimilarity: source points are coincident or collinear");
  }
  const Eigen::Matrix4d m = Eigen::umeyama(src, dst, estimate_scale);
  // With scale estimation, coincident target points give scale 0 (no similarity exists).
  if (!(m.topLeftCorner<3, 3>().determinant() > 0) || !m.allFinite()) {
    throw InputError("AlignSimilarity: target points are coincident (scale 0)");
  }
  SimilarityAlignmentResult result;
  result.target_from_source = Sim3::FromMatrix(m);
  double sum2 = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    sum2 += (result.target_from_source * Eigen::Vector3d(src.col(i)) - dst.col(i)).squaredNorm();
  }
  result.rmse = std::sqrt(sum2 / static_cast<double>(n));
  return result;
}

}  // namespace glam
