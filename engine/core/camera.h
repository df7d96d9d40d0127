// Camera model shared by the tracker, bundle adjustment, the synthetic renderer and the
// evaluator; one definition so that a pixel means the same thing everywhere.
// Convention (OpenCV): x right, y down, z forward; pixel centres at integer coordinates, so
// the image covers [-0.5, width - 0.5) x [-0.5, height - 0.5).
// Pinhole with two radial coefficients (OpenCV's k1, k2):
//   x' = X/Z, y' = Y/Z, r^2 = x'^2 + y'^2, d = 1 + k1 r^2 + k2 r^4,
//   u = fx d x' + cx, v = fy d y' + cy.
// Eigen only: OpenCV stays out of engine/core headers to keep compile times low.
#pragma once

#include <string>

#include <Eigen/Core>

namespace glam {

// Mirrors intrinsics.json (see intrinsics_io.h). model "pinhole" means k1 = k2 = 0;
// "radial" allows k1, k2.
struct Intrinsics {
  std::string model = "pinhole";
  int width = 0;
  int height = 0;
  double fx = 0;
  double fy = 0;
  double cx = 0;
  double cy = 0;
  double k1 = 0;
  double k2 = 0;

  // Throws InputError naming the offending field (e.g. "intrinsics.fx must be > 0, got -1").
  void Check() const;
  // Sets k1, and the model to "radial" when k1 != 0 ("pinhole" allows no distortion; a radial
  // model stays radial, k2 may need it).
  void SetK1(double value);
  // These intrinsics at focal length `focal` (fx = focal, fy = focal x the aspect fy / fx):
  // how a keyframe's or a submap's refined focal becomes a camera.
  Intrinsics WithFocal(double focal) const;
};

class Camera {
 public:
  // Points closer than this in z are treated as behind the camera.
  static constexpr double kMinDepth = 1e-8;

  // Calls intrinsics.Check() (throws InputError).
  explicit Camera(const Intrinsics& intrinsics);

  const Intrinsics& intrinsics() const { return intrinsics_; }

  // Projects a point in the camera frame; returns false (pixel untouched) if z <= kMinDepth.
  bool Project(const Eigen::Vector3d& point_in_cam, Eigen::Vector2d* pixel) const;

  // d pixel / d point_in_cam (2x3). Requires z > kMinDepth.
  Eigen::Matrix<double, 2, 3> ProjectJacobian(const Eigen::Vector3d& point_in_cam) const;

  // Ray through a pixel as a point on the z = 1 plane. Distortion is inverted by Newton's
  // method on the radius (converges to machine precision inside the image for realistic
  // k1, k2, i.e. where r (1 + k1 r^2 + k2 r^4) is increasing).
  Eigen::Vector3d Unproject(const Eigen::Vector2d& pixel) const;

  // True if the pixel lies inside the image shrunk by margin pixels on every side.
  bool InImage(const Eigen::Vector2d& pixel, double margin = 0) const;

  // [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (ignores distortion).
  Eigen::Matrix3d K() const;

 private:
  Intrinsics intrinsics_;
};

}  // namespace glam
