#include "engine/submap/outlier_filter.h"

#include <random>

#include <gtest/gtest.h>

#include "engine/core/error.h"

namespace glam {
namespace {

TEST(OutlierFilter, MeanNeighbourDistanceOnAGrid) {
  // Unit grid: every interior point's 4 nearest neighbours are at distance 1.
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) pts.emplace_back(i, j, 0);
  const auto mean = MeanNeighbourDistances(pts, 4);
  EXPECT_NEAR(mean[5 * 10 + 5], 1.0, 1e-6);
  EXPECT_NEAR(mean[0], (1 + 1 + std::sqrt(2.0) + 2) / 4, 1e-6);  // corner
}

TEST(OutlierFilter, RemovesFarAwayPointsOnly) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-50, 50);
  std::vector<Landmark> lms(1000);
  for (auto& lm : lms) lm.point_in_submap = Eigen::Vector3d(u(rng), u(rng), 0.1 * u(rng));
  // Five points from near-parallel rays: far below the ground.
  for (int i = 0; i < 5; ++i) lms[i * 100].point_in_submap = Eigen::Vector3d(u(rng), u(rng), -800 - 50 * i);
  std::vector<Landmark> filtered = lms;
  const std::size_t removed = RemoveIsolatedLandmarks(filtered, {});
  EXPECT_GE(removed, 5u);
  EXPECT_LE(removed, 60u);  // 2 sigma of a uniform cloud: a few percent at the border
  for (const auto& lm : filtered) EXPECT_GT(lm.point_in_submap.z(), -10);
}

TEST(OutlierFilter, OnlyLandmarksFromTheFirstTestedIdOnCanBeRemoved) {
  // The builder tests each landmark once (SubmapOptions::isolated_filter_once): landmarks below
  // first_tested_id passed earlier and stay, even where the statistic would remove them now.
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-50, 50);
  std::vector<Landmark> lms(1000);
  for (std::size_t i = 0; i < lms.size(); ++i) {
    lms[i].id = static_cast<std::uint32_t>(i);
    lms[i].point_in_submap = Eigen::Vector3d(u(rng), u(rng), 0.1 * u(rng));
  }
  lms[10].point_in_submap = Eigen::Vector3d(0, 0, -900);   // old: kept
  lms[900].point_in_submap = Eigen::Vector3d(0, 0, -900);  // new: removed
  std::vector<Landmark> all = lms;
  const std::size_t removed_all = RemoveIsolatedLandmarks(all, {});
  const std::size_t removed_new = RemoveIsolatedLandmarks(lms, {}, 500);
  EXPECT_LT(removed_new, removed_all);
  EXPECT_GE(removed_new, 1u);
  bool old_kept = false;
  for (const Landmark& lm : lms) {
    EXPECT_NE(lm.id, 900u);
    old_kept = old_kept || lm.id == 10u;
  }
  EXPECT_TRUE(old_kept);
  // The border points the full pass removes below id 500 all stay.
  std::size_t below = 0;
  for (const Landmark& lm : lms) below += lm.id < 500 ? 1 : 0;
  EXPECT_EQ(below, 500u);
}

TEST(OutlierFilter, FewPointsAreKept) {
  std::vector<Landmark> lms(10);
  for (int i = 0; i < 10; ++i) lms[i].point_in_submap = Eigen::Vector3d(i * i * i, 0, 0);
  EXPECT_EQ(RemoveIsolatedLandmarks(lms, {}), 0u);
}

TEST(OutlierFilter, ReprojectionFilterDropsBadObservationsAndOrphans) {
  Intrinsics in{"pinhole", 640, 360, 500, 500, 319.5, 179.5, 0, 0};
  std::vector<Keyframe> kfs(3);
  for (int k = 0; k < 3; ++k) {
    kfs[k].cam_from_submap = SE3(SO3(), Eigen::Vector3d(-k * 1.0, 0, 0));
    kfs[k].focal = 500;
  }
  const Camera cam(in);
  auto observe = [&](const Eigen::Vector3d& p, std::uint32_t k, double offset) {
    Eigen::Vector2d px;
    cam.Project(kfs[k].cam_from_submap * p, &px);
    return Observation{k, Eigen::Vector2f(float(px.x() + offset), float(px.y()))};
  };
  std::vector<Landmark> lms(3);
  lms[0].point_in_submap = {0, 0, 20};  // good in all three
  lms[1].point_in_submap = {1, 1, 20};  // bad in two: left with one observation -> removed
  lms[2].point_in_submap = {-1, 1, 20};  // bad in one: kept with two
  for (std::uint32_t k = 0; k < 3; ++k) {
    lms[0].observations.push_back(observe(lms[0].point_in_submap, k, 0.5));
    lms[1].observations.push_back(observe(lms[1].point_in_submap, k, k == 0 ? 0.0 : 10.0));
    lms[2].observations.push_back(observe(lms[2].point_in_submap, k, k == 2 ? 6.0 : 1.0));
  }
  EXPECT_EQ(RemoveReprojectionOutliers(in, kfs, lms, {}), 1u);
  ASSERT_EQ(lms.size(), 2u);
  EXPECT_EQ(lms[0].observations.size(), 3u);
  EXPECT_EQ(lms[1].observations.size(), 2u);
  EXPECT_EQ(lms[1].point_in_submap, Eigen::Vector3d(-1, 1, 20));
}

TEST(OutlierFilter, CompletionDropsLandmarksWhoseRaysNeverWidened) {
  // Keyframes 1 m apart along x, points 20 m ahead: two adjacent keyframes see a point under
  // ~2.9 degrees, keyframes 0 and 3 under ~8.6 degrees.
  std::vector<Keyframe> kfs(4);
  for (int k = 0; k < 4; ++k) kfs[k].cam_from_submap = SE3(SO3(), Eigen::Vector3d(-k * 1.0, 0, 0));
  auto landmark = [](std::vector<std::uint32_t> keyframes) {
    Landmark lm;
    lm.point_in_submap = {1.5, 0, 20};
    for (std::uint32_t k : keyframes) lm.observations.push_back({k, Eigen::Vector2f(0, 0)});
    return lm;
  };
  std::vector<Landmark> lms = {landmark({0, 1}), landmark({1, 2, 3}), landmark({0, 3}), landmark({2, 3})};
  OutlierFilterOptions options;
  options.min_completion_angle_deg = 4.0;
  EXPECT_EQ(RemoveWeaklyTriangulatedLandmarks(kfs, lms, options), 2u);
  ASSERT_EQ(lms.size(), 2u);
  EXPECT_EQ(lms[0].observations.size(), 3u);  // keyframes 1 and 3: ~5.7 degrees
  EXPECT_EQ(lms[1].observations.size(), 2u);  // keyframes 0 and 3
  options.min_completion_angle_deg = 0;  // off
  EXPECT_EQ(RemoveWeaklyTriangulatedLandmarks(kfs, lms, options), 0u);
  options.min_completion_angle_deg = -1;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace glam
