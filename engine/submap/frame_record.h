// What thread 1 remembers about each frame of the open submap. Features are kept compact
// (float32 pixel positions, uint8 descriptors: ~270 KB per 2000-feature frame instead of
// ~1 MB) because the submap hand-off replays the last 10 % of frames into the next submap, and
// the middle keyframe is chosen among past frames. Memory is bounded by
// SubmapOptions::max_frames_per_submap, not by video length.
#pragma once

#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "engine/core/se3.h"
#include "engine/features/features.h"
#include "engine/map/keyframe.h"
#include "engine/map/landmark.h"

namespace glam {

struct CompactFeatures {
  std::vector<Eigen::Vector2f> points;
  std::vector<Descriptor> descriptors;
  std::vector<Rgb> colors;
  // Features::rolling_shutter_rates (empty unless the readout is estimated) and the readout
  // (s) `points` are corrected for: points = raw - readout_applied_s * rates.
  std::vector<Eigen::Vector2f> rolling_shutter_rates;
  double readout_applied_s = 0;

  static CompactFeatures From(const Features& features);
  // Moves the points to their positions under `readout_s` (no-op without rates).
  void ApplyReadout(double readout_s);
  std::size_t size() const { return points.size(); }
  // N x 128 CV_32F, the inverse of the quantisation in From() (to within 1/512).
  cv::Mat FloatDescriptors() const;
  cv::Mat FloatDescriptors(const std::vector<int>& rows) const;
  // Keypoint positions in double precision (what FeatureGrid takes).
  std::vector<Eigen::Vector2d> PixelPoints() const;
};

// Quantises one RootSIFT/SIFT float row (unit L2 norm) to bytes: min(255, round(512 v)).
Descriptor QuantizeDescriptor(const float* row);
void DequantizeDescriptor(const Descriptor& d, float* row);

// Landmark descriptors as CV_32F rows for matching: all landmarks, or those at `rows`.
cv::Mat LandmarkDescriptorMatrix(const std::vector<Landmark>& landmarks);
cv::Mat LandmarkDescriptorMatrix(const std::vector<Landmark>& landmarks, const std::vector<int>& rows);

struct FrameRecord {
  std::int64_t index = 0;
  double timestamp_s = 0;
  CompactFeatures features;
  // SIFT ran on this frame (Features::detected); false for frames whose keypoints KLT carried
  // over from a detection frame. Keyframes are taken on detected frames where possible: they
  // alone see newly visible ground.
  bool detected = true;
  std::optional<SE3> cam_from_submap;  // set when tracking posed the frame
  // (feature index, landmark id) of the PnP inliers.
  std::vector<std::pair<int, std::uint32_t>> landmark_matches;
  // Descriptor matches PnP rejected: the landmark and its reprojection residual under the
  // frame's pose (observed minus projected, px). A landmark on content that moves on its own
  // (water ripples, cloud-shadow edges) is rejected frame after frame with a residual that
  // keeps its direction and grows (SubmapOptions::moving_landmark_frames; empty when that is
  // off).
  struct RejectedMatch {
    std::uint32_t landmark_id = 0;
    Eigen::Vector2f residual_px = Eigen::Vector2f::Zero();
  };
  std::vector<RejectedMatch> rejected_matches;
  // Set when the frame was posed by rotation only (SubmapOptions::hover_max_speed: a hovering
  // drone yawing to ground no landmark covers): its rotation relative to the frame before it
  // in the open submap, whose centre it shares. Such a frame has no landmark matches and never
  // becomes a keyframe; its pose is re-derived from that frame's final pose at completion.
  std::optional<SO3> cam_from_previous_rotation;
  bool rotation_only() const { return cam_from_previous_rotation.has_value(); }
  // Forgets the pose and everything tracking found (the frame is tracked again).
  void ResetPose() {
    cam_from_submap.reset();
    landmark_matches.clear();
    rejected_matches.clear();
    cam_from_previous_rotation.reset();
  }
  // The submap's record of this posed frame (cam_from_submap must be set).
  FramePose ToFramePose() const;
};

// How much of a frame's textured view the map covers: the image is cut into a grid of
// `columns` columns (rows in proportion to the aspect ratio); of the cells holding at least
// `min_features` of the frame's keypoints, the fraction that also hold a point of `mapped`
// (landmarks projected into the frame). 1 when no cell is textured. The share of unmapped
// ground in view, whichever way it came into view: a drone climbing over its take-off point
// keeps all its landmarks in view and tracked while they shrink towards the image centre.
double MapCoverage(const std::vector<Eigen::Vector2f>& keypoints, const std::vector<Eigen::Vector2d>& mapped,
                   int width, int height, int columns = 8, int min_features = 3);

}  // namespace glam
