// Evaluator on ground truth perturbed with known noise, scale, rotation and drift: the
// metrics must recover what was injected.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "engine/core/error.h"
#include "tests/tools/eval_test_world.h"
#include "tools/eval/evaluation.h"
#include "tools/eval/trajectory_metrics.h"

namespace glam::eval {
namespace {

using testing::MakeGroundTruthTrajectory;
using testing::TempDir;
using testing::TransformPoses;

constexpr double kFps = 10.0;
constexpr int kFrames = 250;  // 25 s: both RPE horizons (1 s, 10 s) fit
constexpr double kTolerance = 0.5 / kFps;

// An arbitrary monocular frame: scale 0.37, rotated, shifted.
Sim3 EstimateFromGt() {
  return Sim3(0.37, SO3::Exp(Eigen::Vector3d(0.3, -1.1, 2.0)), Eigen::Vector3d(5, -20, 3));
}

TEST(TrajectoryMetrics, SimilarityTransformedGroundTruthHasZeroError) {
  const auto gt = MakeGroundTruthTrajectory(kFrames, kFps);
  const auto estimate = TransformPoses(EstimateFromGt(), gt);
  const TrajectoryMetrics m = EvaluateTrajectory(gt, estimate, kTolerance, {});
  EXPECT_EQ(m.matched, kFrames);
  EXPECT_DOUBLE_EQ(m.fraction_posed, 1.0);
  EXPECT_NEAR(m.gt_from_estimate.scale(), 1 / 0.37, 1e-9);
  EXPECT_LT(m.ate_rmse, 1e-6);
  EXPECT_LT(m.orientation_rmse_deg, 1e-5);
  ASSERT_EQ(m.rpe.size(), 2u);
  for (const RelativePoseError& e : m.rpe) {
    EXPECT_GT(e.pairs, 100) << e.horizon_s;
    EXPECT_LT(e.translation_rmse, 1e-6) << e.horizon_s;
    EXPECT_LT(e.rotation_rmse_deg, 1e-5) << e.horizon_s;
  }
  ASSERT_TRUE(m.scale_drift_percent.has_value());
  EXPECT_LT(*m.scale_drift_percent, 1e-6);
}

TEST(TrajectoryMetrics, AteRecoversInjectedNoise) {
  const auto gt = MakeGroundTruthTrajectory(kFrames, kFps);
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.3);
  std::vector<TimedPose> noisy = gt;
  double sum_sq = 0;
  for (TimedPose& p : noisy) {
    const Eigen::Vector3d n(noise(rng), noise(rng), noise(rng));
    p.world_from_cam.translation() += n;
    sum_sq += n.squaredNorm();
  }
  const double injected_rms = std::sqrt(sum_sq / kFrames);
  const TrajectoryMetrics m =
      EvaluateTrajectory(gt, TransformPoses(EstimateFromGt(), noisy), kTolerance, {});
  // The 7-parameter fit absorbs a little of the noise: ATE is slightly below the injected RMS.
  EXPECT_NEAR(m.ate_rmse, injected_rms, 0.03 * injected_rms);
  EXPECT_LE(m.ate_rmse, injected_rms);
  EXPECT_NEAR(m.gt_from_estimate.scale(), 1 / 0.37, 0.01 / 0.37);
  // Relative motion over 1 s sees the noise of two frames: ~sqrt(2) * per-frame RMS.
  EXPECT_NEAR(m.rpe[0].translation_rmse, std::sqrt(2.0) * injected_rms, 0.15 * injected_rms);
}

TEST(TrajectoryMetrics, ScaleDriftOfTheLastThirdIsMeasured) {
  const auto gt = MakeGroundTruthTrajectory(kFrames, kFps);
  std::vector<TimedPose> drifted = gt;
  // The last third of the flight (frames 167..249) is 8 % too large in the estimate.
  const int last_third_begin = kFrames - kFrames / 3;
  const Eigen::Vector3d pivot = gt[last_third_begin].world_from_cam.translation();
  for (int f = last_third_begin; f < kFrames; ++f) {
    Eigen::Vector3d& c = drifted[f].world_from_cam.translation();
    c = pivot + 1.08 * (c - pivot);
  }
  const TrajectoryMetrics m =
      EvaluateTrajectory(gt, TransformPoses(EstimateFromGt(), drifted), kTolerance, {});
  ASSERT_TRUE(m.scale_drift_percent.has_value());
  EXPECT_NEAR(*m.scale_drift_percent, 8.0, 1e-6);
  EXPECT_NEAR(*m.scale_first_third, 0.37, 1e-9);
  EXPECT_NEAR(*m.scale_last_third, 0.37 * 1.08, 1e-9);

  // Undistorted estimate: no drift.
  const TrajectoryMetrics clean =
      EvaluateTrajectory(gt, TransformPoses(EstimateFromGt(), gt), kTolerance, {});
  EXPECT_LT(*clean.scale_drift_percent, 1e-6);
}

TEST(TrajectoryMetrics, Se3AlignmentKeepsTheScaleError) {
  const auto gt = MakeGroundTruthTrajectory(kFrames, kFps);
  const Sim3 rigid(1.0, SO3::Exp(Eigen::Vector3d(0.1, 0.2, -0.4)), Eigen::Vector3d(1, 2, 3));
  TrajectoryEvalOptions se3;
  se3.estimate_scale = false;
  EXPECT_LT(EvaluateTrajectory(gt, TransformPoses(rigid, gt), kTolerance, se3).ate_rmse, 1e-6);
  const TrajectoryMetrics scaled =
      EvaluateTrajectory(gt, TransformPoses(EstimateFromGt(), gt), kTolerance, se3);
  EXPECT_DOUBLE_EQ(scaled.gt_from_estimate.scale(), 1.0);
  EXPECT_GT(scaled.ate_rmse, 5.0);
}

TEST(TrajectoryMetrics, SubsetOfFramesWithJitteredTimestampsIsMatched) {
  const auto gt = MakeGroundTruthTrajectory(kFrames, kFps);
  std::vector<TimedPose> estimate;
  for (int f = 0; f < kFrames; f += 2) {
    TimedPose p = gt[f];
    p.timestamp += (f % 4 == 0 ? 0.4 : -0.4) / kFps;  // within half a frame
    estimate.push_back(p);
  }
  const TrajectoryMetrics m =
      EvaluateTrajectory(gt, TransformPoses(EstimateFromGt(), estimate), kTolerance, {});
  EXPECT_EQ(m.matched, (kFrames + 1) / 2);
  EXPECT_NEAR(m.fraction_posed, 0.5, 0.01);
  EXPECT_LT(m.ate_rmse, 1e-6);  // every pose matched to its own frame
}

TEST(TrajectoryMetrics, HorizonLongerThanTheTrajectoryIsSkipped) {
  const auto gt = MakeGroundTruthTrajectory(50, kFps);  // 4.9 s
  const TrajectoryMetrics m = EvaluateTrajectory(gt, gt, kTolerance, {});
  EXPECT_GT(m.rpe[0].pairs, 0);
  EXPECT_EQ(m.rpe[1].pairs, 0);
}

TEST(TrajectoryMetrics, BadInputsAreInputErrors) {
  const auto gt = MakeGroundTruthTrajectory(kFrames, kFps);
  EXPECT_THROW(EvaluateTrajectory(gt, {}, kTolerance, {}), InputError);
  std::vector<TimedPose> late = gt;
  for (TimedPose& p : late) p.timestamp += 1000;
  try {
    EvaluateTrajectory(gt, late, kTolerance, {});
    FAIL() << "no overlap accepted";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("overlap"));
  }
  const std::vector<TimedPose> two(gt.begin(), gt.begin() + 2);
  EXPECT_THROW(EvaluateTrajectory(gt, two, kTolerance, {}), InputError);
}

