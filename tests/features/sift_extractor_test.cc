#include <cmath>

#include <gtest/gtest.h>

#include "engine/core/error.h"
#include "engine/features/feature_matcher.h"
#include "engine/features/sift_extractor.h"
#include "tests/features/synthetic_texture.h"

namespace glam {
namespace {

using testing::RandomTexture;

TEST(SiftExtractor, FindsBudgetWithColoursAndRootSiftRows) {
  const cv::Mat image = RandomTexture({640, 360}, 1);
  SiftOptions options;
  options.max_features = 800;
  const Features f = SiftExtractor(options).Extract(image);
  ASSERT_GE(f.size(), 700u);
  EXPECT_LE(f.size(), 820u);  // cv::SIFT keeps ties at the cut
  ASSERT_EQ(f.descriptors.rows, static_cast<int>(f.size()));
  EXPECT_EQ(f.descriptors.cols, 128);
  EXPECT_EQ(f.descriptors.type(), CV_32F);
  ASSERT_EQ(f.colors.size(), f.size());
  for (size_t i = 0; i < f.size(); ++i) {
    EXPECT_NEAR(cv::norm(f.descriptors.row(static_cast<int>(i))), 1.0, 1e-4);
    const cv::Point2f& p = f.keypoints[i].pt;
    const cv::Vec3b bgr = image.at<cv::Vec3b>(static_cast<int>(std::lround(p.y)),
                                              static_cast<int>(std::lround(p.x)));
    EXPECT_EQ(f.colors[i], (Rgb{bgr[2], bgr[1], bgr[0]}));
  }
}

TEST(SiftExtractor, LowContrastThresholdFindsMoreOnSmoothTexture) {
  const cv::Mat image = RandomTexture({640, 360}, 2, 0.35);
  SiftOptions options;
  options.max_features = 100000;
  const size_t low = SiftExtractor(options).Extract(image).size();
  options.contrast_threshold = 0.04;  // OpenCV's default
  const size_t high = SiftExtractor(options).Extract(image).size();
  EXPECT_GT(low, 3 * high);
}

TEST(SiftExtractor, GridBucketingSpreadsFeatures) {
  // Strong texture on the left half, weak on the right.
  cv::Mat image = RandomTexture({640, 360}, 3);
  RandomTexture({320, 360}, 4, 0.45).copyTo(image(cv::Rect(320, 0, 320, 360)));
  SiftOptions options;
  options.max_features = 600;
  options.grid_cols = 0;  // off
  auto right_fraction = [&](const Features& f) {
    size_t right = 0;
    for (const auto& kp : f.keypoints) right += kp.pt.x >= 320 ? 1 : 0;
    return static_cast<double>(right) / static_cast<double>(f.size());
  };
  const double plain = right_fraction(SiftExtractor(options).Extract(image));
  options.grid_cols = 4;
  options.grid_rows = 3;
  const Features bucketed = SiftExtractor(options).Extract(image);
  EXPECT_LE(bucketed.size(), 600u);
  EXPECT_GE(bucketed.size(), 590u);
  EXPECT_LT(plain, 0.25);
  EXPECT_GT(right_fraction(bucketed), 0.4);
  // Rows from the aspect ratio (the default): 4 columns -> 2 rows on 640x360.
  SiftOptions defaults;
  defaults.max_features = 600;
  const Features automatic = SiftExtractor(defaults).Extract(image);
  EXPECT_GE(automatic.size(), 590u);
  EXPECT_GT(right_fraction(automatic), 0.4);
}

TEST(SiftExtractor, DownscaledExtractionMapsBackToFullResolution) {
  const cv::Mat image = RandomTexture({640, 480}, 5);
  SiftOptions full_options;
  full_options.max_features = 1500;
  SiftOptions half_options = full_options;
  half_options.extraction_scale = 0.5;
  const Features full = SiftExtractor(full_options).Extract(image);
  const Features half = SiftExtractor(half_options).Extract(image);
  const auto matches = MatchDescriptors(half.descriptors, full.descriptors);
  ASSERT_GT(matches.size(), 100u);
  int close = 0;
  for (const Match& m : matches) {
    const cv::Point2f d = half.keypoints[static_cast<size_t>(m.query)].pt -
                          full.keypoints[static_cast<size_t>(m.train)].pt;
    close += std::hypot(d.x, d.y) < 2.0 ? 1 : 0;
  }
  EXPECT_GT(close, 0.9 * static_cast<double>(matches.size()));
}

// Keypoints follow the camera model's convention (pixel centres at integer coordinates):
// Gaussian blobs drawn at known sub-pixel centres are found there. Raw cv::SIFT reports them
// 0.25 px right of and below (it detects on an image upsampled with half-pixel centres).
TEST(SiftExtractor, KeypointsSitAtTheFeatureInIntegerPixelCentreConvention) {
  cv::RNG rng(7);
  cv::Mat image(360, 640, CV_32F, cv::Scalar(0.8));
  std::vector<cv::Point2d> centres;
  for (int gy = 30; gy < 360 - 20; gy += 40) {
    for (int gx = 30; gx < 640 - 20; gx += 40) {
      const cv::Point2d c(gx + rng.uniform(-0.5, 0.5), gy + rng.uniform(-0.5, 0.5));
      centres.push_back(c);
      for (int y = gy - 15; y <= gy + 15; ++y) {
        for (int x = gx - 15; x <= gx + 15; ++x) {
          const double r2 = (x - c.x) * (x - c.x) + (y - c.y) * (y - c.y);
          image.at<float>(y, x) -= static_cast<float>(0.6 * std::exp(-r2 / (2 * 3.0 * 3.0)));
        }
      }
    }
  }
  cv::Mat grey;
  image.convertTo(grey, CV_8U, 255.0);
  for (double scale : {1.0, 0.5}) {
    SiftOptions options;
    options.extraction_scale = scale;
    const Features f = SiftExtractor(options).Extract(grey);
    double sum_x = 0, sum_y = 0;
    int found = 0;
    for (const cv::Point2d& c : centres) {
      double best = 1e9;
      cv::Point2d offset;
      for (const auto& kp : f.keypoints) {
        const cv::Point2d d(kp.pt.x - c.x, kp.pt.y - c.y);
        if (std::hypot(d.x, d.y) < best) {
          best = std::hypot(d.x, d.y);
          offset = d;
        }
      }
      if (best > 1.0) continue;
      sum_x += offset.x;
      sum_y += offset.y;
      ++found;
    }
    ASSERT_GE(found, static_cast<int>(0.9 * static_cast<double>(centres.size()))) << "scale " << scale;
    EXPECT_NEAR(sum_x / found, 0.0, 0.05) << "scale " << scale;
    EXPECT_NEAR(sum_y / found, 0.0, 0.05) << "scale " << scale;
  }
}

// The descriptor pass is chosen by the previous frame's keypoint count
// (SiftOptions::single_pass_extra_keypoints); what comes out must not depend on it.
TEST(SiftExtractor, OneAndTwoDescriptorPassesGiveTheSameFeatures) {
  for (const int budget : {300, 100000}) {  // bucketing picks a subset / keeps everything
    SiftOptions one_pass;
    one_pass.max_features = budget;
    one_pass.single_pass_extra_keypoints = 1000000;
    SiftOptions two_passes = one_pass;
    two_passes.single_pass_extra_keypoints = -1;
    const SiftExtractor a(one_pass), b(two_passes);
    for (const std::uint64_t seed : {7u, 8u}) {
      const cv::Mat image = RandomTexture({480, 270}, seed);
      const Features fa = a.Extract(image);
      const Features fb = b.Extract(image);
      ASSERT_EQ(fa.size(), fb.size());
      ASSERT_GT(fa.size(), budget < 1000 ? 290u : 1000u);
      for (std::size_t i = 0; i < fa.size(); ++i) {
        ASSERT_EQ(fa.keypoints[i].pt, fb.keypoints[i].pt);
        ASSERT_EQ(fa.colors[i], fb.colors[i]);
      }
      EXPECT_EQ(cv::norm(fa.descriptors, fb.descriptors, cv::NORM_INF), 0.0);
    }
  }
}

TEST(SiftExtractor, GreyInputAndBlankImage) {
  cv::Mat grey;
  cv::cvtColor(RandomTexture({320, 240}, 6), grey, cv::COLOR_BGR2GRAY);
  const Features f = SiftExtractor().Extract(grey);
  ASSERT_GT(f.size(), 50u);
  EXPECT_EQ(f.colors[0][0], f.colors[0][1]);
  const Features none = SiftExtractor().Extract(cv::Mat(240, 320, CV_8UC3, cv::Scalar::all(128)));
  EXPECT_TRUE(none.empty());
  EXPECT_EQ(none.descriptors.cols, 128);
  EXPECT_EQ(none.descriptors.rows, 0);
}

TEST(SiftOptions, CheckRejectsNonsense) {
  SiftOptions o;
  EXPECT_NO_THROW(o.Check());
  o.max_features = 0;
  EXPECT_THROW(o.Check(), InputError);
  o = {};
  o.grid_cols = 4;  // rows from the aspect ratio
  EXPECT_NO_THROW(o.Check());
  o = {};
  o.grid_cols = 0;
  o.grid_rows = 3;  // rows without columns
  EXPECT_THROW(o.Check(), InputError);
  o = {};
  o.extraction_scale = 1.5;
  EXPECT_THROW(SiftExtractor{o}, InputError);
}

}  // namespace
}  // namespace glam
