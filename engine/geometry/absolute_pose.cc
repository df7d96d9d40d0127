#include "engine/geometry/absolute_pose.h"

#include <limits>

#include <Eigen/Cholesky>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "engine/core/error.h"

namespace glam {
namespace {

void ToCv(std::span<const PnPCorrespondence> data, std::vector<cv::Point3d>* object,
          std::vector<cv::Point2d>* image) {
  object->reserve(data.size());
  image->reserve(data.size());
  for (const auto& d : data) {
    object->emplace_back(d.point.x(), d.point.y(), d.point.z());
    image->emplace_back(d.normalized.x(), d.normalized.y());
  }
}

SE3 FromRvecTvec(const cv::Vec3d& rvec, const cv::Vec3d& tvec) {
  return SE3(SO3::Exp(Eigen::Vector3d(rvec[0], rvec[1], rvec[2])),
             Eigen::Vector3d(tvec[0], tvec[1], tvec[2]));
}

const cv::Matx33d kIdentityK = cv::Matx33d::eye();

}  // namespace

std::vector<SE3> AbsolutePoseEstimator::Fit(std::span<const Datum> sample) const {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  ToCv(sample, &object, &image);
  cv::Vec3d rvec, tvec;
  bool ok = false;
  try {
    ok = cv::solvePnP(object, image, kIdentityK, cv::noArray(), rvec, tvec, false,
                      cv::SOLVEPNP_EPNP);
  } catch (const cv::Exception&) {
    return {};  // degenerate sample (e.g. collinear points)
  }
  if (!ok || !cv::checkRange(rvec) || !cv::checkRange(tvec)) return {};
  return {FromRvecTvec(rvec, tvec)};
}

double AbsolutePoseEstimator::Residual(const SE3& cam_from_world, const Datum& datum) const {
  const Eigen::Vector3d p = cam_from_world * datum.point;
  if (p.z() <= Camera::kMinDepth) return std::numeric_limits<double>::infinity();
  return focal_px_ * (p.head<2>() / p.z() - datum.normalized).norm();
}

bool AbsolutePoseEstimator::Refine(std::span<const Datum> inliers, SE3* cam_from_world) const {
  // Gauss-Newton on the normalised reprojection errors with left updates T <- Exp(d) T,
  // d = [upsilon, omega]: d(T X)/dd = [I, -Hat(T X)]. (cv::solvePnPRefineLM gave the same
  // poses but cost ~20 ms for 800 points; this costs well under 1 ms.)
  if (inliers.size() < 4) return false;
  SE3 pose = *cam_from_world;
  for (int it = 0; it < 10; ++it) {
    Matrix6d H = Matrix6d::Zero();
    Vector6d g = Vector6d::Zero();
    for (const auto& d : inliers) {
      const Eigen::Vector3d p = pose * d.point;
      if (p.z() <= Camera::kMinDepth) continue;
      const double iz = 1.0 / p.z();
      const Eigen::Vector2d r = p.head<2>() * iz - d.normalized;
      Eigen::Matrix<double, 2, 3> dproj;
      dproj << iz, 0, -p.x() * iz * iz, 0, iz, -p.y() * iz * iz;
      Eigen::Matrix<double, 2, 6> J;
      J.leftCols<3>() = dproj;
      J.rightCols<3>() = -dproj * Hat(p);
      H.noalias() += J.transpose() * J;
      g.noalias() += J.transpose() * r;
    }
    const Eigen::LDLT<Matrix6d> ldlt(H);
    if (ldlt.info() != Eigen::Success) return false;
    const Vector6d step = -ldlt.solve(g);
    if (!step.allFinite()) return false;
    pose = SE3::Exp(step) * pose;
    if (step.norm() < 1e-10) break;
  }
  *cam_from_world = pose;
  return true;
}

RansacResult<SE3> EstimateAbsolutePose(const std::vector<Eigen::Vector2d>& pixels,
                                       const std::vector<Eigen::Vector3d>& points,
                                       const Camera& camera, const RansacOptions& options) {
  GLAM_CHECK(pixels.size() == points.size(), "{} pixels vs {} points", pixels.size(), points.size());
  std::vector<PnPCorrespondence> data(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) {
    data[i].normalized = camera.Unproject(pixels[i]).head<2>();
    data[i].point = points[i];
  }
  const double focal = 0.5 * (camera.intrinsics().fx + camera.intrinsics().fy);
  return Ransac(AbsolutePoseEstimator(focal), std::span<const PnPCorrespondence>(data), options);
}

}  // namespace glam
