#include <random>

#include <gtest/gtest.h>

#include "engine/core/error.h"
#include "engine/core/so3.h"
#include "engine/features/epipolar_matcher.h"

namespace glam {
namespace {

constexpr double kFocal = 500.0;

cv::Mat RandomDescriptors(int rows, std::uint64_t seed) {
  cv::Mat d(rows, 128, CV_32F);
  cv::RNG(seed).fill(d, cv::RNG::UNIFORM, 0.0, 1.0);
  for (int r = 0; r < rows; ++r) cv::normalize(d.row(r), d.row(r));
  return d;
}

Eigen::Vector2d Normalised(const Eigen::Vector3d& p) { return p.head<2>() / p.z(); }

// Two nadir-ish views 10 m apart over ground 50-60 m away; points in the query camera.
struct TwoViews {
  SE3 cam_train_from_cam_query{SO3::Exp(Eigen::Vector3d(0.02, -0.05, 0.1)), Eigen::Vector3d(-10, 1, 0.5)};
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> query, train;
  cv::Mat query_descriptors, train_descriptors;

  explicit TwoViews(int n) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-25, 25), depth(50, 60);
    while (static_cast<int>(points.size()) < n) {
      const Eigen::Vector3d p(u(rng), 0.5 * u(rng), depth(rng));
      const Eigen::Vector3d in_train = cam_train_from_cam_query * p;
      if (in_train.z() <= 0 || std::abs(Normalised(in_train).x()) > 0.6 || std::abs(Normalised(in_train).y()) > 0.4) continue;
      points.push_back(p);
      query.push_back(Normalised(p));
      train.push_back(Normalised(in_train));
    }
    train_descriptors = RandomDescriptors(n, 11);
    query_descriptors = train_descriptors.clone();
    cv::Mat noise(n, 128, CV_32F);
    cv::RNG(12).fill(noise, cv::RNG::NORMAL, 0.0, 0.01);
    query_descriptors += noise;
  }

  // Appends a train feature at `at` with descriptor row `like` of the train set (+ noise).
  void AddTrain(const Eigen::Vector2d& at, int like, double noise_sigma) {
    cv::Mat row = train_descriptors.row(like).clone();
    cv::Mat noise(1, 128, CV_32F);
    cv::RNG(static_cast<std::uint64_t>(train.size())).fill(noise, cv::RNG::NORMAL, 0.0, noise_sigma);
    row += noise;
    train_descriptors.push_back(row);
    train.push_back(at);
  }

  std::vector<Match> Run(const EpipolarMatchOptions& options = {}) const {
    return MatchAlongEpipolarLines(query_descriptors, query, train_descriptors, train, cam_train_from_cam_query,
                                   kFocal, options);
  }
};

TEST(EpipolarMatcher, FindsEveryTrueCorrespondence) {
  const TwoViews views(400);
  const std::vector<Match> matches = views.Run();
  // Random descriptors: nothing else on a line looks alike, so every point is matched, but
  // lone candidates (nothing else within 3 px of the line) are rejected by default.
  EXPECT_GT(matches.size(), 350u);
  for (const Match& m : matches) EXPECT_EQ(m.query, m.train);
  EpipolarMatchOptions accept_lone;
  accept_lone.accept_lone_candidate = true;
  const std::vector<Match> all = views.Run(accept_lone);
  EXPECT_EQ(all.size(), 400u);
  for (const Match& m : all) EXPECT_EQ(m.query, m.train);
}

// The epipolar line of query i in the train view, scaled so that |line . (x, y, 1)| is the
// distance in normalised units.
Eigen::Vector3d EpipolarLine(const TwoViews& views, int i) {
  const Eigen::Vector3d line = Hat(views.cam_train_from_cam_query.translation()) *
                               views.cam_train_from_cam_query.rotation().matrix() *
                               Eigen::Vector3d(views.query[i].x(), views.query[i].y(), 1.0);
  return line / line.head<2>().norm();
}

