// Rolling-shutter correction (engine/pipeline/rolling_shutter.h): keypoints observed row by
// row while the image moves are put back where they were at the frame's middle row, with the
// velocity from their own KLT tracks or, without one, from the frame's flow model.
#include "engine/pipeline/rolling_shutter.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "engine/core/error.h"
#include "engine/pipeline/decoder_worker.h"
#include "engine/submap/frame_record.h"
#include "tests/features/synthetic_texture.h"
#include "tests/pipeline/feature_stage_runner.h"

namespace glam {
namespace {

constexpr double kFps = 30.0;
const cv::Size kImage(640, 360);

// Image motion of a drone turning while it flies: rotation about a point off the image centre
// plus a drift, pixels at time t of a point that was at p0 at t = 0.
cv::Point2f TruePosition(cv::Point2f p0, double t) {
  const double omega = 0.35;  // rad/s, a brisk yaw
  const cv::Point2d centre(250, 140), drift(45, -70);
  const double c = std::cos(omega * t), s = std::sin(omega * t);
  const cv::Point2d d(p0.x - centre.x, p0.y - centre.y);
  return cv::Point2f(static_cast<float>(centre.x + c * d.x - s * d.y + drift.x * t),
                     static_cast<float>(centre.y + s * d.x + c * d.y + drift.y * t));
}

// Where a rolling shutter with this readout shows the point in frame k: the row it lands on
// was exposed at t_k + readout * (y / (H - 1) - 0.5) (fixed point: the row depends on the
// position).
cv::Point2f RollingObservation(cv::Point2f p0, int k, double readout_s) {
  cv::Point2f p = TruePosition(p0, k / kFps);
  for (int it = 0; it < 20; ++it) {
    p = TruePosition(p0, k / kFps + readout_s * (p.y / (kImage.height - 1) - 0.5));
  }
  return p;
}

// Frames as the feature stage makes them: detection every 6th frame (keypoint i has
// class_id i), KLT-propagated frames in between naming their detection frame's keypoints;
// every third track is lost right after its detection frame (no neighbour: the flow model).
std::vector<FrameFeatures> Frames(const std::vector<cv::Point2f>& ground, int frames, double readout_s) {
  std::vector<FrameFeatures> out;
  for (int k = 0; k < frames; ++k) {
    FrameFeatures f;
    f.index = k;
    f.timestamp_s = k / kFps;
    f.features.detected = k % 6 == 0;
    for (std::size_t i = 0; i < ground.size(); ++i) {
      if (!f.features.detected && i % 3 == 0) continue;
      cv::KeyPoint kp(RollingObservation(ground[i], k, readout_s), 3.0f);
      kp.class_id = static_cast<int>(i);
      f.features.keypoints.push_back(kp);
    }
    out.push_back(std::move(f));
  }
  return out;
}

std::vector<cv::Point2f> Ground() {
  std::vector<cv::Point2f> ground;
  cv::RNG rng(7);
  for (int i = 0; i < 300; ++i) {
    ground.emplace_back(rng.uniform(80.f, 560.f), rng.uniform(60.f, 300.f));
  }
  return ground;
}

double MaxError(const std::vector<FrameFeatures>& frames, const std::vector<cv::Point2f>& ground) {
  double worst = 0;
  for (const FrameFeatures& f : frames) {
    for (const cv::KeyPoint& kp : f.features.keypoints) {
      const cv::Point2f truth = TruePosition(ground[static_cast<std::size_t>(kp.class_id)], f.timestamp_s);
      worst = std::max(worst, std::hypot(static_cast<double>(kp.pt.x - truth.x), static_cast<double>(kp.pt.y - truth.y)));
    }
  }
  return worst;
}

TEST(RollingShutter, PutsKeypointsWhereTheyWereAtTheMiddleRow) {
  const std::vector<cv::Point2f> ground = Ground();
  const double readout_s = 0.033;
  const std::vector<FrameFeatures> raw = Frames(ground, 20, readout_s);
  // Uncorrected, the rows' exposure times move points by up to ~2 px.
  const double raw_error = MaxError(raw, ground);
  EXPECT_GT(raw_error, 1.0);

  RollingShutterOptions options;
  options.readout_ms = 1e3 * readout_s;
  RollingShutterCorrector corrector(options, kImage);
  std::vector<FrameFeatures> corrected;
  for (const FrameFeatures& f : raw) {
    if (std::optional<FrameFeatures> out = corrector.Push(f)) corrected.push_back(std::move(*out));
  }
  ASSERT_EQ(corrected.size(), raw.size() - 1);  // one frame of look-ahead
  if (std::optional<FrameFeatures> last = corrector.Flush()) corrected.push_back(std::move(*last));
  ASSERT_EQ(corrected.size(), raw.size());
  for (std::size_t k = 0; k < raw.size(); ++k) {
    EXPECT_EQ(corrected[k].index, raw[k].index);
    ASSERT_EQ(corrected[k].features.size(), raw[k].features.size());
  }
  // Tracked points (central differences), the tracks lost at once (flow model), the first and
  // last frames (one-sided differences): all within a few hundredths of a pixel.
  const double error = MaxError(corrected, ground);
  std::cout << "rolling shutter: max error " << raw_error << " px raw, " << error << " px corrected, mean shift "
            << corrector.mean_shift_px() << " px\n";
  EXPECT_LT(error, 0.05);
  EXPECT_NEAR(corrector.max_shift_px(), raw_error, 0.1);
}

// A hovering drone: the image does not move, so nothing is moved, whatever the readout; and
// a gap in time (a strided or cut input) is not taken as motion.
TEST(RollingShutter, AStillImageIsLeftAloneAndGapsAreNotMotion) {
  std::vector<FrameFeatures> frames;
  for (int k = 0; k < 10; ++k) {
    FrameFeatures f;
    f.index = k;
    f.timestamp_s = k / kFps + (k >= 5 ? 2.0 : 0.0);  // 2 s missing before frame 5
    f.features.detected = k % 6 == 0;
    for (int i = 0; i < 50; ++i) {
      // Still, except that the ground jumps by 40 px across the gap.
      cv::KeyPoint kp(cv::Point2f(100.f + 8.f * static_cast<float>(i) + (k >= 5 ? 40.f : 0.f), 30.f + 6.f * static_cast<float>(i)), 3.f);
      kp.class_id = i;
      f.features.keypoints.push_back(kp);
    }
    frames.push_back(std::move(f));
  }
  RollingShutterOptions options;
  options.readout_ms = 33;
  RollingShutterCorrector corrector(options, kImage);
  for (const FrameFeatures& f : frames) {
    if (std::optional<FrameFeatures> out = corrector.Push(f)) {
      for (std::size_t i = 0; i < out->features.size(); ++i) {
        EXPECT_EQ(out->features.keypoints[i].pt, frames[static_cast<std::size_t>(out->index)].features.keypoints[i].pt)
            << "frame " << out->index;
      }
    }
  }
  EXPECT_EQ(corrector.max_shift_px(), 0.0);
}

TEST(RollingShutter, FlowModelIgnoresWrongTracks) {
  std::vector<cv::Point2f> points, velocities;
  cv::RNG rng(3);
  for (int i = 0; i < 200; ++i) {
    const cv::Point2f p(rng.uniform(0.f, 639.f), rng.uniform(0.f, 359.f));
    points.push_back(p);
    // Affine flow plus a quadratic term, and every tenth track wrong by 300 px/s.
    cv::Point2f v(30.f + 0.1f * (p.y - 180.f), -20.f + 0.05f * (p.x - 320.f) + 1e-4f * (p.x - 320.f) * (p.x - 320.f));
    if (i % 10 == 0) v += cv::Point2f(300.f, -200.f);
    velocities.push_back(v);
  }
  FlowModel model;
  ASSERT_TRUE(model.Fit(points, velocities, kImage, 12));
  const cv::Point2f at = model.At({100.f, 50.f});
  EXPECT_NEAR(at.x, 30.f + 0.1f * (50.f - 180.f), 0.5);
  EXPECT_NEAR(at.y, -20.f + 0.05f * (100.f - 320.f) + 1e-4f * 220.f * 220.f, 0.5);
  EXPECT_FALSE(model.Fit({points.begin(), points.begin() + 5}, {velocities.begin(), velocities.begin() + 5}, kImage, 12));
}

// Estimating: keypoints stay where they were seen and carry their motion per second of
// readout, which CompactFeatures::ApplyReadout then applies for any readout.
TEST(RollingShutter, EstimatingHandsOnRatesInsteadOfCorrecting) {
  const std::vector<cv::Point2f> ground = Ground();
  const double readout_s = 0.030;
  const std::vector<FrameFeatures> raw = Frames(ground, 12, readout_s);
  RollingShutterOptions options;
  options.estimate = true;
  RollingShutterCorrector corrector(options, kImage);
  std::vector<FrameFeatures> out;
  for (const FrameFeatures& f : raw) {
    if (std::optional<FrameFeatures> o = corrector.Push(f)) out.push_back(std::move(*o));
  }
  if (std::optional<FrameFeatures> last = corrector.Flush()) out.push_back(std::move(*last));
  ASSERT_EQ(out.size(), raw.size());
  double worst = 0;
  for (std::size_t k = 0; k < out.size(); ++k) {
    const Features& f = out[k].features;
    ASSERT_EQ(f.rolling_shutter_rates.size(), f.size());
    for (std::size_t i = 0; i < f.size(); ++i) EXPECT_EQ(f.keypoints[i].pt, raw[k].features.keypoints[i].pt);
    Features with_descriptors = f;  // what the feature stage hands on has them
    with_descriptors.descriptors = cv::Mat::zeros(static_cast<int>(f.size()), 128, CV_32F);
    with_descriptors.colors.assign(f.size(), Rgb{0, 0, 0});
    CompactFeatures compact = CompactFeatures::From(with_descriptors);
    compact.ApplyReadout(0.010);  // first a wrong readout, then the right one: no drift
    compact.ApplyReadout(readout_s);
    EXPECT_EQ(compact.readout_applied_s, readout_s);
    for (std::size_t i = 0; i < f.size(); ++i) {
      const cv::Point2f truth = TruePosition(ground[static_cast<std::size_t>(f.keypoints[i].class_id)], out[k].timestamp_s);
      worst = std::max(worst, std::hypot(static_cast<double>(compact.points[i].x() - truth.x),
                                         static_cast<double>(compact.points[i].y() - truth.y)));
    }
  }
  EXPECT_LT(worst, 0.05);
}

TEST(RollingShutter, ReadoutFromText) {
  EXPECT_TRUE(RollingShutterFromText("auto").estimate);
  EXPECT_EQ(RollingShutterFromText("28.5").readout_ms, 28.5);
  EXPECT_FALSE(RollingShutterFromText("0").enabled());
  EXPECT_THROW(RollingShutterFromText("fast"), InputError);
  EXPECT_THROW(RollingShutterFromText("30ms"), InputError);
  EXPECT_THROW(RollingShutterFromText("-5"), InputError);
  EXPECT_THROW(RollingShutterFromText(""), InputError);
}

TEST(RollingShutter, OptionsAreChecked) {
  RollingShutterOptions o;
  o.readout_ms = -1;
  EXPECT_THROW(o.Check(), InputError);
  o.readout_ms = 150;
  EXPECT_THROW(o.Check(), InputError);
  o.readout_ms = 30;
  o.min_model_points = 2;
  EXPECT_THROW(o.Check(), InputError);
  o.min_model_points = 12;
  o.estimate = true;  // a readout given and estimated
  EXPECT_THROW(o.Check(), InputError);
}

// The feature stage with a real image: a texture panning at 90 px/s seen through a 30 ms
// rolling shutter (row y shows the pan at its own time, so vertical edges lean). Row y of
// frame k shows texture column x + 20 + speed * (t_k + dt(y)): a texture point seen at (x, y)
// is at x + speed * dt(y) at the frame's time t_k. With the same SIFT and KLT, the corrected
// stage must move each keypoint by exactly that (velocity measured on its track, sign and row
// timing right), in detection frames and propagated frames alike.
class RollingPanSource : public FrameSource {
 public:
  explicit RollingPanSource(int frames) : frames_(frames) {
    info_.fps = kFps;
    info_.frame_count = frames;
    info_.original_size = info_.processing_size = {320, 240};
  }
  std::optional<Frame> Next() override {
    if (next_ >= frames_) return std::nullopt;
    Frame f;
    f.index = next_;
    f.timestamp_s = next_ / kFps;
    cv::Mat map_x(240, 320, CV_32F), map_y(240, 320, CV_32F);
    for (int y = 0; y < 240; ++y) {
      const double t = f.timestamp_s + kReadout * (y / 239.0 - 0.5);
      for (int x = 0; x < 320; ++x) {
        map_x.at<float>(y, x) = static_cast<float>(x + 20 + kSpeed * t);
        map_y.at<float>(y, x) = static_cast<float>(y);
      }
    }
    cv::remap(texture_, f.bgr, map_x, map_y, cv::INTER_CUBIC);
    f.original_size = f.bgr.size();
    ++next_;
    return f;
  }
  const FrameSourceInfo& info() const override { return info_; }
  void SeekTo(int64_t index) override { next_ = index; }
  int64_t frames_delivered() const override { return next_; }
  bool ended_early() const override { return false; }

