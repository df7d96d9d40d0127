#include "tests/support/submap_accuracy.h"

#include <algorithm>

#include "engine/core/intrinsics_io.h"
#include "engine/core/similarity_alignment.h"

namespace glam::test_support {

ClipTruth LoadClipTruth(const std::filesystem::path& dir) {
  return {dir / "video.mp4", ReadIntrinsicsJson(dir / "intrinsics.json"), ReadTumTrajectory(dir / "gt_trajectory.tum"),
          eval::HeightfieldSurface::Load(dir / "gt_surface.json")};
}

SubmapAccuracy MeasureSubmap(const Submap& submap, const std::vector<TimedPose>& gt_world_from_cam,
                             const eval::HeightfieldSurface& surface) {
  std::vector<Eigen::Vector3d> est, truth;
  for (const FramePose& fp : submap.frame_poses) {
    est.push_back(fp.cam_from_submap.Inverse().translation());
    truth.push_back(gt_world_from_cam.at(static_cast<std::size_t>(fp.frame_index)).world_from_cam.translation());
  }
  const auto aligned = AlignSimilarity(est, truth);
  SubmapAccuracy out;
  out.ate = aligned.rmse;
  out.gt_world_from_submap = aligned.target_from_source;
  out.point_errors.reserve(submap.landmarks.size());
  for (const Landmark& lm : submap.landmarks) {
    const auto d = surface.Distance(out.gt_world_from_submap * lm.point_in_submap);
    out.point_errors.push_back(d.inside ? d.distance : 1e9);
  }
  return out;
}

double MedianOf(std::vector<double> values) {
  if (values.empty()) return 0;
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

RunAccuracy MeasureSubmaps(const std::vector<Submap>& submaps, const ClipTruth& clip) {
  RunAccuracy out;
  std::vector<double> errors;
  for (const Submap& submap : submaps) {
    const SubmapAccuracy a = MeasureSubmap(submap, clip.gt_world_from_cam, clip.surface);
    out.mean_submap_ate += a.ate;
    out.landmarks += submap.landmarks.size();
    errors.insert(errors.end(), a.point_errors.begin(), a.point_errors.end());
  }
  out.submaps = submaps.size();
  if (out.submaps > 0) out.mean_submap_ate /= static_cast<double>(out.submaps);
  out.map_median = MedianOf(std::move(errors));
  return out;
}

}  // namespace glam::test_support
