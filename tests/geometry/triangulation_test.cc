#include <random>

#include <gtest/gtest.h>

#include "engine/core/error.h"
#include "engine/geometry/triangulation.h"
#include "tests/geometry/synthetic_scene.h"

namespace glam {
namespace {

using testing::Observe;
using testing::Rad;

std::vector<SE3> Cameras() {
  return {testing::DownwardCamera({0, 0, 30}, 0, 5), testing::DownwardCamera({6, 1, 31}, 10, 12),
          testing::DownwardCamera({-4, 5, 29}, -20, 8), testing::DownwardCamera({2, -6, 30}, 45, 20)};
}

TEST(Triangulation, CameraCenterAndAngle) {
  const SE3 pose = testing::DownwardCamera({1, 2, 3}, 30, 10);
  EXPECT_LT((CameraCenter(pose) - Eigen::Vector3d(1, 2, 3)).norm(), 1e-12);
  EXPECT_NEAR(TriangulationAngle({-1, 0, 0}, {1, 0, 0}, {0, 0, 1}), Rad(90), 1e-12);
  EXPECT_NEAR(TriangulationAngle({-1, 0, 0}, {1, 0, 0}, {0, 0, 10}), 2 * std::atan(0.1), 1e-12);
  EXPECT_NEAR(TriangulationAngle({0, 0, 0}, {0, 0, 0}, {0, 0, 10}), 0.0, 1e-12);
  EXPECT_NEAR(TriangulationAngle({-1, 0, 0}, {1, 0, 0}, {0, 0, 1e-9}), Rad(180), 1e-6);
}

TEST(Triangulation, NoiselessTwoAndMultiViewAreExact) {
  const auto cams = Cameras();
  std::mt19937 rng(1);
  for (const auto& X : testing::PointsInView(cams[0], 50, 15, 40, 0.3, rng)) {
    std::vector<Eigen::Vector2d> obs;
    for (const auto& c : cams) obs.push_back(Observe(c, X));
    const auto two = TriangulateDlt(std::span(cams).first(2), std::span<const Eigen::Vector2d>(obs).first(2));
    ASSERT_TRUE(two.has_value());
    EXPECT_LT((*two - X).norm(), 1e-8);
    TriangulationOptions options;
    options.refine = false;
    const Triangulation multi = Triangulate(cams, obs, options);
    ASSERT_TRUE(multi.ok()) << static_cast<int>(multi.status);
    EXPECT_LT((multi.point - X).norm(), 1e-8);
    EXPECT_LT(multi.max_error_px, 1e-6);
    // The reported angle is the largest pairwise one.
    double expected = 0;
    for (size_t i = 0; i < cams.size(); ++i)
      for (size_t j = i + 1; j < cams.size(); ++j)
        expected = std::max(expected, TriangulationAngle(CameraCenter(cams[i]), CameraCenter(cams[j]), X));
    EXPECT_NEAR(multi.max_angle_rad, expected, 1e-9);
  }
}

TEST(Triangulation, RefinementReducesReprojectionError) {
  const auto cams = Cameras();
  std::mt19937 rng(2);
  std::normal_distribution<double> noise(0.0, 1.0 / 1000.0);
  double dlt_sum = 0, refined_sum = 0;
  for (const auto& X : testing::PointsInView(cams[0], 100, 15, 40, 0.3, rng)) {
    std::vector<Eigen::Vector2d> obs;
    for (const auto& c : cams) obs.push_back(Observe(c, X) + Eigen::Vector2d(noise(rng), noise(rng)));
    auto cost = [&](const Eigen::Vector3d& P) {
      double sum = 0;
      for (size_t i = 0; i < cams.size(); ++i) sum += std::pow(NormalizedReprojectionError(cams[i], P, obs[i]), 2);
      return sum;
    };
    const Eigen::Vector3d dlt = *TriangulateDlt(cams, obs);
    Eigen::Vector3d refined = dlt;
    ASSERT_TRUE(RefineTriangulation(cams, obs, &refined));
    EXPECT_LE(cost(refined), cost(dlt) * (1 + 1e-9));
    dlt_sum += cost(dlt);
    refined_sum += cost(refined);
  }
  EXPECT_LT(refined_sum, dlt_sum);
}

TEST(Triangulation, ChecksFlagBadPoints) {
  const auto cams = Cameras();
  const Eigen::Vector3d X(1, 2, 3);
  std::vector<SE3> two = {cams[0], cams[1]};
  std::vector<Eigen::Vector2d> obs = {Observe(cams[0], X), Observe(cams[1], X)};
  TriangulationOptions options;
  EXPECT_TRUE(Triangulate(two, obs, options).ok());

  // Inconsistent observation in one of three views (a shift along the epipolar line of a
  // two-view pair would be absorbed by the depth): large reprojection error.
  std::vector<SE3> three = {cams[0], cams[1], cams[2]};
  std::vector<Eigen::Vector2d> bad = {obs[0], obs[1], Observe(cams[2], X)};
  EXPECT_TRUE(Triangulate(three, bad, options).ok());
  bad[2] += Eigen::Vector2d(0.05, 0.05);  // 70 px at f = 1000
  EXPECT_EQ(Triangulate(three, bad, options).status, TriangulationStatus::kLargeError);

  // A tiny baseline: not enough parallax.
  const SE3 near_twin = testing::DownwardCamera({0.05, 0, 30}, 0, 5);
  std::vector<SE3> narrow = {cams[0], near_twin};
  std::vector<Eigen::Vector2d> narrow_obs = {Observe(cams[0], X), Observe(near_twin, X)};
  const Triangulation small = Triangulate(narrow, narrow_obs, options);
  EXPECT_EQ(small.status, TriangulationStatus::kSmallAngle);
  EXPECT_LT((small.point - X).norm(), 1e-5);  // still exact without noise

  // Rays that meet behind the cameras.
  const Eigen::Vector3d above(1, 2, 60);  // cameras look down from 30 m
  const SE3 c0 = cams[0], c1 = cams[1];
  const Eigen::Vector3d p0 = c0 * above, p1 = c1 * above;
  std::vector<Eigen::Vector2d> behind = {p0.head<2>() / p0.z(), p1.head<2>() / p1.z()};
  EXPECT_EQ(Triangulate(two, behind, options).status, TriangulationStatus::kBehindCamera);

  // One view is not enough; identical rays from one centre have no solution.
  EXPECT_EQ(Triangulate(std::span(two).first(1), std::span<const Eigen::Vector2d>(obs).first(1), options).status,
            TriangulationStatus::kTooFewViews);
  std::vector<SE3> same = {cams[0], cams[0]};
  std::vector<Eigen::Vector2d> same_obs = {obs[0], obs[0]};
  const auto status = Triangulate(same, same_obs, options).status;
  EXPECT_TRUE(status == TriangulationStatus::kDegenerate || status == TriangulationStatus::kSmallAngle);

  options.focal_px = 0;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace glam
