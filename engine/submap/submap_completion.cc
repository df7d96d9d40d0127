// Submap completion (paper, "Completion"): after the last keyframe's bundle adjustment, every
// frame of the submap is relocalised by PnP against the final landmarks — only the 3D-2D
// matches found while tracking are needed, no features are recomputed — and points that are
// inconsistent with the final poses are removed (the third outlier filter).
#include <algorithm>

#include "engine/core/logging.h"
#include "engine/geometry/absolute_pose.h"
#include "engine/submap/submap_builder.h"

namespace glam {

void SubmapBuilder::RelocaliseFrames() {
  const Camera camera = CurrentCamera();
  RansacOptions pnp;
  pnp.inlier_threshold = options_.pnp_threshold_pixels;
  pnp.min_inliers = options_.min_tracking_inliers;
  for (FrameRecord& frame : open_.frames) {
    std::vector<Eigen::Vector2d> pixels;
    std::vector<Eigen::Vector3d> points;
    for (const auto& [feature, id] : frame.landmark_matches) {
      if (const Landmark* lm = FindLandmark(id)) {
        pixels.push_back(frame.features.points[feature].cast<double>());
        points.push_back(lm->point_in_submap);
      }
    }
    if (static_cast<int>(points.size()) < options_.min_tracking_inliers) {
      // Too few surviving matches: try matching against the final landmarks from scratch.
      Localise(frame, frame.cam_from_submap);
      continue;
    }
    const RansacResult<SE3> result = EstimateAbsolutePose(pixels, points, camera, pnp);
    if (result.success) {
      frame.cam_from_submap = result.model;
    } else {
      frame.cam_from_submap.reset();
    }
  }
  // Keyframes keep their bundle-adjusted poses.
  for (std::size_t k = 0; k < open_.keyframes.size(); ++k) {
    open_.frames[open_.keyframe_frame_positions[k]].cam_from_submap = open_.keyframes[k].cam_from_submap;
  }
}

Submap SubmapBuilder::Complete() {
  const Camera camera = CurrentCamera();
  const std::size_t before = open_.landmarks.size();
  RemoveReprojectionOutliers(camera.intrinsics(), open_.keyframes, open_.landmarks, options_.outlier_filter);
  RemoveIsolatedLandmarks(open_.landmarks, options_.outlier_filter);
  RemoveWeaklyTriangulatedLandmarks(open_.keyframes, open_.landmarks, options_.outlier_filter);
  RelocaliseFrames();

  Submap submap;
  submap.id = next_submap_id_++;
  submap.intrinsics = camera.intrinsics();
  submap.keyframes = open_.keyframes;
  submap.landmarks = open_.landmarks;
  submap.first_frame = open_.frames.front().index;
  submap.last_frame = open_.frames.back().index;
  for (const FrameRecord& frame : open_.frames) {
    if (!frame.cam_from_submap) {
      ++submap.stats.frames_unposed;
      continue;
    }
    FramePose pose;
    pose.frame_index = frame.index;
    pose.timestamp_s = frame.timestamp_s;
    pose.cam_from_submap = *frame.cam_from_submap;
    pose.pnp_inliers = static_cast<std::uint32_t>(frame.landmark_matches.size());
    submap.frame_poses.push_back(pose);
  }
  submap.stats.landmarks_removed = static_cast<std::uint32_t>(before - open_.landmarks.size());
  std::string focals;
  for (const Keyframe& kf : open_.keyframes) {
    completed_keyframe_focals_.push_back(kf.focal);
    focals += fmt::format(" {:.1f}", kf.focal);
  }
  GLAM_LOG_DEBUG("submap {} keyframe focals:{}", submap.id, focals);
  UpdateFocalEstimate();
  ++stats_.submaps_completed;
  GLAM_LOG_INFO("submap {} complete: frames {}-{}, {} keyframes, {} landmarks, {} frames posed, focal {:.1f}",
                submap.id, submap.first_frame, submap.last_frame, submap.keyframes.size(),
                submap.landmarks.size(), submap.frame_poses.size(), focal_);
  return submap;
}

}  // namespace glam
