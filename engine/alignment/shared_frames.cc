#include "engine/alignment/shared_frames.h"

#include <unordered_map>

#include "engine/alignment/submap_verifier.h"
#include "engine/core/options.h"

namespace glam {

void SharedFrameOptions::Check() const {
  CheckGreater("SharedFrameOptions.max_disagreement_fraction", max_disagreement_fraction, 0.0);
}

std::vector<LandmarkMatch> SharedFrameMatches(const Submap& reference, const Submap& query,
                                              const Sim3& reference_from_query,
                                              const SharedFrameOptions& options) {
  options.Check();
  std::vector<LandmarkMatch> out;
  if (query.first_frame > reference.last_frame || reference_from_query.scale() <= 0) return out;
  std::unordered_map<std::int64_t, const FramePose*> in_reference;
  for (const FramePose& pose : reference.frame_poses) in_reference[pose.frame_index] = &pose;
  const double depth_a = SubmapDepthScale(reference);
  const double depth_b = depth_a / reference_from_query.scale();
  const double max_error = options.max_disagreement_fraction * depth_a;
  for (const FramePose& pose_b : query.frame_poses) {
    const auto it = in_reference.find(pose_b.frame_index);
    if (it == in_reference.end() || pose_b.frame_index < 0 ||
        pose_b.frame_index >= kMaxSharedFrameIndex) {
      continue;
    }
    const auto id = kSharedFrameIdBase + 2 * static_cast<std::uint32_t>(pose_b.frame_index);
    const SE3 submap_a_from_cam = it->second->cam_from_submap.Inverse();
    const SE3 submap_b_from_cam = pose_b.cam_from_submap.Inverse();
    const Eigen::Vector3d centre_a = submap_a_from_cam.translation();
    const Eigen::Vector3d centre_b = submap_b_from_cam.translation();
    const Eigen::Vector3d ahead_a = submap_a_from_cam * Eigen::Vector3d(0, 0, depth_a);
    const Eigen::Vector3d ahead_b = submap_b_from_cam * Eigen::Vector3d(0, 0, depth_b);
    if ((reference_from_query * centre_b - centre_a).norm() > max_error ||
        (reference_from_query * ahead_b - ahead_a).norm() > max_error) {
      continue;
    }
    out.push_back({id, id, centre_a, centre_b});
    out.push_back({id + 1, id + 1, ahead_a, ahead_b});
  }
  return out;
}

}  // namespace glam