TEST(EpipolarMatcher, AnIdenticalFeatureOffTheLineDoesNotCompete) {
  // Exact twins of point 0's descriptor 40 px either side of its epipolar line: a global ratio
  // test would call point 0 ambiguous; off the line they are not candidates.
  TwoViews views(400);
  const Eigen::Vector3d line = EpipolarLine(views, 0);
  ASSERT_LT(std::abs(line.dot(Eigen::Vector3d(views.train[0].x(), views.train[0].y(), 1.0))), 1e-9);
  const Eigen::Vector2d normal = line.head<2>();
  views.AddTrain(views.train[0] + 40.0 / kFocal * normal, 0, 0.0);
  views.AddTrain(views.train[0] - 40.0 / kFocal * normal, 0, 0.0);
  EpipolarMatchOptions accept_lone;
  accept_lone.accept_lone_candidate = true;
  int found = 0;
  for (const Match& m : views.Run(accept_lone)) {
    if (m.query != 0) continue;
    EXPECT_EQ(m.train, 0);
    ++found;
  }
  EXPECT_EQ(found, 1);
  // 2 px from the line they are candidates, and point 0 is ambiguous.
  TwoViews near(400);
  near.AddTrain(near.train[0] + 2.0 / kFocal * normal, 0, 0.0);
  for (const Match& m : near.Run(accept_lone)) EXPECT_NE(m.query, 0);
}

TEST(EpipolarMatcher, AnAlikeFeatureOnTheLineMakesTheMatchAmbiguous) {
  TwoViews views(400);
  // A near-twin of point 5 elsewhere on its epipolar line (at another depth in front of both
  // cameras): the ratio test among the candidates rejects point 5.
  const Eigen::Vector3d farther = views.points[5] * 1.3;
  views.AddTrain(Normalised(views.cam_train_from_cam_query * farther), 5, 0.01);
  for (const Match& m : views.Run()) EXPECT_NE(m.query, 5);
  // With the ratio at 1 (off) the closer descriptor wins.
  EpipolarMatchOptions no_ratio;
  no_ratio.ratio = 1.0f;
  bool found = false;
  for (const Match& m : views.Run(no_ratio)) found |= m.query == 5;
  EXPECT_TRUE(found);
}

TEST(EpipolarMatcher, CandidatesBehindACameraAreIgnored) {
  TwoViews views(400);
  // Point 9's exact descriptor where its ray would be seen at negative depth: the extension of
  // the epipolar line beyond the epipole. Mirror the true image point through the epipole.
  const Eigen::Vector3d epipole_h = views.cam_train_from_cam_query.translation();
  const Eigen::Vector2d epipole = epipole_h.head<2>() / epipole_h.z();
  const Eigen::Vector2d behind = epipole - (views.train[9] - epipole);
  views.AddTrain(behind, 9, 0.0);
  views.AddTrain(behind, 9, 0.0);  // two, so a candidate would also spoil the ratio test
  const std::vector<Match> matches = views.Run();
  bool found = false;
  for (const Match& m : matches) {
    if (m.query == 9) {
      found = true;
      EXPECT_EQ(m.train, 9);
    }
  }
  EXPECT_TRUE(found);
}

TEST(EpipolarMatcher, MutualKeepsTheCloserOfTwoQueries) {
  TwoViews views(400);
  // Query 3 becomes a second, noisier copy of query 2's descriptor at a position whose line
  // passes through train[2]: the same ray, so the same line.
  views.query[3] = views.query[2];
  cv::Mat noise(1, 128, CV_32F);
  cv::RNG(99).fill(noise, cv::RNG::NORMAL, 0.0, 0.05);
  views.query_descriptors.row(3) = views.train_descriptors.row(2) + noise;
  EpipolarMatchOptions accept_lone;
  accept_lone.accept_lone_candidate = true;
  int train_2 = 0;
  for (const Match& m : views.Run(accept_lone)) {
    if (m.train == 2) {
      ++train_2;
      EXPECT_EQ(m.query, 2);
    }
  }
  EXPECT_EQ(train_2, 1);
}

TEST(EpipolarMatcher, NoBaselineNoMatchesAndOptionsChecked) {
  TwoViews views(50);
  views.cam_train_from_cam_query.translation().setZero();
  EXPECT_TRUE(views.Run().empty());
  EpipolarMatchOptions bad;
  bad.max_line_distance_px = 0;
  EXPECT_THROW(bad.Check(), InputError);
  bad = {};
  bad.ratio = 2.0f;
  EXPECT_THROW(bad.Check(), InputError);
  EXPECT_THROW(MatchAlongEpipolarLines(views.query_descriptors, views.query, views.train_descriptors, views.train,
                                       SE3(SO3(), Eigen::Vector3d(1, 0, 0)), 0.0),
               InputError);
}

}  // namespace
}  // namespace glam
