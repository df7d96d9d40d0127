// Tests of the synthetic renderer: its ground truth must be exact (projections of true
// surface points with true poses land on the same texture), its flights smooth, its files
// complete and parseable, and everything deterministic from the seed.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <numeric>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "engine/export/tum_trajectory.h"

#include "engine/core/camera.h"
#include "engine/core/error.h"
#include "engine/core/intrinsics_io.h"
#include "engine/geo/gps_track.h"
#include "tools/synth/dynamic_surface.h"
#include "tools/synth/gps_srt_writer.h"
#include "tools/synth/ground_truth_writer.h"
#include "tools/synth/renderer.h"
#include "tools/synth/synth.h"
#include "tools/synth/trajectory.h"
#include "tools/synth/world.h"

namespace glam::synth {
namespace {

namespace fs = std::filesystem;

// Small, fast settings: low altitude keeps the world (and its texture) small.
SynthOptions SmallOptions() {
  SynthOptions o;
  o.width = 320;
  o.height = 180;
  o.frames = 40;
  o.altitude = 50;
  o.speed = 8;
  o.seed = 3;
  return o;
}

TerrainFn Terrain(const SynthOptions& o) {
  return [o](double x, double y) { return TerrainHeight(x, y, o); };
}

double Ncc(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat r;
  cv::matchTemplate(a, b, r, cv::TM_CCOEFF_NORMED);
  return r.at<float>(0, 0);
}

double Median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Surface points seen at grid pixels of frame `a`, re-projected into frame `b` with
// `pose_b`; returns the patch NCC of every point visible (unoccluded) in b.
std::vector<double> PatchNccs(const World& world, const Camera& camera, const cv::Mat& img_a,
                              const SE3& pose_a, const cv::Mat& img_b, const SE3& pose_b_true,
                              const SE3& pose_b) {
  cv::Mat ga, gb;
  cv::cvtColor(img_a, ga, cv::COLOR_BGR2GRAY);
  cv::cvtColor(img_b, gb, cv::COLOR_BGR2GRAY);
  ga.convertTo(ga, CV_32F);
  gb.convertTo(gb, CV_32F);
  const cv::Size patch(15, 15);
  std::vector<double> nccs;
  for (int y = 20; y < img_a.rows - 20; y += 12) {
    for (int x = 20; x < img_a.cols - 20; x += 12) {
      const Eigen::Vector3d dir = pose_a.rotation() * camera.Unproject(Eigen::Vector2d(x, y)).normalized();
      RayHit hit;
      if (!world.surface().Intersect(pose_a.translation(), dir, 1e4, &hit)) continue;
      // Visible from b (true pose): the ray from b's centre must reach this point first.
      const Eigen::Vector3d to_point = hit.point - pose_b_true.translation();
      RayHit hit_b;
      if (!world.surface().Intersect(pose_b_true.translation(), to_point.normalized(), 1e4, &hit_b) ||
          std::abs(hit_b.t - to_point.norm()) > 0.05) {
        continue;
      }
      Eigen::Vector2d pb;
      if (!camera.Project(pose_b.Inverse() * hit.point, &pb) || !camera.InImage(pb, 12)) continue;
      cv::Mat pa_img, pb_img;
      cv::getRectSubPix(ga, patch, cv::Point2f(x, y), pa_img);
      cv::getRectSubPix(gb, patch, cv::Point2f(static_cast<float>(pb.x()), static_cast<float>(pb.y())), pb_img);
      cv::Scalar mean, stddev;
      cv::meanStdDev(pa_img, mean, stddev);
      if (stddev[0] < 2.0) continue;  // featureless patch: NCC is meaningless
      nccs.push_back(Ncc(pa_img, pb_img));
    }
  }
  return nccs;
}

TEST(SynthRender, TrueSurfacePointsReprojectOntoTheSameTexture) {
  SynthOptions o = SmallOptions();
  o.k1 = -0.08;  // distortion must be consistent between rendering and Camera::Project
  o.k2 = 0.01;
  o.pitch_deg = 20;
  o.frames = 21;
  const std::vector<SE3> poses = MakeTrajectory(o, Terrain(o));
  const World world = World::Generate(o, poses);
  const Camera camera(MakeIntrinsics(o));
  const Renderer renderer(world, camera.intrinsics());
  const cv::Mat a = renderer.Render(poses[5]);
  const cv::Mat b = renderer.Render(poses[15]);
  ASSERT_EQ(a.size(), cv::Size(o.width, o.height));

  const std::vector<double> good = PatchNccs(world, camera, a, poses[5], b, poses[15], poses[15]);
  ASSERT_GT(good.size(), 50u);
  EXPECT_GT(Median(good), 0.9);

  // A pose 3 m off (about 10 px at this altitude) must not match the texture.
  SE3 wrong = poses[15];
  wrong.translation() += Eigen::Vector3d(3.0, -2.0, 0.0);
  const std::vector<double> bad = PatchNccs(world, camera, a, poses[5], b, poses[15], wrong);
  ASSERT_GT(bad.size(), 50u);
  EXPECT_LT(Median(bad), 0.5);
}

// Rolling shutter: each image row is rendered from the pose at its own exposure time; the
// frame's time (its ground-truth pose) is the middle row's.
TEST(SynthRender, RollingShutterRowsSeeTheirOwnPose) {
  SynthOptions o = SmallOptions();
  o.speed = 20;  // 0.6 m over the readout at 50 m: ~2 px
  o.rolling_shutter_ms = 30;
  const int k = 10;
  EXPECT_NEAR(0.5 * (o.RowTime(k, 0) + o.RowTime(k, o.height - 1)), k / o.fps, 1e-12);
  EXPECT_NEAR(o.RowTime(k, o.height - 1) - o.RowTime(k, 0), 0.030, 1e-12);
  const std::vector<SE3> poses = MakeTrajectory(o, Terrain(o));
  // The same flight at any time: at the frame times it is MakeTrajectory's.
  const std::vector<SE3> again = MakeTrajectoryAt(o, Terrain(o), {k / o.fps});
  EXPECT_LT((again[0].translation() - poses[k].translation()).norm(), 1e-9);
  std::vector<double> times;
  for (int row = 0; row < o.height; ++row) times.push_back(o.RowTime(k, row));
  const std::vector<SE3> rows = MakeTrajectoryAt(o, Terrain(o), times);
  EXPECT_NEAR((rows.back().translation() - rows.front().translation()).norm(), 0.030 * o.speed, 0.01);

  const World world = World::Generate(o, poses);
  const Renderer renderer(world, MakeIntrinsics(o));
  const cv::Mat rolling = renderer.Render(rows);
  const cv::Mat from_top = renderer.Render(rows.front());
  const cv::Mat from_middle = renderer.Render(poses[k]);
  auto band_difference = [](const cv::Mat& a, const cv::Mat& b, int first_row) {
    cv::Mat d;
    cv::absdiff(a.rowRange(first_row, first_row + 6), b.rowRange(first_row, first_row + 6), d);
    return cv::mean(d)[0];
  };
  // The top rows are the top row's view, not the middle row's.
  EXPECT_LT(band_difference(rolling, from_top, 1), 1.0);
  EXPECT_GT(band_difference(rolling, from_middle, 1), 4.0 * band_difference(rolling, from_top, 1) + 1.0);
  // Rows near the middle are (nearly) the frame pose's view.
  EXPECT_LT(band_difference(rolling, from_middle, o.height / 2 - 3), 1.0);
}

TEST(SynthRender, RayHitsLieOnTheHeightfieldAndAreTheFirstCrossing) {
  SynthOptions o = SmallOptions();
  o.frames = 2;
  o.pitch_deg = 45;
  o.building_density = 2.0;
  const std::vector<SE3> poses = MakeTrajectory(o, Terrain(o));
  const World world = World::Generate(o, poses);
  const Camera camera(MakeIntrinsics(o));
  const Heightfield& hf = world.surface();
  int hits = 0;
  for (int y = 0; y < o.height; y += 9) {
    for (int x = 0; x < o.width; x += 9) {
      const Eigen::Vector3d c = poses[0].translation();
      const Eigen::Vector3d dir = poses[0].rotation() * camera.Unproject(Eigen::Vector2d(x, y)).normalized();
      RayHit hit;
      if (!hf.Intersect(c, dir, 1e4, &hit)) continue;
      ++hits;
      ASSERT_NEAR(hit.point.z(), hf.HeightAt(hit.point.x(), hit.point.y()), 1e-5);
      // No earlier crossing: march the ray densely up to the hit.
      for (double t = 0; t < hit.t - 0.02; t += 0.02) {
        const Eigen::Vector3d p = c + t * dir;
        ASSERT_GT(p.z(), hf.HeightAt(p.x(), p.y()) - 1e-6) << "ray crossed the surface before t=" << hit.t;
      }
    }
  }
  EXPECT_GT(hits, 500);
}

struct Motion {
  double max_accel = 0;        // m/s^2
  double max_accel_jump = 0;   // m/s^2 between consecutive frames
  double max_ang_accel = 0;    // rad/s^2
  double max_speed_error = 0;  // relative
  double max_altitude_error = 0;
  double total_yaw_change = 0; // rad
};

Motion Analyse(const SynthOptions& o, const std::vector<SE3>& poses) {
  Motion m;
  const double dt = 1.0 / o.fps;
  std::vector<Eigen::Vector3d> accel;
  std::vector<Eigen::Vector3d> omega;
  for (std::size_t k = 0; k + 1 < poses.size(); ++k) {
    const Eigen::Vector3d v = (poses[k + 1].translation() - poses[k].translation()) / dt;
    m.max_speed_error = std::max(m.max_speed_error, std::abs(v.head<2>().norm() - o.speed) / o.speed);
    omega.push_back((poses[k].rotation().Inverse() * poses[k + 1].rotation()).Log() / dt);
    m.total_yaw_change += std::abs(omega.back().norm()) * dt;
    if (k > 0) {
      accel.push_back((poses[k + 1].translation() - 2 * poses[k].translation() + poses[k - 1].translation()) /
                      (dt * dt));
      m.max_accel = std::max(m.max_accel, accel.back().norm());
    }
  }
  for (std::size_t k = 1; k < accel.size(); ++k) {
    m.max_accel_jump = std::max(m.max_accel_jump, (accel[k] - accel[k - 1]).norm());
  }
  for (std::size_t k = 1; k < omega.size(); ++k) {
    m.max_ang_accel = std::max(m.max_ang_accel, (omega[k] - omega[k - 1]).norm() / dt);
  }
  for (const SE3& pose : poses) {
    const Eigen::Vector3d& p = pose.translation();
    m.max_altitude_error = std::max(m.max_altitude_error, std::abs(p.z() - TerrainHeight(p.x(), p.y(), o) - o.altitude));
  }
  return m;
}

TEST(SynthTrajectory, SmoothAtRequestedSpeedAndAltitude) {
  for (const auto kind : {TrajectoryKind::kLawnmower, TrajectoryKind::kLoop, TrajectoryKind::kOrbit}) {
    SCOPED_TRACE(TrajectoryKindName(kind));
    SynthOptions o;
    o.trajectory = kind;
    o.frames = 900;
    o.pitch_deg = kind == TrajectoryKind::kOrbit ? 45 : 10;
    const std::vector<SE3> poses = MakeTrajectory(o, Terrain(o));
    ASSERT_EQ(poses.size(), 900u);
    const Motion m = Analyse(o, poses);
    EXPECT_LT(m.max_accel, 6.0);        // a gentle drone, no jumps in velocity
    EXPECT_LT(m.max_accel_jump, 0.5);   // continuous acceleration (C2 path)
    EXPECT_LT(m.max_ang_accel, 1.5);    // no jumps in heading rate
    EXPECT_LT(m.max_speed_error, 0.05);
    EXPECT_LT(m.max_altitude_error, o.relief);
    EXPECT_GT(m.total_yaw_change, 0.5);  // the camera does turn along the way
    // Nadir-ish camera: the optical axis points down.
    for (const SE3& pose : poses) ASSERT_LT((pose.rotation() * Eigen::Vector3d::UnitZ()).z(), -0.5);
  }
}

TEST(SynthTrajectory, LoopReturnsOverItsStart) {
  SynthOptions o;
  o.trajectory = TrajectoryKind::kLoop;
  o.frames = 1500;
  const std::vector<SE3> poses = MakeTrajectory(o, Terrain(o));
  double far = 0;
  double closest_late = 1e9;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const double d = (poses[k].translation() - poses[0].translation()).head<2>().norm();
    far = std::max(far, d);
    if (k > poses.size() * 3 / 4) closest_late = std::min(closest_late, d);
  }
  EXPECT_GT(far, 100.0);
  EXPECT_LT(closest_late, 5.0);
}

// Stop-and-yaw: every stop_every metres the drone slows to a hover, yaws in place and flies on
// with the new heading; speed and yaw change smoothly, and the hover is exactly still.
TEST(SynthTrajectory, StopAndYawHoversStillTurnsInPlaceAndFliesOn) {
  SynthOptions o;
  EXPECT_DOUBLE_EQ(ProgressAt(o, 3.0).metres, 30.0);  // no stops: speed x time
  EXPECT_DOUBLE_EQ(ProgressAt(o, 3.0).extra_yaw, 0.0);
  o.stop_every = 50;  // 5 s of cruise, then a 6 s stop: 1.5 s ramps around a 3 s yaw in place
  o.stop_yaw_deg = 90;
  const double ramp = o.StopRampSeconds();
  ASSERT_DOUBLE_EQ(ramp, 1.5);
  EXPECT_NEAR(ProgressAt(o, 5.0).metres, 50.0, 1e-9);
  const FlightProgress hover_start = ProgressAt(o, 5.0 + ramp);
  const FlightProgress hover_end = ProgressAt(o, 11.0 - ramp - 1e-9);
  EXPECT_NEAR(hover_start.metres, 50.0 + 0.5 * o.speed * ramp, 1e-9);  // half a ramp at speed
  EXPECT_DOUBLE_EQ(hover_end.metres, hover_start.metres);               // still while yawing
  EXPECT_NEAR(hover_start.extra_yaw, 0.0, 1e-9);
  EXPECT_NEAR(hover_end.extra_yaw, std::numbers::pi / 2, 1e-6);
  // After the stop: cruising again at full speed, the yaw kept, one stop's distance behind.
  const FlightProgress after = ProgressAt(o, 12.0);
  EXPECT_NEAR(after.metres, 50.0 + o.speed * ramp + o.speed * 1.0, 1e-9);
  EXPECT_NEAR(after.extra_yaw, std::numbers::pi / 2, 1e-9);
  EXPECT_NEAR(ProgressAt(o, 26.0).extra_yaw, 2 * std::numbers::pi / 2, 1e-9);  // two stops done
  // Smooth: no jumps in position or yaw, speed never above cruise or below zero.
  double max_speed = 0, min_speed = 1e9, max_yaw_step = 0;
  for (double t = 0; t < 40; t += 0.01) {
    const FlightProgress a = ProgressAt(o, t), b = ProgressAt(o, t + 0.01);
    max_speed = std::max(max_speed, (b.metres - a.metres) / 0.01);
    min_speed = std::min(min_speed, (b.metres - a.metres) / 0.01);
    max_yaw_step = std::max(max_yaw_step, std::abs(b.extra_yaw - a.extra_yaw));
  }
  EXPECT_LT(max_speed, o.speed * 1.0001);
  EXPECT_GE(min_speed, -1e-9);
  EXPECT_LT(max_yaw_step, 0.01);  // < 0.6 deg per 10 ms: 90 deg over 3 s, eased

  // The rendered trajectory: the camera centre stands still during the hover while it turns.
  o.frames = 400;
  o.wobble_deg = 0;
  const std::vector<SE3> poses = MakeTrajectory(o, Terrain(o));
  const auto centre = [&](int f) { return poses[f].translation(); };
  const int f0 = static_cast<int>(std::ceil((5.0 + ramp) * o.fps));
  const int f1 = static_cast<int>(std::floor((11.0 - ramp) * o.fps)) - 1;
  EXPECT_LT((centre(f1) - centre(f0)).norm(), 1e-6);
  const Eigen::Matrix3d turn = (poses[f0].rotation().Inverse() * poses[f1].rotation()).matrix();
  EXPECT_GT(Eigen::AngleAxisd(turn).angle(), 0.5 * std::numbers::pi / 2);
}

// Take-off climb: the clip starts climb_from metres above the ground, rises straight up to
// the altitude with smooth vertical speed, and only then flies the path from rest.
TEST(SynthTrajectory, ClimbRisesStraightUpThenFliesThePath) {
  SynthOptions o;
  EXPECT_DOUBLE_EQ(ProgressAt(o, 3.0).height, o.altitude);  // no climb: at altitude throughout
  EXPECT_DOUBLE_EQ(o.ClimbSeconds(), 0.0);
  o.altitude = 100;
  o.climb_from = 30;
  o.climb_speed = 5;  // 70 m: 14 s at full speed plus half of each 1.5 s ramp
  const double ramp = o.ClimbRampSeconds();
  ASSERT_DOUBLE_EQ(ramp, 1.5);
  ASSERT_DOUBLE_EQ(o.ClimbSeconds(), 15.5);
  EXPECT_DOUBLE_EQ(ProgressAt(o, 0.0).height, 30.0);
  EXPECT_NEAR(ProgressAt(o, 7.75).height, 65.0, 1e-9);  // halfway up at half time (symmetric)
  EXPECT_DOUBLE_EQ(ProgressAt(o, 15.0).metres, 0.0);    // no path flown while climbing
  EXPECT_NEAR(ProgressAt(o, 15.5).height, 100.0, 1e-9);
  // The path starts from rest and then runs half a ramp behind.
  EXPECT_NEAR(ProgressAt(o, 15.5 + ramp).metres, 0.5 * o.speed * ramp, 1e-9);
  EXPECT_NEAR(ProgressAt(o, 25.0).metres, o.speed * (25.0 - 15.5 - 0.5 * ramp), 1e-9);
  EXPECT_DOUBLE_EQ(ProgressAt(o, 25.0).height, 100.0);
  // Smooth: vertical and horizontal speeds within bounds and continuous (no step above what
  // a raised-cosine ramp changes in 10 ms).
  double max_climb = 0, max_speed = 0, max_climb_change = 0, max_speed_change = 0;
  double last_climb = 0, last_speed = 0;
  for (double t = 0; t < 30; t += 0.01) {
    const FlightProgress a = ProgressAt(o, t), b = ProgressAt(o, t + 0.01);
    const double climb = (b.height - a.height) / 0.01, speed = (b.metres - a.metres) / 0.01;
    EXPECT_GE(climb, -1e-9);
    EXPECT_GE(speed, -1e-9);
    max_climb = std::max(max_climb, climb);
    max_speed = std::max(max_speed, speed);
    if (t > 0) {
      max_climb_change = std::max(max_climb_change, std::abs(climb - last_climb));
      max_speed_change = std::max(max_speed_change, std::abs(speed - last_speed));
    }
    last_climb = climb;
    last_speed = speed;
  }
  EXPECT_LT(max_climb, o.climb_speed * 1.0001);
  EXPECT_LT(max_speed, o.speed * 1.0001);
  EXPECT_LT(max_climb_change, 0.06);  // 5 m/s over 1.5 s: at most ~0.05 m/s per 10 ms
  EXPECT_LT(max_speed_change, 0.11);  // 10 m/s over 1.5 s

  // The rendered trajectory: straight up over the path's start, then away at altitude.
  o.frames = 600;
  o.wobble_deg = 0;
  const TerrainFn terrain = Terrain(o);
  const std::vector<SE3> poses = MakeTrajectory(o, terrain);
  const Eigen::Vector3d first = poses.front().translation(), top = poses[465].translation();
  EXPECT_LT((top.head<2>() - first.head<2>()).norm(), 1e-6);
  EXPECT_NEAR(top.z() - first.z(), 70.0, 1e-6);
  EXPECT_GT((poses.back().translation().head<2>() - top.head<2>()).norm(), 30.0);
  EXPECT_TRUE(o.ToJson().contains("climb_from"));
  EXPECT_FALSE(SynthOptions().ToJson().contains("climb_from"));  // older clips stay up to date
}

// Gimbal tilt at the start: the camera eases from tilt_from_deg to pitch_deg over tilt_seconds.
TEST(SynthTrajectory, GimbalTiltEasesToThePitch) {
  SynthOptions o;
  EXPECT_DOUBLE_EQ(o.PitchDegAt(0.0), 0.0);  // no tilt: the pitch throughout
  o.pitch_deg = 10;
  o.tilt_from_deg = 70;
  o.tilt_seconds = 4;
  EXPECT_DOUBLE_EQ(o.PitchDegAt(0.0), 70.0);
  EXPECT_NEAR(o.PitchDegAt(2.0), 40.0, 1e-9);  // halfway at half time (raised cosine)
  EXPECT_DOUBLE_EQ(o.PitchDegAt(4.0), 10.0);
  EXPECT_DOUBLE_EQ(o.PitchDegAt(9.0), 10.0);
  double last = 71;
  for (double t = 0; t < 5; t += 0.05) {
    EXPECT_LE(o.PitchDegAt(t), last);
    last = o.PitchDegAt(t);
  }
  EXPECT_TRUE(o.ToJson().contains("tilt_from_deg"));
  EXPECT_FALSE(SynthOptions().ToJson().contains("tilt_from_deg"));
  // The rendered camera: its optical axis 70 deg from straight down at the first frame.
  o.frames = 10;
  o.wobble_deg = 0;
  const std::vector<SE3> poses = MakeTrajectory(o, Terrain(o));
  const Eigen::Vector3d axis = poses.front().rotation().matrix().col(2);
  EXPECT_NEAR(std::acos(-axis.z()) * 180 / std::numbers::pi, 70.0, 1e-6);
}

TEST(SynthFiles, ClipFilesExistParseAndMatch) {
  SynthOptions o = SmallOptions();
  o.out = (fs::path(testing::TempDir()) / "glam_synth_files").string();
  o.force = true;
  RunSynth(o);
  const fs::path dir(o.out);

  const std::vector<TimedPose> timed = ReadTumTrajectory(dir / "gt_trajectory.tum");
  ASSERT_EQ(timed.size(), static_cast<std::size_t>(o.frames));
  EXPECT_NEAR(timed[1].timestamp, 1.0 / o.fps, 1e-6);
  std::vector<SE3> tum;
  for (const TimedPose& p : timed) tum.push_back(p.world_from_cam);
  const std::vector<SE3> poses = MakeTrajectory(o, Terrain(o));
  for (int k = 0; k < o.frames; ++k) {
    EXPECT_LT((tum[k].translation() - poses[k].translation()).norm(), 1e-6);
    EXPECT_LT((tum[k].rotation().Inverse() * poses[k].rotation()).Log().norm(), 1e-9);
  }

  const Intrinsics in = ReadIntrinsicsJson(dir / "intrinsics.json");
  const Intrinsics expected = MakeIntrinsics(o);
  EXPECT_EQ(in.width, o.width);
  EXPECT_EQ(in.height, o.height);
  EXPECT_DOUBLE_EQ(in.fx, expected.fx);
  EXPECT_NEAR(2 * std::atan(0.5 * o.width / in.fx) * 180 / M_PI, 60.0, 1e-9);

  std::ifstream surface_file(dir / "gt_surface.json");
  const nlohmann::json surface = nlohmann::json::parse(surface_file);
  EXPECT_EQ(surface["format"], "glam-heightfield");
  EXPECT_EQ(surface["version"], 1);
  const auto cols = surface["cols"].get<std::size_t>();
  const auto rows = surface["rows"].get<std::size_t>();
  EXPECT_EQ(fs::file_size(dir / surface["heights"].get<std::string>()), cols * rows * sizeof(float));

  cv::VideoCapture video((dir / "video.mp4").string(), cv::CAP_FFMPEG);
  ASSERT_TRUE(video.isOpened());
  int frames = 0;
  cv::Mat frame;
  while (video.read(frame)) {
    EXPECT_EQ(frame.size(), cv::Size(o.width, o.height));
    ++frames;
  }
  EXPECT_EQ(frames, o.frames);

  std::ifstream meta_file(dir / "synth.json");
  EXPECT_EQ(nlohmann::json::parse(meta_file), o.ToJson());
  EXPECT_FALSE(fs::exists(dir / "video.SRT"));  // only with gps_noise_m >= 0
  o.force = false;
  EXPECT_TRUE(RunSynth(o).skipped);  // same options: nothing to do
}

// `glam synth --gps-noise`: video.SRT in DJI's layout, one entry per frame at the frame's time,
// positions the true camera centres (east, north, up around kSynthGpsOrigin) plus the noise.
TEST(SynthFiles, GpsTrackFollowsTheTrueCentres) {
  SynthOptions o = SmallOptions();
  o.out = (fs::path(testing::TempDir()) / "glam_synth_gps").string();
  o.force = true;
  o.gps_noise_m = 0;
  RunSynth(o);
  const fs::path dir(o.out);
  const std::vector<TimedPose> truth = ReadTumTrajectory(dir / "gt_trajectory.tum");
  std::vector<GpsSample> gps = ReadGpsTrack(dir / "video.SRT");
  ASSERT_EQ(gps.size(), truth.size());
  const EnuFrame frame(synth::kSynthGpsOrigin);
  for (std::size_t i = 0; i < gps.size(); ++i) {
    EXPECT_NEAR(gps[i].time_s, truth[i].timestamp, 1e-3);
    // 7 decimals of a degree: ~1 cm; altitudes to the millimetre.
    EXPECT_LT((frame.EnuFromGeodetic(gps[i].position) - truth[i].world_from_cam.translation()).norm(), 0.03);
  }
  // With noise: the first fix exact (the origin of a georeferenced result), the rest scattered
  // by about the requested amount.
  const std::string noisy = synth::DjiSrtFromTrajectory(truth, 2.0, 5);
  gps = ParseDjiSrt(noisy);
  EXPECT_LT((frame.EnuFromGeodetic(gps[0].position) - truth[0].world_from_cam.translation()).norm(), 0.03);
  double sum = 0;
  for (std::size_t i = 1; i < gps.size(); ++i) {
    sum += (frame.EnuFromGeodetic(gps[i].position) - truth[i].world_from_cam.translation()).squaredNorm();
  }
  EXPECT_NEAR(std::sqrt(sum / static_cast<double>(gps.size() - 1) / 3), 2.0, 0.5);
}

TEST(SynthDeterminism, SameSeedSameWorldOtherSeedOtherWorld) {
  SynthOptions o = SmallOptions();
  o.frames = 5;
  o.altitude = 30;
  auto make = [](const SynthOptions& opts) {
    const std::vector<SE3> poses = MakeTrajectory(opts, Terrain(opts));
    return std::make_pair(poses, World::Generate(opts, poses));
  };
  const auto [poses1, world1] = make(o);
  const auto [poses2, world2] = make(o);
  EXPECT_EQ(world1.surface().heights(), world2.surface().heights());
  EXPECT_EQ(cv::norm(world1.albedo()[0], world2.albedo()[0], cv::NORM_INF), 0.0);
  for (std::size_t k = 0; k < poses1.size(); ++k) {
    EXPECT_EQ(poses1[k].translation(), poses2[k].translation());
  }
  SynthOptions other = o;
  other.seed = o.seed + 1;
  const auto [poses3, world3] = make(other);
  EXPECT_GT((poses3.back().translation() - poses1.back().translation()).norm(), 1.0);
  const bool same_size = world3.surface().heights().size() == world1.surface().heights().size();
  EXPECT_TRUE(!same_size || world3.surface().heights() != world1.surface().heights());
}

// Water and cloud shadows are the only parts of the world that change over time: rendered
// twice from one pose, a static world gives the same image, water changes where it is (and
// nowhere else), cloud shadows darken the ground and drift.
int ChangedPixels(const cv::Mat& a, const cv::Mat& b, int min_difference) {
  cv::Mat diff, grey;
  cv::absdiff(a, b, diff);
  cv::cvtColor(diff, grey, cv::COLOR_BGR2GRAY);
  return cv::countNonZero(grey >= min_difference);
}

TEST(SynthDynamicSurface, WaterCoversTheRequestedShareOfTheArea) {
  SynthOptions o = SmallOptions();
  for (const double fraction : {0.2, 0.5, 0.8}) {
    o.water_fraction = fraction;
    const DynamicSurface dynamic(o, -300, -200, 300, 200);
    int water = 0, sand = 0, n = 0;
    for (double y = -199; y < 200; y += 4) {
      for (double x = -299; x < 300; x += 4) {
        const DynamicSurface::Shore shore = dynamic.ShoreAt(x, y);
        water += shore.water >= 0.5;
        sand += shore.water < 0.5 && shore.sand > 0.5;
        ++n;
      }
    }
    EXPECT_NEAR(static_cast<double>(water) / n, fraction, 0.02) << fraction;
    EXPECT_GT(sand, 0) << "a beach along the shore";
    EXPECT_LT(static_cast<double>(sand) / n, 0.1) << fraction;
  }
  o.water_fraction = 0;
  const DynamicSurface dry(o, -300, -200, 300, 200);
  EXPECT_FALSE(dry.has_water());
  EXPECT_EQ(dry.ShoreAt(0, 0).water, 0.0);
  EXPECT_EQ(dry.CloudShadow(0, 0, 5.0), 0.0);
}

// Seen coarsely (a footprint of 0.45 m keeps only the 2 m ripples, which drift at
// (0.6, 0.25) m/s), water without renewal is the same pattern carried along; with renewal it
// is a different pattern after two renewal periods.
TEST(SynthDynamicSurface, RipplesDriftAndRenew) {
  auto correlation_after_drift = [](double renewal_s) {
    SynthOptions o = SmallOptions();
    o.water_fraction = 0.9;
    o.water_renewal_s = renewal_s;
    const DynamicSurface dynamic(o, -100, -100, 100, 100);
    const Eigen::Vector3d down(0, 0, -1);
    const Eigen::Vector3d sun = Eigen::Vector3d(1, 0, 0.2).normalized();  // no glint straight down
    const cv::Vec3f sky(0.9f, 0.85f, 0.8f);
    const double t = 3.0;
    std::vector<double> a, b;
    for (double y = -20; y < 20; y += 0.37) {
      for (double x = -20; x < 20; x += 0.37) {
        a.push_back(dynamic.ShadeWater({x, y, 0}, down, 0.45, 0.0, sun, sky)[0]);
        b.push_back(dynamic.ShadeWater({x + 0.6 * t, y + 0.25 * t, 0}, down, 0.45, t, sun, sky)[0]);
      }
    }
    const double ma = std::accumulate(a.begin(), a.end(), 0.0) / a.size();
    const double mb = std::accumulate(b.begin(), b.end(), 0.0) / b.size();
    double sab = 0, saa = 0, sbb = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      sab += (a[i] - ma) * (b[i] - mb);
      saa += (a[i] - ma) * (a[i] - ma);
      sbb += (b[i] - mb) * (b[i] - mb);
    }
    EXPECT_GT(saa, 0.0) << "the ripples show";
    return sab / std::sqrt(saa * sbb);
  };
  EXPECT_GT(correlation_after_drift(0.0), 0.999) << "a river's foam only drifts";
  EXPECT_LT(std::abs(correlation_after_drift(1.5)), 0.3) << "wind ripples come and go";
}

