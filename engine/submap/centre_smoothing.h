// Camera-centre smoothing of a submap's frames (added to the paper; docs/algorithm.md).
//
// Why: a frame's PnP pose is exact up to the image noise, but looking down at gently rolling
// ground a sideways shift of the camera and a small tilt move the image almost alike; only
// the relief and the image edges tell them apart. Where features are noisy (compressed video:
// H.264 CRF 24, a typical re-encoded upload) that ambiguity makes consecutive frames' centres
// jump 0.2-0.3 m sideways at 100 m while the truth moves on a smooth path (measured: median
// second difference of the centres 0.21 m against the truth's 0.004 m). A drone's position at
// video rate is smooth (its acceleration is a few m/s^2: a few millimetres of second
// difference per frame at 30 fps), so each centre is replaced by a robust local quadratic fit
// over its neighbours within +-half_window_s, and the rotation is then re-solved with the
// centre fixed, so the pose still explains the frame's matches. Rotations are not smoothed:
// gimbals do jerk.
//
// Only runs of consecutive posed frames are smoothed (an unposed frame ends a run, and so does
// a jump no flight makes), and only where a window holds at least min_frames frames: photo
// sequences (one image per second or more) and strided videos at a few frames per second are
// left as they are.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "engine/core/se3.h"

namespace glam {

struct CentreSmoothingOptions {
  // Half width of the fit window in seconds; 0 = no smoothing (the paper).
  double half_window_s = 0.25;
  // Windows with fewer frames (including the centre frame) leave the centre as it is.
  int min_frames = 7;
  // Neighbours further than this many robust standard deviations from the first fit are
  // left out of the second (a wrong pose must not pull its neighbours).
  double outlier_sigmas = 3.0;
  // A step between consecutive centres longer than this many times the median step over
  // half a window before or after it (the larger) splits the run: measured on a stream
  // frozen for 3 s that then jumps 30 m, smoothing across the jump made the frames around it
  // 30 m wrong (ATE 0.09 -> 0.57 m).
  double jump_factor = 8.0;

  void Check() const;  // throws InputError
};

// Smoothed centres for one run of consecutive frames (times ascending, one centre each).
std::vector<Eigen::Vector3d> SmoothCentres(const std::vector<double>& times_s,
                                           const std::vector<Eigen::Vector3d>& centres,
                                           const CentreSmoothingOptions& options);

// The rotation of `cam_from_world` re-solved (Gauss-Newton on the normalised reprojection
// errors) with the camera centre held at `centre`; `normalized`: the observations' normalised
// image coordinates, `points`: their world points. Returns false (pose untouched) when it
// does not converge or too few points are in front of the camera.
bool SolveRotationWithCentre(const std::vector<Eigen::Vector2d>& normalized,
                             const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& centre,
                             SE3* cam_from_world);

}  // namespace glam
