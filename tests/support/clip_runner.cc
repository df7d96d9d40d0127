#include "tests/support/clip_runner.h"

#include <atomic>
#include <cstdio>
#include <memory>
#include <utility>
#include <thread>

#include "engine/pipeline/decoder_worker.h"
#include "engine/pipeline/mapping_options.h"
#include "engine/submap/submap_builder.h"
#include "engine/video/frame_source.h"

namespace glam::test_support {
namespace {

// The frames of `source` except those `skip` names, as a live stream that dropped them
// delivers the rest (indices and times unchanged, so the gaps show).
class SkippingSource : public FrameSource {
 public:
  SkippingSource(FrameSource& source, std::function<bool(std::int64_t)> skip)
      : source_(source), skip_(std::move(skip)) {}
  std::optional<Frame> Next() override {
    while (std::optional<Frame> frame = source_.Next()) {
      if (!skip_(frame->index)) {
        ++delivered_;
        return frame;
      }
      ++skipped_;
    }
    return std::nullopt;
  }
  const FrameSourceInfo& info() const override { return source_.info(); }
  void SeekTo(int64_t index) override { source_.SeekTo(index); }
  int64_t frames_delivered() const override { return delivered_; }
  bool ended_early() const override { return source_.ended_early(); }
  int64_t frames_dropped() const override { return skipped_; }

 private:
  FrameSource& source_;
  std::function<bool(std::int64_t)> skip_;
  int64_t delivered_ = 0;
  int64_t skipped_ = 0;
};

}  // namespace

ClipRun RunSubmapBuilderOnClip(const std::filesystem::path& video, const Intrinsics& intrinsics,
                               const SubmapOptions& options, int detection_interval,
                               std::int64_t max_frames, const SiftOptions& sift,
                               const std::function<bool(std::int64_t)>& skip_frame) {
  SubmapBuilder builder(intrinsics, options);
  std::unique_ptr<FrameSource> opened = OpenFrameSource(video);
  std::unique_ptr<FrameSource> skipping;
  if (skip_frame) skipping = std::make_unique<SkippingSource>(*opened, skip_frame);
  FrameSource* source = skipping ? skipping.get() : opened.get();
  MappingOptions mapping;
  mapping.detection_interval = detection_interval;
  FeatureStageOptions stage;
  stage.sift = sift;
  stage.detection_interval = mapping.EffectiveDetectionInterval(source->info().fps);
  stage.max_detection_interval = mapping.EffectiveMaxDetectionInterval(source->info().fps);
  stage.detection_motion_fraction = mapping.detection_motion_fraction;
  std::printf("SIFT on every %d. to %d. frame\n", stage.detection_interval, stage.max_detection_interval);
  BoundedQueue<FrameFeatures> queue(8);
  std::atomic<bool> stop{false};
  DecoderWorker worker(*source, stage, queue, {}, stop);
  std::thread decoder([&worker] { worker.Run(); });
  ClipRun run;
  while (std::optional<FrameFeatures> item = queue.Pop()) {
    if (max_frames >= 0 && run.frames >= max_frames) {
      stop = true;  // drain what the decoder still delivers
      continue;
    }
    ++run.frames;
    for (Submap& s : builder.AddFrame(item->index, item->timestamp_s, item->features)) {
      run.submaps.push_back(std::move(s));
    }
  }
  decoder.join();
  if (worker.error()) std::rethrow_exception(worker.error());
  for (Submap& s : builder.Finish()) run.submaps.push_back(std::move(s));
  if (max_frames < 0) run.frames = source->frames_delivered();
  run.focal = builder.focal();
  run.stats = builder.stats();
  return run;
}

}  // namespace glam::test_support