TEST(SynthDynamicSurface, WaterMovesOverTimeAndTheLandDoesNot) {
  SynthOptions o = SmallOptions();
  o.water_fraction = 0.5;
  o.frames = 10;
  const std::vector<SE3> poses = MakeTrajectory(o, Terrain(o));
  const World world = World::Generate(o, poses);
  const Renderer renderer(world, MakeIntrinsics(o));
  // A frame that sees both water and land (half the area the flight sees is water).
  int chosen = -1;
  double share = 0;
  for (int f = 0; f < o.frames && chosen < 0; ++f) {
    renderer.Render(poses[f], 0.0, &share);
    if (share > 0.15 && share < 0.85) chosen = f;
  }
  ASSERT_GE(chosen, 0) << "no view of the shore found";
  const cv::Mat at0 = renderer.Render(poses[chosen], 0.0, &share);
  const cv::Mat at0_again = renderer.Render(poses[chosen], 0.0);
  const cv::Mat at1 = renderer.Render(poses[chosen], 1.0);
  EXPECT_EQ(ChangedPixels(at0, at0_again, 1), 0) << "deterministic";
  const double pixels = static_cast<double>(at0.total());
  const double changed = ChangedPixels(at0, at1, 1) / pixels;
  // The ripples changed most of the water; the land (the rest, but the shore's blend) not at all.
  EXPECT_GT(changed, 0.5 * share);
  EXPECT_LT(changed, share + 0.05);

  SynthOptions dry = o;
  dry.water_fraction = 0;
  const World dry_world = World::Generate(dry, poses);
  const Renderer dry_renderer(dry_world, MakeIntrinsics(dry));
  EXPECT_EQ(ChangedPixels(dry_renderer.Render(poses[chosen], 0.0), dry_renderer.Render(poses[chosen], 1.0), 1), 0)
      << "a world without water or clouds is static";
}

