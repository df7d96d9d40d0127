// Ground truth for the evaluator tests, built here (not by `glam synth`) so the expected
// numbers are known exactly: a smooth non-planar drone trajectory, an analytic heightfield
// written in the gt_surface.json format by hand, and helpers to perturb them.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "engine/core/sim3.h"
#include "engine/export/ply_points.h"
#include "engine/export/tum_trajectory.h"

namespace glam::eval::testing {

// Frames 0..frames-1 at t = frame / fps: a curved flight at ~50 m over the origin, camera
// looking down, yawing along the way. No third of it is collinear.
std::vector<TimedPose> MakeGroundTruthTrajectory(int frames, double fps);

// Applies a similarity to camera poses (centre by the full Sim3, orientation rotated only):
// an estimate "in its own frame" for the given estimate_from_gt.
std::vector<TimedPose> TransformPoses(const Sim3& estimate_from_gt,
                                      const std::vector<TimedPose>& poses);

// Writes gt_surface.json + gt_heights.f32 in `dir` by hand (independent of the library's
// writer) for z = height(x, y) sampled on cols x rows vertices.
void WriteHeightfieldByHand(const std::filesystem::path& dir, const Eigen::Vector2d& origin,
                            double cell_size, int cols, int rows,
                            const std::function<double(double, double)>& height);

void WriteSynthJson(const std::filesystem::path& dir, double fps);

// A fresh temporary directory named after the running test; removed by the destructor.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

}  // namespace glam::eval::testing
