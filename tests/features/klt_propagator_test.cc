#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "engine/core/error.h"
#include "engine/features/klt_propagator.h"
#include "engine/features/sift_extractor.h"
#include "tests/features/synthetic_texture.h"

namespace glam {
namespace {

using testing::RandomTexture;

cv::Mat Gray(const cv::Mat& bgr) {
  cv::Mat g;
  cv::cvtColor(bgr, g, cv::COLOR_BGR2GRAY);
  return g;
}

// `image` moved by (dx, dy) pixels: content at x appears at x + d (bicubic, reflected border).
cv::Mat Shifted(const cv::Mat& image, double dx, double dy) {
  const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, dx, 0, 1, dy);
  cv::Mat out;
  cv::warpAffine(image, out, m, image.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
  return out;
}

struct Scene {
  cv::Mat bgr = RandomTexture({640, 360}, 11);
  Features features = SiftExtractor().Extract(bgr);
};

TEST(KltPropagator, FollowsSubPixelMotionAndKeepsDescriptors) {
  const Scene scene;
  ASSERT_GT(scene.features.size(), 500u);
  KltPropagator klt;
  klt.SetReference(Gray(scene.bgr), scene.features);
  const double dx = 7.3, dy = -4.6;
  const Features moved = klt.Propagate(Gray(Shifted(scene.bgr, dx, dy)));
  EXPECT_FALSE(moved.detected);
  ASSERT_GT(moved.size(), scene.features.size() * 9 / 10);
  ASSERT_EQ(moved.descriptors.rows, static_cast<int>(moved.size()));
  ASSERT_EQ(moved.colors.size(), moved.size());
  std::vector<double> errors;
  for (std::size_t i = 0; i < moved.size(); ++i) {
    // Find the reference keypoint by its descriptor (inherited bit for bit).
    int source = -1;
    for (int r = 0; r < scene.features.descriptors.rows && source < 0; ++r) {
      if (cv::norm(scene.features.descriptors.row(r), moved.descriptors.row(static_cast<int>(i)), cv::NORM_INF) == 0 &&
          scene.features.keypoints[r].size == moved.keypoints[i].size) {
        source = r;
      }
    }
    ASSERT_GE(source, 0) << "descriptor " << i << " not inherited";
    EXPECT_EQ(moved.colors[i], scene.features.colors[source]);
    const cv::Point2f expected = scene.features.keypoints[source].pt + cv::Point2f(dx, dy);
    errors.push_back(std::hypot(moved.keypoints[i].pt.x - expected.x, moved.keypoints[i].pt.y - expected.y));
  }
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.1);  // median, pixels (SIFT itself: ~0.1-0.3)
  std::nth_element(errors.begin(), errors.begin() + errors.size() * 95 / 100, errors.end());
  EXPECT_LT(errors[errors.size() * 95 / 100], 0.3);
}

// The image motion the adaptive detection schedule plans with: the median distance from the
// reference positions, and the frames since the reference.
TEST(KltPropagator, MeasuresHowFarTheImageMovedSinceTheReference) {
  const Scene scene;
  KltPropagator klt;
  klt.SetReference(Gray(scene.bgr), scene.features);
  EXPECT_EQ(klt.median_displacement_px(), 0.0);
  EXPECT_EQ(klt.frames_since_reference(), 0);
  klt.Propagate(Gray(Shifted(scene.bgr, 3.0, 4.0)));
  EXPECT_NEAR(klt.median_displacement_px(), 5.0, 0.1);
  EXPECT_EQ(klt.frames_since_reference(), 1);
  klt.Propagate(Gray(Shifted(scene.bgr, 6.0, 8.0)));
  EXPECT_NEAR(klt.median_displacement_px(), 10.0, 0.1);
  EXPECT_EQ(klt.frames_since_reference(), 2);
  klt.SetReference(Gray(Shifted(scene.bgr, 6.0, 8.0)), scene.features);
  EXPECT_EQ(klt.median_displacement_px(), 0.0);
  EXPECT_EQ(klt.frames_since_reference(), 0);
}

TEST(KltPropagator, TracksEveryFrameFromTheReferenceWithoutDrift) {
  const Scene scene;
  KltPropagator klt;
  klt.SetReference(Gray(scene.bgr), scene.features);
  Features last;
  for (int k = 1; k <= 6; ++k) last = klt.Propagate(Gray(Shifted(scene.bgr, 3.1 * k, 1.7 * k)));
  ASSERT_GT(last.size(), scene.features.size() * 8 / 10);
  // Positions after six frames are as precise as after one: every frame is matched against
  // the reference, the previous result only seeds the search.
  std::vector<double> errors;
  for (std::size_t i = 0; i < last.size(); ++i) {
    double best = 1e9;
    for (const cv::KeyPoint& kp : scene.features.keypoints) {
      const cv::Point2f expected = kp.pt + cv::Point2f(3.1f * 6, 1.7f * 6);
      best = std::min(best, static_cast<double>(std::hypot(last.keypoints[i].pt.x - expected.x,
                                                           last.keypoints[i].pt.y - expected.y)));
    }
    errors.push_back(best);
  }
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.1);
}