TEST(SynthDynamicSurface, CloudShadowsCoverTheRequestedShareAndDriftWithTheWind) {
  SynthOptions o = SmallOptions();
  o.cloud_shadow_fraction = 0.4;
  const DynamicSurface dynamic(o, -300, -200, 300, 200);
  EXPECT_NEAR(dynamic.wind().norm(), 7.0, 1e-9);
  int shaded = 0, n = 0;
  for (double y = -199; y < 200; y += 4) {
    for (double x = -299; x < 300; x += 4) {
      const double now = dynamic.CloudShadow(x, y, 0.0);
      shaded += now >= 0.5;
      ++n;
      // The same shadow 3 s later, carried by the wind.
      const Eigen::Vector2d later = Eigen::Vector2d(x, y) + 3.0 * dynamic.wind();
      EXPECT_NEAR(dynamic.CloudShadow(later.x(), later.y(), 3.0), now, 1e-9);
    }
  }
  EXPECT_NEAR(static_cast<double>(shaded) / n, 0.4, 0.02);
}

TEST(SynthDynamicSurface, CloudShadowsOnlyDarkenTheImage) {
  SynthOptions o = SmallOptions();
  o.frames = 10;
  const std::vector<SE3> poses = MakeTrajectory(o, Terrain(o));
  SynthOptions cloudy = o;
  cloudy.cloud_shadow_fraction = 0.5;
  const World sunny_world = World::Generate(o, poses);
  const World cloudy_world = World::Generate(cloudy, poses);
  const Renderer sunny(sunny_world, MakeIntrinsics(o));
  const Renderer shaded(cloudy_world, MakeIntrinsics(cloudy));
  int darker = 0;
  int drifted = 0;
  for (int f = 0; f < o.frames; f += 3) {
    const cv::Mat s = sunny.Render(poses[f], 0.0);
    const cv::Mat c = shaded.Render(poses[f], 0.0);
    cv::Mat brighter, dimmed;
    cv::compare(c, s + cv::Scalar::all(1), brighter, cv::CMP_GT);
    EXPECT_EQ(cv::countNonZero(brighter.reshape(1)), 0) << "a shadow never brightens";
    cv::Mat grey_s, grey_c;
    cv::cvtColor(s, grey_s, cv::COLOR_BGR2GRAY);
    cv::cvtColor(c, grey_c, cv::COLOR_BGR2GRAY);
    grey_s.convertTo(grey_s, CV_32F);
    grey_c.convertTo(grey_c, CV_32F);
    cv::compare(grey_c, 0.8 * grey_s, dimmed, cv::CMP_LT);
    darker += cv::countNonZero(dimmed);
    // 5 s later at 7 m/s the shadows have moved 35 m.
    drifted += ChangedPixels(c, shaded.Render(poses[f], 5.0), 4);
  }
  EXPECT_GT(darker, 0);
  EXPECT_GT(drifted, 0);
}

