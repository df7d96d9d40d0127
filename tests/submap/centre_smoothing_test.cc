// Camera-centre smoothing against known answers: a smooth path is kept, noise on it shrinks,
// a wrong pose does not pull its neighbours, sparse frames are left alone, and the rotation
// re-solved with the true centre is the true rotation.
#include "engine/submap/centre_smoothing.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "engine/core/so3.h"

namespace glam {
namespace {

constexpr double kFps = 30.0;

// A turning, accelerating flight (metres), smooth at video rate.
Eigen::Vector3d TruePath(double t) {
  return {40.0 * std::sin(0.25 * t) + 0.3 * t * t, 40.0 * (1.0 - std::cos(0.25 * t)), 100.0 + 0.5 * std::sin(t)};
}

struct FramesRun {
  std::vector<double> times;
  std::vector<Eigen::Vector3d> truth;
};

FramesRun MakeRun(int frames, double fps) {
  FramesRun run;
  for (int i = 0; i < frames; ++i) {
    run.times.push_back(i / fps);
    run.truth.push_back(TruePath(i / fps));
  }
  return run;
}

double Rms(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  double sum = 0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += (a[i] - b[i]).squaredNorm();
  return std::sqrt(sum / static_cast<double>(a.size()));
}

TEST(CentreSmoothing, KeepsASmoothPathAndRemovesJitter) {
  const FramesRun run = MakeRun(300, kFps);
  const CentreSmoothingOptions options;
  // On the smooth path itself the local quadratic moves nothing measurable (< 1 cm).
  EXPECT_LT(Rms(SmoothCentres(run.times, run.truth, options), run.truth), 0.01);

  // Sideways jitter of 0.2 m (compressed footage, measured) shrinks at least twofold (a quadratic over 15 frames: ~2.6x in the middle of a run).
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.2);
  std::vector<Eigen::Vector3d> noisy = run.truth;
  for (Eigen::Vector3d& c : noisy) c += Eigen::Vector3d(noise(rng), noise(rng), 0.1 * noise(rng));
  const double before = Rms(noisy, run.truth);
  const double after = Rms(SmoothCentres(run.times, noisy, options), run.truth);
  EXPECT_LT(after, before / 2.0) << before << " -> " << after;
}

TEST(CentreSmoothing, AWrongPoseDoesNotPullItsNeighbours) {
  const FramesRun run = MakeRun(200, kFps);
  std::vector<Eigen::Vector3d> centres = run.truth;
  centres[100] += Eigen::Vector3d(5.0, -3.0, 2.0);
  const std::vector<Eigen::Vector3d> smoothed = SmoothCentres(run.times, centres, {});
  for (int i = 90; i <= 110; ++i) {
    EXPECT_LT((smoothed[i] - run.truth[i]).norm(), 0.02) << "frame " << i;  // the wrong one too
  }
}

TEST(CentreSmoothing, AJumpNoFlightMakesIsKept) {
  // A stream frozen for 3 s (the same pose repeated), then 30 m further on (measured clip).
  const FramesRun run = MakeRun(240, kFps);
  std::vector<Eigen::Vector3d> centres = run.truth;
  for (int i = 60; i < 150; ++i) centres[i] = run.truth[60];
  for (int i = 150; i < 240; ++i) centres[i] = run.truth[i] + Eigen::Vector3d(30, 0, 0);
  const std::vector<Eigen::Vector3d> smoothed = SmoothCentres(run.times, centres, {});
  for (int i = 140; i < 160; ++i) {
    EXPECT_LT((smoothed[i] - centres[i]).norm(), 0.05) << "frame " << i;
  }
}

TEST(CentreSmoothing, AHoverThenAFlightIsSmoothedAsAFlight) {
  // 8 s of hovering (a few millimetres of noise), then 2 s accelerating away at 5 m/s^2: most
  // steps are the hover's, but taking off is no jump, and the flight's jitter must go.
  const int frames = 300;
  std::vector<double> times;
  std::vector<Eigen::Vector3d> truth, noisy;
  std::mt19937 rng(9);
  std::normal_distribution<double> noise(0.0, 0.003);
  std::normal_distribution<double> jitter(0.0, 0.1);
  for (int i = 0; i < frames; ++i) {
    const double t = i / kFps;
    const double flying = std::max(0.0, t - 8.0);
    times.push_back(t);
    truth.emplace_back(2.5 * flying * flying, 0.0, 50.0);
    const double sideways = flying > 0 ? jitter(rng) : noise(rng);
    noisy.push_back(truth.back() + Eigen::Vector3d(noise(rng), sideways, noise(rng)));
  }
  const std::vector<Eigen::Vector3d> smoothed = SmoothCentres(times, noisy, {});
  const std::vector<Eigen::Vector3d> flight_truth(truth.begin() + 250, truth.end());
  const std::vector<Eigen::Vector3d> flight_noisy(noisy.begin() + 250, noisy.end());
  const std::vector<Eigen::Vector3d> flight_smoothed(smoothed.begin() + 250, smoothed.end());
  EXPECT_LT(Rms(flight_smoothed, flight_truth), 0.6 * Rms(flight_noisy, flight_truth));
}

TEST(CentreSmoothing, SparseFramesAndDisabledOptionLeaveCentresAlone) {
  // One photo a second: no window holds min_frames frames.
  const FramesRun photos = MakeRun(30, 1.0);
  std::vector<Eigen::Vector3d> centres = photos.truth;
  centres[10] += Eigen::Vector3d(1, 1, 1);
  const std::vector<Eigen::Vector3d> kept = SmoothCentres(photos.times, centres, {});
  for (std::size_t i = 0; i < centres.size(); ++i) EXPECT_EQ(kept[i], centres[i]);
  CentreSmoothingOptions off;
  off.half_window_s = 0;
  const FramesRun video = MakeRun(60, kFps);
  std::vector<Eigen::Vector3d> jittered = video.truth;
  jittered[30].x() += 0.5;
  EXPECT_EQ(SmoothCentres(video.times, jittered, off)[30], jittered[30]);
}

TEST(CentreSmoothing, OptionsAreChecked) {
  CentreSmoothingOptions options;
  EXPECT_NO_THROW(options.Check());
  options.half_window_s = -1;
  EXPECT_ANY_THROW(options.Check());
  options = {};
  options.min_frames = 2;
  EXPECT_ANY_THROW(options.Check());
  options = {};
  options.jump_factor = 0.5;
  EXPECT_ANY_THROW(options.Check());
}

TEST(CentreSmoothing, RotationIsReSolvedForTheGivenCentre) {
  const SO3 rotation = SO3::Exp(Eigen::Vector3d(3.0, 0.1, -0.2));  // looking roughly down
  const Eigen::Vector3d centre(2.0, -1.0, 100.0);
  const SE3 truth(rotation, -(rotation * centre));
  std::vector<Eigen::Vector2d> normalized;
  std::vector<Eigen::Vector3d> points;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ground(-40.0, 40.0);
  while (points.size() < 200) {
    const Eigen::Vector3d x(ground(rng), ground(rng), 0.1 * ground(rng));
    const Eigen::Vector3d p = truth * x;
    if (p.z() <= 1.0) continue;
    points.push_back(x);
    normalized.push_back(p.head<2>() / p.z());
  }
  SE3 pose(SO3::Exp(Eigen::Vector3d(0.02, -0.03, 0.05)) * rotation, Eigen::Vector3d(0, 0, 0));
  ASSERT_TRUE(SolveRotationWithCentre(normalized, points, centre, &pose));
  EXPECT_LT((pose.rotation().matrix() - rotation.matrix()).norm(), 1e-9);
  EXPECT_LT((pose.Inverse().translation() - centre).norm(), 1e-9);
  // Too few points: refused, pose untouched.
  SE3 untouched = truth;
  EXPECT_FALSE(SolveRotationWithCentre({normalized[0]}, {points[0]}, centre, &untouched));
}

}  // namespace
}  // namespace glam
