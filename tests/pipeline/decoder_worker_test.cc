// The feature stage's schedule: SIFT on every N-th frame (or adapted to the image motion),
// KLT in between, frames in input order with either worker count, an early detection when most tracks are lost, and errors
// and cancellation that leave no thread behind.
#include "engine/pipeline/decoder_worker.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "engine/core/error.h"
#include "tests/features/synthetic_texture.h"
#include "tests/pipeline/feature_stage_runner.h"

namespace glam {
namespace {

// Frames of a texture panning right by 2 px per frame; frame `cut` (if any) shows unrelated
// ground from then on.
class PanningSource : public FrameSource {
 public:
  PanningSource(int frames, int cut = -1) : frames_(frames), cut_(cut) {
    info_.fps = 30;
    info_.frame_count = frames;
    info_.original_size = info_.processing_size = {320, 240};
  }
  std::optional<Frame> Next() override {
    if (next_ >= frames_) return std::nullopt;
    const cv::Mat& texture = (cut_ >= 0 && next_ >= cut_) ? other_ : base_;
    Frame f;
    f.index = next_;
    f.timestamp_s = next_ / 30.0;
    f.bgr = texture(cv::Rect(std::min(2 * next_, 80), 0, 320, 240)).clone();  // 40 frames of pan
    f.original_size = f.bgr.size();
    ++next_;
    return f;
  }
  const FrameSourceInfo& info() const override { return info_; }
  void SeekTo(int64_t index) override { next_ = index; }
  int64_t frames_delivered() const override { return next_; }
  bool ended_early() const override { return false; }

 private:
  int frames_, cut_;
  int next_ = 0;
  cv::Mat base_ = testing::RandomTexture({400, 240}, 5);
  cv::Mat other_ = testing::RandomTexture({400, 240}, 6);
  FrameSourceInfo info_;
};

// Frames of a texture panning right by `slow_px` per frame up to frame `change`, by `fast_px`
// per frame after it (the camera speeds up).
class SpeedChangeSource : public FrameSource {
 public:
  SpeedChangeSource(int frames, int change, int slow_px, int fast_px)
      : frames_(frames), change_(change), slow_px_(slow_px), fast_px_(fast_px) {
    info_.fps = 30;
    info_.frame_count = frames;
    info_.original_size = info_.processing_size = {320, 240};
    texture_ = testing::RandomTexture({320 + Offset(frames), 240}, 7);
  }
  std::optional<Frame> Next() override {
    if (next_ >= frames_) return std::nullopt;
    Frame f;
    f.index = next_;
    f.timestamp_s = next_ / 30.0;
    f.bgr = texture_(cv::Rect(Offset(next_), 0, 320, 240)).clone();
    f.original_size = f.bgr.size();
    ++next_;
    return f;
  }
  const FrameSourceInfo& info() const override { return info_; }
  void SeekTo(int64_t index) override { next_ = static_cast<int>(index); }
  int64_t frames_delivered() const override { return next_; }
  bool ended_early() const override { return false; }

