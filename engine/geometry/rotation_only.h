// Does a pure rotation explain two views? A drone that hovers and yaws gives image pairs
// without any baseline, and on those the essential matrix is degenerate: E = [t]x R holds for
// every t when x2 ~ R x1, and a rotation off by a small angle theta together with a
// translation along its axis still explains the flow to second order (theta^2 x focal: 0.7 px
// at 2 degrees and 554 px), inside any RANSAC threshold. Triangulating with such a motion
// invents parallax: measured on a 640x360 flight 45 degrees from nadir hovering through a
// 180-degree yaw, a bootstrap accepted two frames of the hover at a 2.1-degree median angle and
// built a submap 2.7 m wrong. Comparing with the rotation-only model tells the two apart: all a
// rotation leaves of a hover pair is the matching noise (~0.5 px), while a real baseline at a
// bootstrap's 2-6 degrees leaves 1-5 px of structured residual (depth and perspective) that no
// rotation absorbs; a small nadir step over low relief is the closest case.
//
// The model x2 ~ K R K^-1 x1 also fits a focal scale s (true focal = s x the focal the rays
// were normalised with), since a focal that is still being estimated would otherwise make a
// pure rotation look like something else (rotation by theta with the focal off by df/f moves
// an image corner by ~theta x r^2 x df/f).
#pragma once

#include <span>

#include "engine/core/so3.h"
#include "engine/geometry/essential.h"

namespace glam {

struct RotationOnlyOptions {
  // A correspondence is explained within this (pixels): about twice the matching noise, well
  // below the structured residual a baseline leaves (1-5 px at 2-6 deg of parallax).
  double inlier_threshold_px = 1.0;
  // Residuals are truncated here while fitting: wide enough that the closed-form start (focal
  // scale 1) reaches the points even when the focal is a few percent off on a large rotation.
  double fit_gate_px = 9.0;
  int iterations = 10;               // Levenberg-Marquardt steps after the closed-form start
  // The focal scale's range: a focal still being estimated is within it; a free scale runs
  // off to a long lens, under which a sideways move is a rotation.
  double min_focal_scale = 0.8;
  double max_focal_scale = 1.25;

  void Check() const;
};

struct RotationOnlyFit {
  bool success = false;       // false with fewer than 3 correspondences
  SO3 cam2_from_cam1;         // the rotation
  double focal_scale = 1.0;   // true focal / the focal the rays were normalised with
  int inliers = 0;            // correspondences within the threshold
  double inlier_fraction = 0; // inliers / all given correspondences
};

// Fits the rotation (and focal scale) to `data` (normalised with focal_px): a closed-form
// start (Kabsch on the unit rays), then Levenberg-Marquardt on pixel residuals truncated at
// fit_gate_px, so outliers do not pull it; inliers are counted at inlier_threshold_px.
RotationOnlyFit FitRotationOnly(std::span<const TwoViewCorrespondence> data, double focal_px,
                                const RotationOnlyOptions& options = {});

}  // namespace glam