TEST(SynthOptions, DefaultsAreValid) { EXPECT_NO_THROW(SynthOptions().Check()); }

TEST(SynthOptions, CheckRejectsNonsense) {
  auto rejects = [](auto mutate) {
    SynthOptions o;
    mutate(o);
    EXPECT_THROW(o.Check(), InputError);
  };
  rejects([](SynthOptions& o) { o.width = -640; });
  rejects([](SynthOptions& o) { o.height = 0; });
  rejects([](SynthOptions& o) { o.width = 641; });
  rejects([](SynthOptions& o) { o.pitch_deg = 85; });
  rejects([](SynthOptions& o) { o.pitch_deg = -5; });
  rejects([](SynthOptions& o) { o.fps = 0; });
  rejects([](SynthOptions& o) { o.frames = 0; });
  rejects([](SynthOptions& o) { o.altitude = -100; });
  rejects([](SynthOptions& o) { o.speed = 0; });
  rejects([](SynthOptions& o) { o.focal = -1; });
  rejects([](SynthOptions& o) { o.k1 = -0.5; o.k2 = -0.5; });  // not invertible in the image
  rejects([](SynthOptions& o) { o.cell_size = 0; });
  rejects([](SynthOptions& o) { o.stop_every = -10; });
  rejects([](SynthOptions& o) { o.stop_every = 50; o.stop_seconds = 0.5; });
  rejects([](SynthOptions& o) { o.stop_every = 50; o.stop_yaw_deg = 400; });
  rejects([](SynthOptions& o) { o.climb_from = 5; });           // roofs too close
  rejects([](SynthOptions& o) { o.climb_from = o.altitude; });  // nothing to climb
  rejects([](SynthOptions& o) { o.climb_from = 30; o.climb_speed = 0; });
  rejects([](SynthOptions& o) { o.tilt_seconds = 4; o.tilt_from_deg = 85; });  // beyond the renderer's 80
  rejects([](SynthOptions& o) { o.tilt_seconds = -1; });
  rejects([](SynthOptions& o) { o.rolling_shutter_ms = -1; });
  rejects([](SynthOptions& o) { o.rolling_shutter_ms = 40; });  // longer than a frame at 30 fps
  rejects([](SynthOptions& o) { o.water_fraction = 0.99; });         // nothing left to map
  rejects([](SynthOptions& o) { o.water_fraction = -0.1; });
  rejects([](SynthOptions& o) { o.cloud_shadow_fraction = 1.0; });
  EXPECT_THROW(ParseTrajectoryKind("zigzag"), InputError);
  SynthOptions rolling;
  rolling.rolling_shutter_ms = 30;
  EXPECT_TRUE(rolling.ToJson().contains("rolling_shutter_ms"));
  EXPECT_FALSE(SynthOptions().ToJson().contains("rolling_shutter_ms"));  // older clips stay up to date
  EXPECT_FALSE(SynthOptions().ToJson().contains("water_fraction"));
  EXPECT_FALSE(SynthOptions().ToJson().contains("cloud_shadow_fraction"));
  EXPECT_EQ(ParseTrajectoryKind("orbit"), TrajectoryKind::kOrbit);
}

}  // namespace
}  // namespace glam::synth
