// Accuracy of one completed submap against a synthetic fixture's ground truth: the ATE of its
// posed frames' camera centres after a Sim3 fit (gt_world_from_submap), and each landmark's
// distance to the true surface in that fit. Shared by the clip tests that compare builder
// configurations on the same clip.
#pragma once

#include <filesystem>
#include <vector>

#include "engine/core/camera.h"
#include "engine/core/sim3.h"
#include "engine/export/tum_trajectory.h"
#include "engine/map/submap.h"
#include "tools/eval/ground_truth_surface.h"

namespace glam::test_support {

// A synthetic fixture's ground truth (`glam synth` output directory).
struct ClipTruth {
  std::filesystem::path video;
  Intrinsics intrinsics;
  std::vector<TimedPose> gt_world_from_cam;  // indexed by frame
  eval::HeightfieldSurface surface;
};
ClipTruth LoadClipTruth(const std::filesystem::path& dir);

struct SubmapAccuracy {
  double ate = 0;                    // RMSE of the frame centres after the Sim3 fit (m)
  Sim3 gt_world_from_submap;         // the fit
  std::vector<double> point_errors;  // per landmark, distance to the surface (m); 1e9 outside it
};

// gt_world_from_cam: the fixture's poses indexed by frame index (gt_trajectory.tum).
SubmapAccuracy MeasureSubmap(const Submap& submap, const std::vector<TimedPose>& gt_world_from_cam,
                             const eval::HeightfieldSurface& surface);

// Median of the values (copied); 0 for none.
double MedianOf(std::vector<double> values);

// Over all submaps of a run: the mean of their ATEs, the median of all their landmarks' errors.
struct RunAccuracy {
  double mean_submap_ate = 0;  // mean over submaps of MeasureSubmap's ate (m)
  double map_median = 0;       // median landmark distance to the true surface (m)
  std::size_t submaps = 0;
  std::size_t landmarks = 0;
};
RunAccuracy MeasureSubmaps(const std::vector<Submap>& submaps, const ClipTruth& clip);

}  // namespace glam::test_support
