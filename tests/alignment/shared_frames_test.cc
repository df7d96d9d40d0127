// Shared-frame correspondences of a temporal edge: every frame both submaps posed gives its
// camera centre and a point ahead on its optical axis, in both submaps' units, consistent
// with the edge's similarity; badly posed frames are left out.
#include "engine/alignment/shared_frames.h"

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

}  // namespace
}  // namespace glam