 private:
  int Offset(int frame) const {
    return slow_px_ * std::min(frame, change_) + fast_px_ * std::max(0, frame - change_);
  }
  int frames_, change_, slow_px_, fast_px_;
  int next_ = 0;
  cv::Mat texture_;
  FrameSourceInfo info_;
};

std::vector<FrameFeatures> RunWorker(FrameSource& source, const FeatureStageOptions& options) {
  return testing::RunFeatureStage(source, options);
}

FeatureStageOptions Options(int interval, int workers) {
  FeatureStageOptions o;
  o.sift.max_features = 500;
  o.detection_interval = interval;
  o.workers = workers;
  return o;
}

TEST(DecoderWorker, DetectsEveryNthFrameAndPropagatesTheRestInOrder) {
  for (int workers : {1, 2, 3}) {
    PanningSource source(23);
    const std::vector<FrameFeatures> items = RunWorker(source, Options(5, workers));
    ASSERT_EQ(items.size(), 23u) << workers << " workers";
    for (std::size_t i = 0; i < items.size(); ++i) {
      EXPECT_EQ(items[i].index, static_cast<std::int64_t>(i));
      // Frames 0, 5, 10, 15, 20 are detected; 21 and 22 (end of input) are propagated.
      EXPECT_EQ(items[i].features.detected, i % 5 == 0) << "frame " << i;
      EXPECT_GT(items[i].features.size(), 200u);
    }
    // A propagated frame's keypoints are its detection frame's, moved by the pan (-2 px/frame).
    const Features& det = items[10].features;
    const Features& prop = items[13].features;
    int checked = 0;
    for (std::size_t i = 0; i < prop.size(); ++i) {
      for (std::size_t j = 0; j < det.size(); ++j) {
        if (cv::norm(det.descriptors.row(static_cast<int>(j)), prop.descriptors.row(static_cast<int>(i)),
                     cv::NORM_INF) == 0) {
          const double error = std::hypot(prop.keypoints[i].pt.x - (det.keypoints[j].pt.x - 6.0),
                                          prop.keypoints[i].pt.y - det.keypoints[j].pt.y);
          checked += error < 0.25 ? 1 : 0;
          break;
        }
      }
    }
    EXPECT_GT(checked, static_cast<int>(prop.size()) * 9 / 10);
  }
}

// Detected frames of a run, in order.
std::vector<std::int64_t> DetectedFrames(const std::vector<FrameFeatures>& items) {
  std::vector<std::int64_t> detected;
  for (const FrameFeatures& item : items) {
    if (item.features.detected) detected.push_back(item.index);
  }
  return detected;
}

FeatureStageOptions AdaptiveOptions(int workers) {
  FeatureStageOptions o = Options(3, workers);
  o.max_detection_interval = 30;
  o.detection_motion_fraction = 0.03;  // 12 px on the 320x240 frames
  return o;
}

// The adaptive schedule: 1 px per frame for 60 frames, then 8 px per frame. The slow pan is
// detected about every 12th frame (the blocks planned from the motion measured two blocks
// back), the fast one every 3rd (the shortest interval); the blocks planned from the slow
// motion when the camera speeds up are cut short once the image moved twice the target.
TEST(DecoderWorker, AdaptiveScheduleDetectsWhenTheImageHasMoved) {
  SpeedChangeSource source(120, 60, 1, 8);
  const std::vector<FrameFeatures> items = RunWorker(source, AdaptiveOptions(2));
  ASSERT_EQ(items.size(), 120u);
  const std::vector<std::int64_t> detected = DetectedFrames(items);
  ASSERT_GE(detected.size(), 4u);
  EXPECT_EQ(detected[0], 0);
  EXPECT_EQ(detected[1], 3);  // the first two blocks: no motion measured yet
  EXPECT_EQ(detected[2], 6);
  int slow = 0;
  for (std::size_t i = 1; i < detected.size(); ++i) {
    const std::int64_t gap = detected[i] - detected[i - 1];
    if (detected[i - 1] >= 6 && detected[i] <= 60) {
      ++slow;
      EXPECT_GE(gap, 10) << "after frame " << detected[i - 1];
      EXPECT_LE(gap, 13) << "after frame " << detected[i - 1];
    }
    // Moving 8 px per frame, no frame waits longer than 4 frames (32 px > twice 12 px).
    if (detected[i - 1] >= 60) {
      EXPECT_LE(gap, 4) << "after frame " << detected[i - 1];
    }
    if (detected[i - 1] >= 90) {
      EXPECT_EQ(gap, 3) << "after frame " << detected[i - 1];
    }
  }
  EXPECT_GE(slow, 3);
  // The fixed schedule at the shortest interval detects 40 of the 120 frames.
  EXPECT_LT(detected.size(), 30u);
}

// SIFT of the next detection frames runs ahead on `workers` helper threads (fewer when the
// interval is long); what the stage emits is the same for every worker count, with the
// adaptive schedule too.
TEST(DecoderWorker, OutputDoesNotDependOnTheNumberOfWorkers) {
  for (int interval : {3, 40, 0}) {
    std::vector<std::vector<FrameFeatures>> runs;
    for (int workers : {1, 2, 3}) {
      if (interval == 0) {  // the adaptive schedule
        SpeedChangeSource source(90, 45, 1, 8);
        runs.push_back(RunWorker(source, AdaptiveOptions(workers)));
      } else {
        PanningSource source(90);
        runs.push_back(RunWorker(source, Options(interval, workers)));
      }
    }
    for (std::size_t r = 1; r < runs.size(); ++r) {
      ASSERT_EQ(runs[r].size(), runs[0].size());
      for (std::size_t i = 0; i < runs[0].size(); ++i) {
        const Features& a = runs[0][i].features;
        const Features& b = runs[r][i].features;
        ASSERT_EQ(runs[r][i].index, runs[0][i].index);
        EXPECT_EQ(b.detected, a.detected) << "interval " << interval << ", frame " << i;
        ASSERT_EQ(b.size(), a.size()) << "interval " << interval << ", frame " << i;
        for (std::size_t k = 0; k < a.size(); ++k) {
          EXPECT_EQ(b.keypoints[k].pt, a.keypoints[k].pt);
        }
        EXPECT_EQ(cv::norm(a.descriptors, b.descriptors, cv::NORM_INF), 0.0) << "frame " << i;
      }
    }
  }
}

// A source that fails at frame `fail_at` (a truncated file found while reading ahead).
class FailingSource : public PanningSource {
 public:
  FailingSource(int frames, int fail_at) : PanningSource(frames), fail_at_(fail_at) {}
  std::optional<Frame> Next() override {
    if (frames_delivered() == fail_at_) throw InputError("decode failed");
    return PanningSource::Next();
  }

