#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "engine/core/error.h"
#include "engine/features/feature_matcher.h"
#include "engine/features/sift_extractor.h"
#include "tests/features/synthetic_texture.h"

namespace glam {
namespace {

using testing::RandomTexture;

struct WarpedPair {
  cv::Mat homography;  // maps image a pixels to image b pixels
  Features a, b;
};

// A texture seen again after rotation, zoom and a mild perspective change.
const WarpedPair& Pair() {
  static const WarpedPair pair = [] {
    WarpedPair p;
    const cv::Mat a = RandomTexture({640, 480}, 11);
    cv::Mat H = cv::getRotationMatrix2D(cv::Point2f(320, 240), 20.0, 0.85);
    H.push_back(cv::Mat((cv::Mat_<double>(1, 3) << 1e-4, -5e-5, 1.0)));
    p.homography = H;
    cv::Mat b;
    cv::warpPerspective(a, b, H, a.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
    SiftOptions options;
    options.max_features = 1500;
    SiftExtractor extractor(options);
    p.a = extractor.Extract(a);
    p.b = extractor.Extract(b);
    return p;
  }();
  return pair;
}

double HomographyError(const WarpedPair& p, const Match& m) {
  std::vector<cv::Point2f> src{p.a.keypoints[static_cast<size_t>(m.query)].pt}, dst;
  cv::perspectiveTransform(src, dst, p.homography);
  const cv::Point2f d = dst[0] - p.b.keypoints[static_cast<size_t>(m.train)].pt;
  return std::hypot(d.x, d.y);
}

double FractionCorrect(const WarpedPair& p, const std::vector<Match>& matches) {
  int ok = 0;
  for (const Match& m : matches) ok += HomographyError(p, m) < 3.0 ? 1 : 0;
  return static_cast<double>(ok) / static_cast<double>(matches.size());
}

class MatcherOnWarp : public ::testing::TestWithParam<MatcherType> {};

TEST_P(MatcherOnWarp, MatchesAgreeWithHomography) {
  const WarpedPair& p = Pair();
  MatchOptions options;
  options.type = GetParam();
  const auto matches = MatchDescriptors(p.a.descriptors, p.b.descriptors, options);
  EXPECT_GT(matches.size(), 300u);
  EXPECT_GT(FractionCorrect(p, matches), 0.9);
  for (size_t i = 1; i < matches.size(); ++i) EXPECT_LT(matches[i - 1].query, matches[i].query);

  options.mutual = true;
  const auto mutual = MatchDescriptors(p.a.descriptors, p.b.descriptors, options);
  EXPECT_LE(mutual.size(), matches.size());
  EXPECT_GT(mutual.size(), matches.size() * 8 / 10);
  std::vector<int> trains;
  for (const Match& m : mutual) trains.push_back(m.train);
  std::sort(trains.begin(), trains.end());
  EXPECT_EQ(std::adjacent_find(trains.begin(), trains.end()), trains.end());
  EXPECT_GE(FractionCorrect(p, mutual), FractionCorrect(p, matches) - 1e-9);
}

INSTANTIATE_TEST_SUITE_P(Backends, MatcherOnWarp,
                         ::testing::Values(MatcherType::kFlann, MatcherType::kBruteForce,
                                           MatcherType::kAuto));

TEST(FeatureMatcher, FlannIsDeterministic) {
  const WarpedPair& p = Pair();
  MatchOptions options;
  options.type = MatcherType::kFlann;
  const auto first = MatchDescriptors(p.a.descriptors, p.b.descriptors, options);
  const auto second = MatchDescriptors(p.a.descriptors, p.b.descriptors, options);
  ASSERT_EQ(first.size(), second.size());
  for (size_t i = 0; i < first.size(); ++i) {
    EXPECT_EQ(first[i].query, second[i].query);
    EXPECT_EQ(first[i].train, second[i].train);
  }
}

cv::Mat RandomDescriptors(int rows, uint64_t seed) {
  cv::Mat d(rows, 128, CV_32F);
  cv::RNG(seed).fill(d, cv::RNG::UNIFORM, 0.0, 1.0);
  for (int r = 0; r < rows; ++r) cv::normalize(d.row(r), d.row(r));
  return d;
}

TEST(FeatureMatcher, RatioTestRejectsAmbiguousMatches) {
  const cv::Mat train = RandomDescriptors(50, 21);
  // Train row 10 gets a near twin (row 11): a query close to both is ambiguous.
  cv::Mat noise(1, 128, CV_32F);
  cv::RNG(22).fill(noise, cv::RNG::NORMAL, 0.0, 0.01);
  train.row(10).copyTo(train.row(11));
  train.row(11) += noise;
  cv::Mat query(2, 128, CV_32F);
  train.row(10).copyTo(query.row(0));
  query.row(0) += 0.5 * noise;  // halfway between rows 10 and 11
  train.row(30).copyTo(query.row(1));                  // unambiguous
  cv::RNG(23).fill(noise, cv::RNG::NORMAL, 0.0, 0.01);
  query.row(1) += noise;

  for (MatcherType type : {MatcherType::kBruteForce, MatcherType::kFlann}) {
    MatchOptions options;
    options.type = type;
    auto matches = MatchDescriptors(query, train, options);
    ASSERT_EQ(matches.size(), 1u);
    EXPECT_EQ(matches[0].query, 1);
    EXPECT_EQ(matches[0].train, 30);
    options.ratio = 1.0f;  // ratio test off: the ambiguous query matches its nearest twin
    matches = MatchDescriptors(query, train, options);
    ASSERT_EQ(matches.size(), 2u);
    EXPECT_TRUE(matches[0].train == 10 || matches[0].train == 11);
    options.max_distance = 1e-6f;
    EXPECT_TRUE(MatchDescriptors(query, train, options).empty());
  }
}

TEST(FeatureMatcher, MutualCheckDropsManyToOne) {
  const cv::Mat train = RandomDescriptors(20, 31);
  cv::Mat query(2, 128, CV_32F);
  cv::Mat noise(1, 128, CV_32F);
  for (int r = 0; r < 2; ++r) {
    cv::RNG(32 + r).fill(noise, cv::RNG::NORMAL, 0.0, 0.02 * (r + 1));
    query.row(r) = train.row(5) + noise;  // both nearest to train 5; query 0 is closer
  }
  MatchOptions options;
  options.type = MatcherType::kBruteForce;
  EXPECT_EQ(MatchDescriptors(query, train, options).size(), 2u);
  options.mutual = true;
  const auto mutual = MatchDescriptors(query, train, options);
  ASSERT_EQ(mutual.size(), 1u);
  EXPECT_EQ(mutual[0].query, 0);
  EXPECT_EQ(mutual[0].train, 5);
}

TEST(FeatureMatcher, EmptyInputsAndChooser) {
  const cv::Mat d = RandomDescriptors(5, 41);
  EXPECT_TRUE(MatchDescriptors(cv::Mat(0, 128, CV_32F), d).empty());
  EXPECT_TRUE(MatchDescriptors(d, cv::Mat(0, 128, CV_32F)).empty());
  // A single train row has no second neighbour: the ratio test passes.
  EXPECT_EQ(MatchDescriptors(d.row(2), d.row(2)).size(), 1u);
  EXPECT_EQ(ChooseMatcher(100, 2000), MatcherType::kBruteForce);
  EXPECT_EQ(ChooseMatcher(2000, 2000), MatcherType::kFlann);
  MatchOptions bad;
  bad.ratio = 0.f;
  EXPECT_THROW(MatchDescriptors(d, d, bad), InputError);
}

}  // namespace
}  // namespace glam
