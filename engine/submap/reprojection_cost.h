// The pixel residual of bundle adjustment with hand-written Jacobians. Bundle adjustment is the
// submap builder's largest cost; with ceres::AutoDiffCostFunction (11-dimensional jets) the
// Jacobian evaluation of a 20-keyframe, 4100-landmark submap took 29 ms per iteration here,
// with these Jacobians 11 ms, and the loop benchmark video's bundle adjustments 9.4 s instead
// of 17.4 s in all (docs/benchmarks.md). The pose is one 7-number block so that one manifold
// covers it (and Ceres could use its fixed-size <2,3,6> Schur eliminator; it does not while the
// scale-fixed second keyframe, tangent size 5, is in the problem, which was measured to cost
// only ~20 % of the linear solver time, not worth a softer gauge).
//
// Parameter blocks, in order:
//   cam_from_submap  7: Eigen quaternion storage (x, y, z, w), then translation (x, y, z);
//                       use NewPoseManifold() (quaternion x Euclidean) for it
//   focal            1: fx in pixels (fy = fx * aspect of the camera)
//   k1               1: first radial distortion coefficient (shared by all keyframes; held
//                       constant by the caller when it is not estimated)
//   point_in_submap  3
// The rotation is applied as Eigen's quaternion-vector product, which assumes a unit
// quaternion; the Jacobian is that of the same formula, so it is exact for any quaternion the
// manifold produces. Principal point and k2 are constants of the camera: too weakly observed
// inside one submap to refine (k1 alone is what COLMAP's SIMPLE_RADIAL model refines too).
#pragma once

#include <ceres/manifold.h>
#include <ceres/sized_cost_function.h>
#include <Eigen/Core>

#include "engine/core/camera.h"

namespace glam {

class ReprojectionCostFunction final : public ceres::SizedCostFunction<2, 7, 1, 1, 3> {
 public:
  // Residual of a point behind (or on) the camera plane, with zero Jacobians: large but finite,
  // so the solver turns back instead of failing.
  static constexpr double kBehindCameraResidual = 1e3;

  // `intrinsics` supplies cx, cy, k2 and the aspect ratio; focal and k1 are parameters.
  ReprojectionCostFunction(const Eigen::Vector2d& observed_pixel, const Intrinsics& intrinsics);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector2d observed_;
  double cx_, cy_, k2_, aspect_;
};

// Quaternion (Eigen order) x R^3 for the 7-dimensional pose block. scale_axis = 0, 1 or 2
// holds that translation coordinate fixed (the monocular scale gauge); -1 = none.
ceres::Manifold* NewPoseManifold(int scale_axis = -1);

}  // namespace glam