// The scene moved 40 px right with its right half painted over by unrelated texture, tracked
// with `options`.
struct ReplacedHalf {
  std::size_t expected_left = 0;  // reference keypoints that stay visible on the left half
  std::size_t kept = 0;           // tracks returned
  std::size_t kept_right = 0;     // ... of them on the replaced half (all wrong)
  std::size_t near_border = 0;    // ... closer than 2 px to the left border
  std::size_t back = 0;           // tracks returned when the reference image is shown again
};

ReplacedHalf TrackIntoReplacedHalf(const KltOptions& options) {
  const Scene scene;
  KltPropagator klt(options);
  klt.SetReference(Gray(scene.bgr), scene.features);
  cv::Mat next = Shifted(scene.bgr, 40, 0);
  RandomTexture({320, 360}, 99).copyTo(next(cv::Rect(320, 0, 320, 360)));
  const Features moved = klt.Propagate(Gray(next));
  ReplacedHalf r;
  for (const cv::KeyPoint& kp : scene.features.keypoints) r.expected_left += kp.pt.x + 40 < 300 ? 1 : 0;
  r.kept = moved.size();
  for (const cv::KeyPoint& kp : moved.keypoints) {
    r.near_border += kp.pt.x < 2.0f ? 1 : 0;
    r.kept_right += kp.pt.x > 340 ? 1 : 0;
  }
  r.back = klt.Propagate(Gray(scene.bgr)).size();
  return r;
}

void ExpectReplacedHalfDropped(const ReplacedHalf& r) {
  EXPECT_EQ(r.near_border, 0u);
  EXPECT_GT(r.kept, r.expected_left * 9 / 10);
  EXPECT_LT(r.kept_right, r.kept / 20);  // the replaced half keeps almost nothing
  // Lost points stay lost: back to the reference image, only the survivors return.
  EXPECT_LE(r.back, r.kept);
}

TEST(KltPropagator, DropsPointsThatLeaveTheImageOrChangeAppearance) {
  ExpectReplacedHalfDropped(TrackIntoReplacedHalf(KltOptions{}));  // default: forward-backward
}

TEST(KltPropagator, PatchCorrelationCheckAlsoDropsReplacedPoints) {
  KltOptions ncc;
  ncc.max_forward_backward_px = 0;
  ncc.min_patch_correlation = 0.9;
  ExpectReplacedHalfDropped(TrackIntoReplacedHalf(ncc));
}

TEST(KltPropagator, WithoutAWrongTrackTestReplacedPointsSurvive) {
  // The two tests above are not vacuous: with neither check, the patch-error guard alone lets
  // many tracks on the replaced half through (smooth random texture differs little per pixel).
  KltOptions none;
  none.min_patch_correlation = -1;
  none.max_forward_backward_px = 0;
  const ReplacedHalf r = TrackIntoReplacedHalf(none);
  EXPECT_GT(r.kept_right, r.kept / 10);
}

TEST(KltPropagator, OptionsAreChecked) {
  KltOptions o;
  o.window_px = 14;
  EXPECT_THROW(o.Check(), InputError);
  o = {};
  o.min_survival_fraction = 1.5;
  EXPECT_THROW(o.Check(), InputError);
  o = {};
  o.min_patch_correlation = 1.5;
  EXPECT_THROW(o.Check(), InputError);
  EXPECT_NO_THROW(KltOptions{}.Check());
}

}  // namespace
}  // namespace glam
