// The end-of-run joint bundle adjustment (engine/alignment/global_refinement.h) on a scene
// with known truth: two submaps of a straight nadir flight, each exact in its own frame, the
// second placed in the world by a Sim3 that is off (as a drifted join would be). Only the links
// the refinement is given (landmarks matched across the submaps, or a keyframe of the same
// frame in both) can tell it where the second submap's cameras belong; the checks are against
// the true world poses and points.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <vector>

#include "engine/alignment/global_refinement.h"
#include "engine/core/camera.h"
#include "engine/core/error.h"
#include "engine/core/placed_pose.h"

namespace glam {
namespace {

constexpr double kAltitude = 40.0;

Intrinsics Lens(double k1 = 0) {
  Intrinsics intrinsics;
  intrinsics.width = 640;
  intrinsics.height = 360;
  intrinsics.fx = intrinsics.fy = 400;
  intrinsics.cx = 319.5;
  intrinsics.cy = 179.5;
  intrinsics.SetK1(k1);
  return intrinsics;
}

// Camera looking straight down from (x, 0, altitude): camera x = world x, y = -world y.
SE3 TrueCamFromWorld(double x) {
  const SO3 rotation(Eigen::Vector3d(1, -1, -1).asDiagonal().toDenseMatrix());
  return SE3(rotation, -(rotation * Eigen::Vector3d(x, 0, kAltitude)));
}

double CentreX(std::int64_t frame) { return static_cast<double>(frame); }  // 1 m per frame

std::vector<Eigen::Vector3d> TruePoints() {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 48; ++i) {
    for (int j = 0; j < 12; ++j) {
      const double x = -25.0 + 3.3 * i;
      const double y = -15.0 + 2.7 * j;
      points.emplace_back(x, y, 3.0 * std::sin(0.3 * x) * std::cos(0.4 * y));
    }
  }
  return points;
}

// cam_from_submap of a camera whose metric world pose is cam_from_world, in a submap that the
// world sees through world_from_submap: x_cam = R (s R_s x + t_s) + t, divided by s.
// A submap of keyframes at `keyframe_frames` and every frame in [first, last], exact in the
// frame `world_from_submap`, observing every true point that projects into >= 2 keyframes;
// landmark ids are the point indices + id_offset.
Submap MakeSubmap(std::uint32_t id, const std::vector<std::int64_t>& keyframe_frames, std::int64_t first,
                  std::int64_t last, const Sim3& world_from_submap, const Intrinsics& lens,
                  std::uint32_t id_offset) {
  Submap submap;
  submap.id = id;
  submap.first_frame = first;
  submap.last_frame = last;
  submap.intrinsics = lens;
  for (const std::int64_t frame : keyframe_frames) {
    submap.keyframes.push_back({frame, CamFromSubmap(world_from_submap, TrueCamFromWorld(CentreX(frame))), lens.fx});
  }
  for (std::int64_t frame = first; frame <= last; ++frame) {
    submap.frame_poses.push_back(
        {frame, frame / 30.0, CamFromSubmap(world_from_submap, TrueCamFromWorld(CentreX(frame))), 100});
  }
  const Camera camera(lens);
  const std::vector<Eigen::Vector3d> points = TruePoints();
  for (std::size_t p = 0; p < points.size(); ++p) {
    Landmark landmark;
    landmark.id = static_cast<std::uint32_t>(p) + id_offset;
    landmark.point_in_submap = world_from_submap.Inverse() * points[p];
    for (std::size_t k = 0; k < keyframe_frames.size(); ++k) {
      Eigen::Vector2d pixel;
      if (camera.Project(TrueCamFromWorld(CentreX(keyframe_frames[k])) * points[p], &pixel) &&
          camera.InImage(pixel, 2)) {
        landmark.observations.push_back({static_cast<std::uint32_t>(k), pixel.cast<float>()});
      }
    }
    if (landmark.observations.size() >= 2) submap.landmarks.push_back(landmark);
  }
  return submap;
}

struct Scene {
  std::vector<Submap> submaps;
  std::vector<Sim3> world_from_submap;  // the given (wrong for submap 1) placements
  Sim3 true_world_from_b;
  std::vector<std::vector<LandmarkKey>> groups;  // every point both submaps observe
};

constexpr std::uint32_t kIdOffsetB = 10000;

// Submap 0 (keyframes 0..60) is placed right; submap 1 (keyframes from b_first_keyframe to
// 110) is exact in its frame but placed 1.5 deg, 0.6 m and 2 % off.
Scene MakeScene(std::int64_t b_first_keyframe, double b_k1 = 0) {
  Scene scene;
  const Sim3 world_from_a(1.7, SO3::Exp(Eigen::Vector3d(0.1, -0.2, 0.3)), Eigen::Vector3d(4, -2, 1));
  scene.true_world_from_b = Sim3(0.6, SO3::Exp(Eigen::Vector3d(-0.3, 0.1, 1.2)), Eigen::Vector3d(-7, 3, 2));
  const Sim3 error(1.02, SO3::Exp(Eigen::Vector3d(0.0, 0.0, 1.5 * M_PI / 180)), Eigen::Vector3d(0.6, 0, 0));
  std::vector<std::int64_t> a_frames, b_frames;
  for (std::int64_t f = 0; f <= 60; f += 10) a_frames.push_back(f);
  for (std::int64_t f = b_first_keyframe; f <= 110; f += 10) b_frames.push_back(f);
  scene.submaps.push_back(MakeSubmap(0, a_frames, 0, 60, world_from_a, Lens(), 0));
  scene.submaps.push_back(
      MakeSubmap(1, b_frames, b_first_keyframe, 110, scene.true_world_from_b, Lens(b_k1), kIdOffsetB));
  scene.world_from_submap = {world_from_a, error * scene.true_world_from_b};
  std::map<std::uint32_t, std::uint32_t> in_a;
  for (const Landmark& l : scene.submaps[0].landmarks) in_a[l.id] = l.id;
  for (const Landmark& l : scene.submaps[1].landmarks) {
    if (in_a.contains(l.id - kIdOffsetB)) scene.groups.push_back({{0, l.id - kIdOffsetB}, {1, l.id}});
  }
  return scene;
}

// The largest of `error(frame index, cam_from_world, centre)` over submap 1's frames (every
// frame, keyframes or not), posed in the world as the given placement puts them.
template <typename Error>
double WorstOverFrames(const Scene& scene, Error error) {
  double worst = 0;
  for (const FramePose& pose : scene.submaps[1].frame_poses) {
    const SE3 cam_from_world = CamFromWorld(scene.world_from_submap[1], pose.cam_from_submap);
    const Eigen::Vector3d centre = -(cam_from_world.rotation().Inverse() * cam_from_world.translation());
    worst = std::max(worst, error(pose.frame_index, cam_from_world, centre));
  }
  return worst;
}

// Distance of the centres from the truth.
double WorstCentreError(const Scene& scene) {
  return WorstOverFrames(scene, [](std::int64_t frame, const SE3&, const Eigen::Vector3d& centre) {
    return (centre - Eigen::Vector3d(CentreX(frame), 0, kAltitude)).norm();
  });
}

// Rotation error (degrees).
double WorstRotationErrorDeg(const Scene& scene) {
  return WorstOverFrames(scene, [](std::int64_t, const SE3& cam_from_world, const Eigen::Vector3d&) {
    return (cam_from_world.rotation() * TrueCamFromWorld(0).rotation().Inverse()).Log().norm() * 180 / M_PI;
  });
}

// Distance of the centres from the flight line (y = 0, z = altitude).
double WorstOffLineError(const Scene& scene) {
  return WorstOverFrames(scene, [](std::int64_t, const SE3&, const Eigen::Vector3d& centre) {
    return Eigen::Vector2d(centre.y(), centre.z() - kAltitude).norm();
  });
}

double WorstPointError(const Scene& scene, std::size_t s) {
  const std::vector<Eigen::Vector3d> points = TruePoints();
  const std::uint32_t offset = s == 0 ? 0 : kIdOffsetB;
  double worst = 0;
  for (const Landmark& l : scene.submaps[s].landmarks) {
    worst = std::max(worst, (scene.world_from_submap[s] * l.point_in_submap - points[l.id - offset]).norm());
  }
  return worst;
}

TEST(GlobalRefinement, MatchedLandmarksPullAMisplacedSubmapOntoTheTruth) {
  // No keyframe in common (submap 1 starts at frame 70), and submap 1 seen through another k1:
  // the matched landmarks are the only link, and the pixels must be re-expressed for one lens.
  Scene scene = MakeScene(70, -0.05);
  ASSERT_GT(scene.groups.size(), 100u);
  ASSERT_GT(WorstCentreError(scene), 0.5);
  const SE3 first_before = scene.submaps[0].keyframes[0].cam_from_submap;

  const GlobalRefinementSummary summary =
      RefineMapJointly(scene.submaps, scene.world_from_submap, scene.groups, {});
  ASSERT_TRUE(summary.applied) << summary.reason;
  EXPECT_EQ(summary.keyframes, 12);
  EXPECT_EQ(summary.shared_keyframes, 0);
  EXPECT_EQ(summary.joined_landmarks, static_cast<int>(scene.groups.size()));
  EXPECT_GT(summary.initial_rms_pixels, 1.0);
  EXPECT_LT(summary.final_rms_pixels, 0.01);
  EXPECT_LT(WorstCentreError(scene), 0.01);  // every frame, keyframe or not
  EXPECT_LT(WorstPointError(scene, 1), 0.01);
  EXPECT_LT(WorstPointError(scene, 0), 0.01);
  // The gauge: the first keyframe (and with it the world frame) does not move.
  EXPECT_LT((scene.submaps[0].keyframes[0].cam_from_submap.matrix() - first_before.matrix()).norm(), 1e-9);
}

TEST(GlobalRefinement, AKeyframeOfTheSameFrameInBothSubmapsIsOneCamera) {
  Scene scene = MakeScene(60);  // frame 60 is a keyframe of both
  scene.groups.clear();
  ASSERT_GT(WorstRotationErrorDeg(scene), 1.0);
  ASSERT_GT(WorstOffLineError(scene), 0.5);
  const GlobalRefinementSummary summary =
      RefineMapJointly(scene.submaps, scene.world_from_submap, scene.groups, {});
  ASSERT_TRUE(summary.applied) << summary.reason;
  EXPECT_EQ(summary.keyframes, 12);
  EXPECT_EQ(summary.shared_keyframes, 1);
  EXPECT_EQ(summary.joined_landmarks, 0);
  // One shared camera fixes submap 1's pose but not its scale (a Sim3 about that camera keeps
  // all of submap 1's reprojections): the cameras' rotations are right again and their
  // centres back on the flight line, at a distance from frame 60 only the scale can get wrong.
  const SE3 world_60_a = CamFromWorld(scene.world_from_submap[0], scene.submaps[0].keyframes.back().cam_from_submap);
  const SE3 world_60_b = CamFromWorld(scene.world_from_submap[1], scene.submaps[1].keyframes.front().cam_from_submap);
  EXPECT_LT((world_60_a.matrix() - world_60_b.matrix()).norm(), 1e-6);
  EXPECT_LT(WorstRotationErrorDeg(scene), 1e-3);
  EXPECT_LT(WorstOffLineError(scene), 0.01);
}

TEST(GlobalRefinement, UnlinkedSubmapsStayWhereTheyWere) {
  Scene scene = MakeScene(70);
  scene.groups.clear();
  const double before = WorstCentreError(scene);
  const GlobalRefinementSummary summary =
      RefineMapJointly(scene.submaps, scene.world_from_submap, scene.groups, {});
  // Nothing ties submap 1 to submap 0: exact on its own, it has nothing to change.
  ASSERT_TRUE(summary.applied) << summary.reason;
  EXPECT_NEAR(WorstCentreError(scene), before, 1e-6);
}

TEST(GlobalRefinement, LimitsAndChecksLeaveTheSubmapsUntouched) {
  Scene scene = MakeScene(70);
  const double before = WorstCentreError(scene);
  GlobalRefinementOptions options;
  options.max_keyframes = 11;
  GlobalRefinementSummary summary = RefineMapJointly(scene.submaps, scene.world_from_submap, scene.groups, options);
  EXPECT_FALSE(summary.ran);
  EXPECT_FALSE(summary.applied);
  EXPECT_NE(summary.reason.find("12 keyframes"), std::string::npos) << summary.reason;

  options = {};
  options.max_camera_shift_fraction = 1e-4;  // the 0.5 m correction is "too large" here
  summary = RefineMapJointly(scene.submaps, scene.world_from_submap, scene.groups, options);
  EXPECT_TRUE(summary.ran);
  EXPECT_FALSE(summary.applied);
  EXPECT_NE(summary.reason.find("moved"), std::string::npos) << summary.reason;
  EXPECT_GT(summary.max_camera_shift, 0.3);

  options = {};
  options.max_keyframes = 0;
  summary = RefineMapJointly(scene.submaps, scene.world_from_submap, scene.groups, options);
  EXPECT_FALSE(summary.ran);
  EXPECT_EQ(WorstCentreError(scene), before);

  std::vector<Submap> one = {scene.submaps[0]};
  summary = RefineMapJointly(one, {scene.world_from_submap[0]}, {}, {});
  EXPECT_FALSE(summary.ran);

  options = {};
  options.bundle_adjustment.refine_focal = true;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace glam
