// A drone that stops, hovers and yaws in place (SynthOptions::stop_every) gives frame pairs
// without a baseline. Tracking is lost when the yaw turns the camera to unseen ground, and the
// new submap's bootstrap must wait for the drone to move: the essential matrix of a pure
// rotation is degenerate and triangulates invented parallax (engine/geometry/rotation_only.h).
// Ground truth: the fixture's own trajectory and surface (`glam eval`).
#include <filesystem>
#include <iostream>
#include <string>

#include <gtest/gtest.h>

#include "engine/pipeline/mapping_job.h"
#include "tools/eval/evaluation.h"

namespace glam {
namespace {

namespace fs = std::filesystem;

const fs::path kClip = fs::path(GLAM_TEST_FIXTURES_DIR) / "hover_yaw";

eval::EvaluationResult MapAndEvaluate(const MappingOptions& options, const std::string& name) {
  const fs::path out = fs::temp_directory_path() / ("glam_hover_yaw_" + name);
  fs::remove_all(out);
  RunMapping(kClip / "video.mp4", out, options);  // uncalibrated: the focal is estimated
  const eval::EvaluationResult result = eval::EvaluateDirectories(kClip, out, {});
  std::cout << name << ": " << eval::Summary(result) << "\n";
  return result;
}

TEST(HoverYaw, NoSubmapStartsOnAPureRotation) {
  const eval::EvaluationResult with_veto = MapAndEvaluate(MappingOptions(), "default");
  ASSERT_TRUE(with_veto.map.has_value());
  // Measured: ATE 0.20 m, map median 0.21 m, 87 % of the 1200 frames posed (the yaws to
  // unseen ground cannot be posed) at 60 m, 45 deg oblique.
  EXPECT_LT(with_veto.trajectory.ate_rmse, 0.35);
  EXPECT_LT(with_veto.map->median, 0.35);
  EXPECT_GT(with_veto.trajectory.fraction_posed, 0.8);

  // The control: the same clip without the rotation check bootstraps a submap on two frames
  // of the second hover and maps it metres wrong (measured ATE 1.86 m, map median 0.72 m). If
  // this stops holding, the clip no longer tests the case.
  MappingOptions paper_bootstrap;
  paper_bootstrap.submap.bootstrap_rotation_veto_fraction = 0;
  const eval::EvaluationResult without = MapAndEvaluate(paper_bootstrap, "no_veto");
  EXPECT_GT(without.trajectory.ate_rmse, 3 * with_veto.trajectory.ate_rmse);
}

}  // namespace
}  // namespace glam
