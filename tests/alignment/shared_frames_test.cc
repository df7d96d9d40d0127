// Shared-frame correspondences of a temporal edge: every frame both submaps posed gives its
// camera centre and a point ahead on its optical axis, in both submaps' units, consistent
// with the edge's similarity; badly posed frames are left out.
#include "engine/alignment/shared_frames.h"

#include <cmath>
#include <optional>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "engine/alignment/submap_verifier.h"
#include "engine/core/error.h"
#include "engine/core/placed_pose.h"

namespace glam {
namespace {

// A camera looking down from 100 m over world x = 4 m per frame, slightly rolled per frame.
SE3 TrueCamFromWorld(int frame) {
  const SO3 rotation = SO3::Exp(Eigen::Vector3d(M_PI + 0.01 * frame, 0.02, 0.005 * frame));
  const Eigen::Vector3d centre(4.0 * frame, 1.0, 100.0);
  return SE3(rotation, -(rotation * centre));
}

Submap MakeSubmap(std::uint32_t id, int first, int last, const Sim3& world_from_submap) {
  Submap s;
  s.id = id;
  s.first_frame = first;
  s.last_frame = last;
  const Sim3 submap_from_world = world_from_submap.Inverse();
  for (int f = first; f <= last; ++f) {
    FramePose pose;
    pose.frame_index = f;
    pose.cam_from_submap = CamFromSubmap(world_from_submap, TrueCamFromWorld(f));
    s.frame_poses.push_back(pose);
    if (f == first || f == last) s.keyframes.push_back({f, pose.cam_from_submap, 500.0});
  }
  // Ground points (depth scale ~100 m in world units).
  for (int i = 0; i < 50; ++i) {
    Landmark lm;
    lm.id = static_cast<std::uint32_t>(i);
    lm.point_in_submap = submap_from_world * Eigen::Vector3d(4.0 * first + 2.0 * i, (i % 7) - 3.0, 0.0);
    s.landmarks.push_back(lm);
  }
  return s;
}

const Sim3 kWorldFromA(1.0, SO3(), Eigen::Vector3d::Zero());
const Sim3 kWorldFromB(2.5, SO3::Exp(Eigen::Vector3d(0.1, -0.2, 0.3)), Eigen::Vector3d(10, -4, 3));

TEST(SharedFrames, GivesCentreAndAheadPairsConsistentWithTheEdge) {
  const Submap a = MakeSubmap(0, 0, 14, kWorldFromA);
  const Submap b = MakeSubmap(1, 10, 25, kWorldFromB);
  const Sim3 a_from_b = kWorldFromA.Inverse() * kWorldFromB;
  const std::vector<LandmarkMatch> pairs = SharedFrameMatches(a, b, a_from_b);
  ASSERT_EQ(pairs.size(), 2u * 5u);  // frames 10..14, two points each
  std::set<std::uint32_t> ids;
  const double depth = SubmapDepthScale(a);
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const LandmarkMatch& m = pairs[i];
    EXPECT_EQ(m.landmark_a, m.landmark_b);
    ids.insert(m.landmark_a);
    EXPECT_LT((a_from_b * m.point_in_b - m.point_in_a).norm(), 1e-9 * depth) << "pair " << i;
  }
  EXPECT_EQ(ids.size(), pairs.size());
  EXPECT_EQ(*ids.begin(), kSharedFrameIdBase + 2 * 10);
  // Centres of frame 10 and the point one depth ahead on its axis.
  const Eigen::Vector3d centre = a.frame_poses[10].cam_from_submap.Inverse().translation();
  EXPECT_LT((pairs[0].point_in_a - centre).norm(), 1e-9);
  EXPECT_NEAR((pairs[1].point_in_a - centre).norm(), depth, 1e-9 * depth);
}

TEST(SharedFrames, LeavesOutFramesThatDisagreeAndNeedsAnOverlap) {
  const Submap a = MakeSubmap(0, 0, 14, kWorldFromA);
  Submap b = MakeSubmap(1, 10, 25, kWorldFromB);
  const Sim3 a_from_b = kWorldFromA.Inverse() * kWorldFromB;
  // Frame 12 badly posed in b: 5 degrees off (8.7 m at the point 100 m ahead, over the 2 %
  // default), and frame 13 shifted by 5 m (world units).
  b.frame_poses[2].cam_from_submap = SE3(SO3::Exp(Eigen::Vector3d(0, 0.0873, 0)), Eigen::Vector3d::Zero()) *
                                     b.frame_poses[2].cam_from_submap;
  b.frame_poses[3].cam_from_submap =
      SE3(SO3(), Eigen::Vector3d(5.0 / kWorldFromB.scale(), 0, 0)) * b.frame_poses[3].cam_from_submap;
  const std::vector<LandmarkMatch> pairs = SharedFrameMatches(a, b, a_from_b);
  std::set<std::uint32_t> frames;
  for (const LandmarkMatch& m : pairs) frames.insert((m.landmark_a - kSharedFrameIdBase) / 2);
  EXPECT_EQ(frames, (std::set<std::uint32_t>{10, 11, 14}));

  const Submap later = MakeSubmap(2, 30, 40, kWorldFromB);
  EXPECT_TRUE(SharedFrameMatches(a, later, a_from_b).empty());
  SharedFrameOptions bad;
  bad.max_disagreement_fraction = 0;
  EXPECT_THROW(SharedFrameMatches(a, b, a_from_b, bad), InputError);
}

// Ground of gentle relief (world metres) and a submap's landmarks sampled on it at random, as
// two submaps triangulate different points of the same ground; a camera model to project them.
double GroundHeight(double x, double y) { return 3.0 * std::sin(0.05 * x) + 2.0 * std::cos(0.07 * y); }

void AddGroundLandmarks(Submap* s, const Sim3& world_from_submap, unsigned seed, double x0, double x1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(x0, x1), uy(-70, 70);
  s->landmarks.clear();
  const Sim3 submap_from_world = world_from_submap.Inverse();
  for (std::uint32_t i = 0; i < 4000; ++i) {
    Landmark lm;
    lm.id = i;
    const double x = ux(rng), y = uy(rng);
    lm.point_in_submap = submap_from_world * Eigen::Vector3d(x, y, GroundHeight(x, y));
    s->landmarks.push_back(lm);
  }
  s->intrinsics.width = 640;
  s->intrinsics.height = 360;
  s->intrinsics.fx = s->intrinsics.fy = 500;
  s->intrinsics.cx = 319.5;
  s->intrinsics.cy = 179.5;
}

double RotationErrorDeg(const Sim3& a, const Sim3& b) {
  return (a.rotation() * b.rotation().Inverse()).Log().norm() * 180 / M_PI;
}

// The open submap's placement from the frames it shares with the previous one (the live
// preview): with landmarks, the scale comes from the depths of the same image points, and
// stays right when the shared camera centres are noisy (the few shared frames span only a
// short path, so their spread alone gives the scale poorly).
TEST(SharedFrames, EstimateRecoversTheSimilarityFromSharedFramesAndDepths) {
  Submap a = MakeSubmap(0, 0, 14, kWorldFromA);
  Submap b = MakeSubmap(1, 10, 25, kWorldFromB);
  AddGroundLandmarks(&a, kWorldFromA, 1, -60, 120);
  AddGroundLandmarks(&b, kWorldFromB, 2, -20, 160);
  const Sim3 a_from_b = kWorldFromA.Inverse() * kWorldFromB;
  const std::optional<Sim3> exact = EstimateFromSharedFrames(a, b);
  ASSERT_TRUE(exact.has_value());
  EXPECT_NEAR(exact->scale() / a_from_b.scale(), 1.0, 2e-3);
  EXPECT_LT(RotationErrorDeg(*exact, a_from_b), 0.05);
  EXPECT_LT((exact->translation() - a_from_b.translation()).norm(), 0.1);

  // Centres of b's shared frames off by ~0.3 m (world), as tracking leaves them.
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, 0.3 / kWorldFromB.scale());
  for (FramePose& pose : b.frame_poses) {
    pose.cam_from_submap = pose.cam_from_submap * SE3(SO3(), Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
  }
  const std::optional<Sim3> noisy = EstimateFromSharedFrames(a, b);
  ASSERT_TRUE(noisy.has_value());
  EXPECT_NEAR(noisy->scale() / a_from_b.scale(), 1.0, 3e-3);  // measured 0.2 %, centres only 1 %
  EXPECT_LT(RotationErrorDeg(*noisy, a_from_b), 0.2);  // measured 0.06
  // Without landmarks to compare depths, the centres' spread gives the scale: worse.
  Submap bare_a = a, bare_b = b;
  bare_a.intrinsics.width = bare_b.intrinsics.width = 0;
  const std::optional<Sim3> centres_only = EstimateFromSharedFrames(bare_a, bare_b);
  ASSERT_TRUE(centres_only.has_value());
  EXPECT_GT(std::abs(centres_only->scale() / a_from_b.scale() - 1.0), std::abs(noisy->scale() / a_from_b.scale() - 1.0));
}

TEST(SharedFrames, EstimateNeedsTwoAgreeingSharedFrames) {
  const Submap a = MakeSubmap(0, 0, 14, kWorldFromA);
  const Sim3 a_from_b = kWorldFromA.Inverse() * kWorldFromB;
  // Noiseless centres: exact even without landmark depths (no intrinsics here).
  const std::optional<Sim3> exact = EstimateFromSharedFrames(a, MakeSubmap(1, 10, 25, kWorldFromB));
  ASSERT_TRUE(exact.has_value());
  EXPECT_NEAR(exact->scale() / a_from_b.scale(), 1.0, 1e-6);
  // One shared frame (14) is not enough; none after a tracking loss either.
  EXPECT_FALSE(EstimateFromSharedFrames(a, MakeSubmap(1, 14, 25, kWorldFromB)).has_value());
  EXPECT_FALSE(EstimateFromSharedFrames(a, MakeSubmap(2, 30, 40, kWorldFromB)).has_value());
  // A badly posed shared frame is left out and the rest still gives the similarity.
  Submap b = MakeSubmap(1, 10, 25, kWorldFromB);
  b.frame_poses[2].cam_from_submap = SE3(SO3::Exp(Eigen::Vector3d(0, 0.0873, 0)), Eigen::Vector3d::Zero()) *
                                     b.frame_poses[2].cam_from_submap;
  const std::optional<Sim3> robust = EstimateFromSharedFrames(a, b);
  ASSERT_TRUE(robust.has_value());
  EXPECT_NEAR(robust->scale() / a_from_b.scale(), 1.0, 1e-3);
  EXPECT_LT(RotationErrorDeg(*robust, a_from_b), 0.05);
}

}  // namespace
}  // namespace glam
