// Tracking (paper, "Tracking"): landmarks are projected with a predicted pose, those outside
// the frame or seen from a very different angle than when they were created are dropped, the
// rest are matched to the frame's features near their projection, and EPnP inside RANSAC gives
// the pose. The paper predicts with the previous pose; a constant-velocity prediction is used
// here (same thing for a hovering camera, better for a moving one), scaled to the time since
// the last posed frame (engine/submap/motion_prediction.h: streams drop frames, and frames
// tracking could not pose leave gaps). When guided matching
// finds too little (fast motion, a jump), matching against all landmarks is tried once before
// tracking is declared lost.
#include <cmath>

#include "engine/features/feature_grid.h"
#include "engine/features/feature_matcher.h"
#include "engine/features/guided_matcher.h"
#include "engine/geometry/absolute_pose.h"
#include "engine/submap/motion_prediction.h"
#include "engine/submap/submap_builder.h"

namespace glam {

std::optional<SE3> SubmapBuilder::PredictPose(const FrameRecord& record) const {
  const FrameRecord* last = nullptr;
  const FrameRecord* before = nullptr;
  // The posed frames before the one being tracked (usually the newest; the bootstrap tracks
  // the frames after its second keyframe in order, with later ones not posed yet).
  for (auto it = open_.frames.rbegin(); it != open_.frames.rend(); ++it) {
    if (it->index >= record.index || !it->cam_from_submap) continue;
    if (last == nullptr) {
      last = &*it;
    } else {
      before = &*it;
      break;
    }
  }
  if (last == nullptr) return std::nullopt;
  if (before == nullptr) return last->cam_from_submap;
  return ExtrapolateConstantVelocity(*before->cam_from_submap, before->timestamp_s, *last->cam_from_submap,
                                     last->timestamp_s, record.timestamp_s);
}

bool SubmapBuilder::Track(FrameRecord& record) {
  bool matched_globally = false;
  const bool posed = LocaliseGuidedFirst(record, PredictPose(record), &matched_globally);
  if (matched_globally) ++stats_.frames_matched_globally;
  if (posed) FollowRejectedLandmarks(record);
  return posed;
}

bool SubmapBuilder::LocaliseGuidedFirst(FrameRecord& record, std::optional<SE3> predicted,
                                        bool* matched_globally) const {
  if (predicted && Localise(record, predicted)) return true;
  if (predicted && matched_globally != nullptr) *matched_globally = true;
  return Localise(record, std::nullopt);
}

bool SubmapBuilder::Localise(FrameRecord& record, std::optional<SE3> predicted) const {
  record.ResetPose();
  if (record.features.size() == 0 || open_.landmarks.empty()) return false;
  const Camera camera = CurrentCamera();
  const cv::Mat frame_descriptors = record.features.FloatDescriptors();

  std::vector<int> candidate_landmarks;  // indices into open_.landmarks
  std::vector<Match> matches;            // query = candidate position, train = feature
  if (predicted) {
    const double max_cos = std::cos(options_.max_view_angle_deg * M_PI / 180.0);
    const Eigen::Vector3d centre = predicted->Inverse().translation();
    std::vector<Eigen::Vector2d> projections;
    for (std::size_t i = 0; i < open_.landmarks.size(); ++i) {
      const Landmark& lm = open_.landmarks[i];
      Eigen::Vector2d px;
      if (!camera.Project(*predicted * lm.point_in_submap, &px) || !camera.InImage(px)) continue;
      const Eigen::Vector3d view = (lm.point_in_submap - centre).normalized();
      if (view.dot(open_.extras.at(lm.id).first_view_direction) < max_cos) continue;
      candidate_landmarks.push_back(static_cast<int>(i));
      projections.push_back(px);
    }
    if (static_cast<int>(candidate_landmarks.size()) < options_.min_tracking_inliers) return false;
    const cv::Mat landmark_descriptors = LandmarkDescriptorMatrix(open_.landmarks, candidate_landmarks);
    const double diagonal = std::hypot(camera.intrinsics().width, camera.intrinsics().height);
    GuidedMatchOptions guided;
    guided.radius_px = options_.match_radius_fraction * diagonal;
    guided.ratio = static_cast<float>(options_.match_ratio);
    const FeatureGrid grid(record.features.PixelPoints(), camera.intrinsics().width, camera.intrinsics().height, guided.radius_px);
    matches = MatchGuided(landmark_descriptors, projections, frame_descriptors, grid, guided);
  } else {
    const cv::Mat landmark_descriptors = LandmarkDescriptorMatrix(open_.landmarks);
    for (int r = 0; r < landmark_descriptors.rows; ++r) candidate_landmarks.push_back(r);
    MatchOptions global;
    global.ratio = static_cast<float>(options_.match_ratio);
    global.mutual = true;
    matches = MatchDescriptors(landmark_descriptors, frame_descriptors, global);
  }
  if (static_cast<int>(matches.size()) < options_.min_tracking_inliers) return false;

  std::vector<Eigen::Vector2d> pixels;
  std::vector<Eigen::Vector3d> points3d;
  for (const Match& m : matches) {
    pixels.push_back(record.features.points[m.train].cast<double>());
    points3d.push_back(open_.landmarks[candidate_landmarks[m.query]].point_in_submap);
  }
  RansacOptions pnp;
  pnp.inlier_threshold = options_.pnp_threshold_pixels;
  pnp.min_inliers = options_.min_tracking_inliers;
  const RansacResult<SE3> result = EstimateAbsolutePose(pixels, points3d, camera, pnp);
  if (!result.success) return false;

  record.cam_from_submap = result.model;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    const std::uint32_t id = open_.landmarks[candidate_landmarks[matches[i].query]].id;
    if (result.inlier_mask[i]) {
      record.landmark_matches.emplace_back(matches[i].train, id);
      continue;
    }
    if (options_.moving_landmark_frames == 0) continue;  // only FollowRejectedLandmarks reads them
    Eigen::Vector2d projected;
    if (!camera.Project(result.model * points3d[i], &projected)) continue;
    record.rejected_matches.push_back({id, (pixels[i] - projected).cast<float>()});
  }
  return true;
}

void SubmapBuilder::FollowRejectedLandmarks(const FrameRecord& record) {
  if (options_.moving_landmark_frames == 0) return;
  for (const auto& [feature, id] : record.landmark_matches) {
    open_.rejections.erase(id);
    open_.moving_landmarks.erase(id);  // an inlier again: it was the pose that had drifted
  }
  for (const FrameRecord::RejectedMatch& r : record.rejected_matches) {
    OpenSubmap::Rejections& run = open_.rejections[r.landmark_id];
    const float norm = r.residual_px.norm();
    const float last_norm = run.residual_px.norm();
    const bool drifting = run.frames > 0 && norm > last_norm &&
                          r.residual_px.dot(run.residual_px) > options_.moving_landmark_min_cos * norm * last_norm;
    run.frames = drifting ? run.frames + 1 : 1;
    run.residual_px = r.residual_px;
    if (run.frames >= options_.moving_landmark_frames) open_.moving_landmarks.insert(r.landmark_id);
  }
}

}  // namespace glam