  static constexpr double kReadout = 0.030;
  static constexpr double kSpeed = 90.0;  // px/s: the image content moves left

 private:
  int frames_;
  int next_ = 0;
  cv::Mat texture_ = testing::RandomTexture({420, 240}, 11);
  FrameSourceInfo info_;
};

std::vector<FrameFeatures> RunPan(double readout_ms) {
  RollingPanSource source(14);
  FeatureStageOptions options;
  options.sift.max_features = 400;
  options.detection_interval = 6;
  options.rolling_shutter.readout_ms = readout_ms;
  return testing::RunFeatureStage(source, options);
}

TEST(RollingShutter, TheFeatureStageCorrectsKeypointsByTheirTracksMotion) {
  const std::vector<FrameFeatures> raw = RunPan(0);
  const std::vector<FrameFeatures> corrected = RunPan(1e3 * RollingPanSource::kReadout);
  ASSERT_EQ(raw.size(), 14u);
  ASSERT_EQ(corrected.size(), raw.size());
  double worst = 0, largest_shift = 0;
  int compared = 0;
  for (std::size_t k = 0; k < raw.size(); ++k) {
    ASSERT_EQ(corrected[k].index, raw[k].index);
    EXPECT_EQ(corrected[k].features.detected, raw[k].features.detected);
    ASSERT_EQ(corrected[k].features.size(), raw[k].features.size()) << "frame " << k;
    for (std::size_t i = 0; i < raw[k].features.size(); ++i) {
      const cv::KeyPoint& r = raw[k].features.keypoints[i];
      const cv::KeyPoint& c = corrected[k].features.keypoints[i];
      EXPECT_EQ(c.class_id, r.class_id);
      const double dt = RollingPanSource::kReadout * (r.pt.y / 239.0 - 0.5);
      const double expected = RollingPanSource::kSpeed * dt;
      worst = std::max(worst, std::abs(c.pt.x - r.pt.x - expected) + std::abs(c.pt.y - r.pt.y));
      largest_shift = std::max(largest_shift, std::abs(expected));
      ++compared;
    }
  }
  std::cout << "pan: " << compared << " keypoints, shifts up to " << largest_shift << " px, worst error " << worst
            << " px\n";
  EXPECT_GT(compared, 3000);
  EXPECT_GT(largest_shift, 1.2);  // 90 px/s x 15 ms at the top and bottom rows
  EXPECT_LT(worst, 0.1);
}

}  // namespace
}  // namespace glam