// Whole evaluation through the files of the Contracts: GT directory + result directory with
// a point cloud sampled on the true surface, perturbed along the surface normal.
TEST(Evaluation, MapErrorRecoversInjectedPointNoise) {
  TempDir gt_dir, result_dir;
  const auto gt = MakeGroundTruthTrajectory(kFrames, kFps);
  WriteTumTrajectory(gt_dir / "gt_trajectory.tum", gt);
  testing::WriteSynthJson(gt_dir.path(), kFps);
  const auto terrain = [](double x, double y) { return 2 * std::sin(x / 10) + std::cos(y / 7); };
  testing::WriteHeightfieldByHand(gt_dir.path(), {-60, -50}, 0.5, 241, 201, terrain);

  const Sim3 estimate_from_gt = EstimateFromGt();
  WriteTumTrajectory(result_dir / "trajectory.tum", TransformPoses(estimate_from_gt, gt));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> x(-55, 55), y(-45, 45);
  std::normal_distribution<double> noise(0.0, 0.3);
  std::vector<ColoredPoint> points;
  double sum_sq = 0;
  int within_half = 0;
  const int n = 4000;
  for (int k = 0; k < n; ++k) {
    const double px = x(rng), py = y(rng);
    // Analytic normal of the smooth terrain; the mesh differs from it by < 1 mm at 0.5 m cells.
    const Eigen::Vector3d normal =
        Eigen::Vector3d(-0.2 * std::cos(px / 10), std::sin(py / 7) / 7, 1).normalized();
    const double offset = noise(rng);
    sum_sq += offset * offset;
    within_half += std::abs(offset) < 0.5 ? 1 : 0;
    const Eigen::Vector3d on_gt = Eigen::Vector3d(px, py, terrain(px, py)) + offset * normal;
    points.push_back({(estimate_from_gt * on_gt).cast<float>(), {100, 150, 200}});
  }
  points.push_back({(estimate_from_gt * Eigen::Vector3d(500, 0, 0)).cast<float>(), {0, 0, 0}});
  WritePlyPoints(result_dir / "points.ply", points);

  const EvaluationResult r = EvaluateDirectories(gt_dir.path(), result_dir.path(), {});
  EXPECT_DOUBLE_EQ(r.fps, kFps);
  EXPECT_LT(r.trajectory.ate_rmse, 1e-5);
  ASSERT_TRUE(r.map.has_value());
  EXPECT_EQ(r.map->points, static_cast<std::size_t>(n + 1));
  EXPECT_EQ(r.map->outside, 1u);
  const double injected_rms = std::sqrt(sum_sq / n);
  EXPECT_NEAR(r.map->rmse, injected_rms, 0.02 * injected_rms);
  EXPECT_NEAR(r.map->median, 0.6745 * 0.3, 0.03);  // median of |N(0, 0.3)|
  EXPECT_NEAR(r.map->within_0_5m, static_cast<double>(within_half) / n, 0.01);
  EXPECT_GT(r.map->within_1m, 0.99);

  const nlohmann::json j = ToJson(r);
  EXPECT_EQ(j["trajectory"]["matched_frames"], kFrames);
  EXPECT_NEAR(j["map"]["rmse_m"].get<double>(), r.map->rmse, 1e-12);
  EXPECT_TRUE(j["trajectory"]["rpe"]["10s"]["translation_rmse_m"].is_number());
  EXPECT_THAT(Summary(r), ::testing::HasSubstr("map RMSE"));
}

TEST(Evaluation, WithoutPointCloudThereAreNoMapMetrics) {
  TempDir gt_dir, result_dir;
  const auto gt = MakeGroundTruthTrajectory(60, kFps);
  WriteTumTrajectory(gt_dir / "gt_trajectory.tum", gt);  // no synth.json: fps inferred
  WriteTumTrajectory(result_dir / "trajectory.tum", gt);
  const EvaluationResult r = EvaluateDirectories(gt_dir.path(), result_dir.path(), {});
  EXPECT_NEAR(r.fps, kFps, 1e-6);
  EXPECT_FALSE(r.map.has_value());
  const nlohmann::json j = ToJson(r);
  EXPECT_TRUE(j["map"].is_null());
  EXPECT_TRUE(j["trajectory"]["rpe"]["10s"]["translation_rmse_m"].is_null());  // 5.9 s < 10 s
}

}  // namespace
}  // namespace glam::eval
