#include "tests/support/clip_runner.h"

#include <atomic>
#include <cstdio>
#include <thread>

#include "engine/pipeline/decoder_worker.h"
#include "engine/pipeline/mapping_options.h"
#include "engine/submap/submap_builder.h"
#include "engine/video/frame_source.h"

namespace glam::test_support {

ClipRun RunSubmapBuilderOnClip(const std::filesystem::path& video, const Intrinsics& intrinsics,
                               const SubmapOptions& options, int detection_interval,
                               std::int64_t max_frames, const SiftOptions& sift) {
  SubmapBuilder builder(intrinsics, options);
  auto source = OpenFrameSource(video);
  MappingOptions mapping;
  mapping.detection_interval = detection_interval;
  FeatureStageOptions stage;
  stage.sift = sift;
  stage.detection_interval = mapping.EffectiveDetectionInterval(source->info().fps);
  std::printf("SIFT on every %d. frame\n", stage.detection_interval);
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
