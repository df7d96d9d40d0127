#include <random>

#include <gtest/gtest.h>

#include "engine/core/error.h"
#include "engine/features/feature_grid.h"
#include "engine/features/guided_matcher.h"

namespace glam {
namespace {

std::vector<Eigen::Vector2d> RandomPoints(int n, uint32_t seed, double w, double h) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(0, w), uy(0, h);
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < n; ++i) pts.emplace_back(ux(rng), uy(rng));
  return pts;
}

TEST(FeatureGrid, RadiusQueryEqualsExhaustiveSearch) {
  const auto pts = RandomPoints(3000, 1, 640, 480);
  const FeatureGrid grid(pts, 640, 480, 16.0);
  const auto centres = RandomPoints(200, 2, 700, 540);  // some outside the image
  for (const auto& c : centres) {
    for (double r : {0.0, 5.0, 17.0, 60.0}) {
      std::vector<int> got;
      grid.Query(c, r, &got);
      std::sort(got.begin(), got.end());
      std::vector<int> want;
      for (int i = 0; i < static_cast<int>(pts.size()); ++i) {
        if ((pts[static_cast<size_t>(i)] - c).norm() <= r) want.push_back(i);
      }
      EXPECT_EQ(got, want);
    }
  }
  std::vector<int> none;
  grid.Query({std::nan(""), 3.0}, 10, &none);
  EXPECT_TRUE(none.empty());
}

cv::Mat RandomDescriptors(int rows, uint64_t seed) {
  cv::Mat d(rows, 128, CV_32F);
  cv::RNG(seed).fill(d, cv::RNG::UNIFORM, 0.0, 1.0);
  for (int r = 0; r < rows; ++r) cv::normalize(d.row(r), d.row(r));
  return d;
}

TEST(GuidedMatcher, FindsTrueFeatureOnlyWithinRadius) {
  const auto pts = RandomPoints(2000, 3, 640, 480);
  const cv::Mat train = RandomDescriptors(2000, 4);
  const FeatureGrid grid(pts, 640, 480, 20.0);
  // Queries are noisy copies of train rows; predictions are offset from the true position.
  const std::vector<int> truth = {7, 100, 555, 1999};
  cv::Mat query(static_cast<int>(truth.size()), 128, CV_32F);
  cv::Mat noise(1, 128, CV_32F);
  for (size_t i = 0; i < truth.size(); ++i) {
    cv::RNG(50 + i).fill(noise, cv::RNG::NORMAL, 0.0, 0.01);
    query.row(static_cast<int>(i)) = train.row(truth[i]) + noise;
  }
  GuidedMatchOptions options;
  options.radius_px = 15.0;
  options.max_distance = 0.5f;  // random unit descriptors are ~1 apart; true twins ~0.1
  for (double offset : {3.0, 14.0, 16.0, 40.0}) {
    std::vector<Eigen::Vector2d> predicted;
    for (int t : truth) predicted.push_back(pts[static_cast<size_t>(t)] + Eigen::Vector2d(0.6, 0.8) * offset);
    const auto matches = MatchGuided(query, predicted, train, grid, options);
    if (offset <= options.radius_px) {
      ASSERT_EQ(matches.size(), truth.size()) << "offset " << offset;
      for (const Match& m : matches) EXPECT_EQ(m.train, truth[static_cast<size_t>(m.query)]);
    } else {
      EXPECT_TRUE(matches.empty()) << "offset " << offset;
    }
  }
}

TEST(GuidedMatcher, RatioTestAmongCandidatesAndUniqueTrain) {
  // Two features 5 px apart with near-identical descriptors: ambiguous inside the radius.
  const std::vector<Eigen::Vector2d> pts = {{100, 100}, {105, 100}, {300, 300}};
  cv::Mat train = RandomDescriptors(3, 5);
  cv::Mat noise(1, 128, CV_32F);
  cv::RNG(6).fill(noise, cv::RNG::NORMAL, 0.0, 0.005);
  train.row(1) = train.row(0) + noise;
  const FeatureGrid grid(pts, 400, 400, 10.0);
  cv::Mat query(2, 128, CV_32F);
  query.row(0) = train.row(0) + 0.5 * noise;  // halfway between features 0 and 1
  train.row(2).copyTo(query.row(1));
  GuidedMatchOptions options;
  options.radius_px = 10.0;
  auto matches = MatchGuided(query, {{101, 100}, {300, 301}}, train, grid, options);
  ASSERT_EQ(matches.size(), 1u);  // query 0 is ambiguous
  EXPECT_EQ(matches[0].train, 2);
  options.radius_px = 3.0;  // now only feature 0 is a candidate: a lone candidate is accepted
  matches = MatchGuided(query, {{101, 100}, {300, 301}}, train, grid, options);
  ASSERT_EQ(matches.size(), 2u);
  EXPECT_EQ(matches[0].train, 0);

  // Two queries competing for feature 2: the closer descriptor wins.
  cv::Mat twins(2, 128, CV_32F);
  twins.row(0) = train.row(2) + noise * 4;
  twins.row(1) = train.row(2) + noise;
  matches = MatchGuided(twins, {{300, 300}, {300, 300}}, train, grid, options);
  ASSERT_EQ(matches.size(), 1u);
  EXPECT_EQ(matches[0].query, 1);
  options.unique_train = false;
  EXPECT_EQ(MatchGuided(twins, {{300, 300}, {300, 300}}, train, grid, options).size(), 2u);
}

TEST(GuidedMatcher, OptionsCheck) {
  GuidedMatchOptions options;
  options.radius_px = 0;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace glam