 private:
  int fail_at_;
};

TEST(DecoderWorker, AReadErrorWhileDetectionsRunAheadIsReportedAndLeavesNoThread) {
  for (int workers : {1, 2}) {
    FailingSource source(60, 17);
    EXPECT_THROW(RunWorker(source, Options(4, workers)), InputError) << workers << " workers";
  }
}

TEST(DecoderWorker, IntervalOneIsSiftOnEveryFrame) {
  PanningSource source(7);
  const std::vector<FrameFeatures> items = RunWorker(source, Options(1, 2));
  ASSERT_EQ(items.size(), 7u);
  for (const FrameFeatures& item : items) EXPECT_TRUE(item.features.detected);
}

TEST(DecoderWorker, DetectsAtOnceWhenTheGroundChanges) {
  PanningSource source(12, /*cut=*/3);
  const std::vector<FrameFeatures> items = RunWorker(source, Options(8, 2));
  ASSERT_EQ(items.size(), 12u);
  EXPECT_TRUE(items[0].features.detected);
  EXPECT_FALSE(items[2].features.detected);
  EXPECT_TRUE(items[3].features.detected);  // the cut: KLT lost nearly everything
  EXPECT_FALSE(items[4].features.detected); // then propagated from frame 3
  EXPECT_GT(items[4].features.size(), items[3].features.size() * 8 / 10);
  EXPECT_TRUE(items[8].features.detected);  // the scheduled detection
}

TEST(DecoderWorker, StopsWhenTheConsumerClosesTheQueue) {
  PanningSource source(200);
  BoundedQueue<FrameFeatures> queue(2);
  std::atomic<bool> stop{false};
  DecoderWorker worker(source, Options(4, 2), queue, {}, stop);
  std::thread t([&] { worker.Run(); });
  ASSERT_TRUE(queue.Pop().has_value());
  queue.Close();
  t.join();  // returns: no thread is left blocked on the closed queue
  EXPECT_LT(worker.frames(), 200);
  EXPECT_FALSE(worker.error());
}

TEST(DecoderWorker, OptionsAreChecked) {
  FeatureStageOptions o = Options(0, 2);
  EXPECT_THROW(o.Check(), InputError);
  o = Options(3, 0);
  EXPECT_THROW(o.Check(), InputError);
  o = AdaptiveOptions(2);
  EXPECT_NO_THROW(o.Check());
  o.max_detection_interval = 2;  // shorter than the shortest
  EXPECT_THROW(o.Check(), InputError);
  o = AdaptiveOptions(2);
  o.detection_motion_fraction = 0;
  EXPECT_THROW(o.Check(), InputError);
}

}  // namespace
}  // namespace glam
