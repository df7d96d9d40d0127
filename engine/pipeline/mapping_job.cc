#include "engine/pipeline/mapping_job.h"

#include <atomic>
#include <chrono>
#include <exception>
#include <fstream>
#include <mutex>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "engine/core/bounded_queue.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/features/sift_extractor.h"
#include "engine/map/submap_io.h"
#include "engine/pipeline/map_assembly.h"
#include "engine/submap/submap_builder.h"
#include "engine/video/frame_source.h"

namespace glam {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

struct FrameFeatures {
  std::int64_t index = 0;
  double timestamp_s = 0;
  Features features;
};

void PrepareOutputDirectory(const std::filesystem::path& out_dir) {
  std::error_code ec;
  std::filesystem::create_directories(out_dir / "submaps", ec);
  if (ec) {
    throw InputError(fmt::format("cannot create output directory {}: {}", out_dir.string(),
                                 ec.message()));
  }
  const std::filesystem::path probe = out_dir / ".glam_write_test";
  {
    std::ofstream out(probe);
    out << "ok";
    if (!out) throw InputError(fmt::format("output directory {} is not writable", out_dir.string()));
  }
  std::filesystem::remove(probe, ec);
}

void WriteJson(const std::filesystem::path& path, const nlohmann::json& json) {
  std::ofstream out(path);
  out << json.dump(2) << "\n";
  out.close();
  if (!out) throw EnvironmentError(fmt::format("cannot write {}", path.string()));
}

// The decoder side: owns the frame source and one SIFT extractor per feature worker, runs on
// its own thread. Frames are decoded in batches of `workers` and their features extracted in
// parallel, then pushed in input order.
class DecoderWorker {
 public:
  DecoderWorker(FrameSource& source, const SiftOptions& sift, int workers,
                BoundedQueue<FrameFeatures>& queue, CancellationToken cancel,
                const std::atomic<bool>& stop, std::size_t min_features)
      : source_(source),
        queue_(queue),
        cancel_(std::move(cancel)),
        stop_(stop),
        min_features_(min_features) {
    // Separate extractors (not copies sharing one cv::SIFT) so workers share no state.
    for (int i = 0; i < workers; ++i) extractors_.emplace_back(sift);
  }

  void Run() {
    try {
      bool more = true;
      while (more && !cancel_.IsCancelled() && !stop_.load()) {
        const auto start = Clock::now();
        std::vector<Frame> batch;
        while (batch.size() < extractors_.size()) {
          std::optional<Frame> frame = source_.Next();
          if (!frame) {
            more = false;
            break;
          }
          batch.push_back(std::move(*frame));
        }
        std::vector<FrameFeatures> items = ExtractBatch(batch);
        busy_seconds_ += Seconds(start);
        for (FrameFeatures& item : items) {
          ++frames_;
          if (item.features.size() < min_features_) ++frames_without_features_;
          if (!queue_.Push(std::move(item))) {  // consumer closed the queue
            more = false;
            break;
          }
        }
      }
    } catch (...) {
      error_ = std::current_exception();
    }
    queue_.Close();
  }

  std::exception_ptr error() const { return error_; }

 private:
  // Frame i goes to extractor i; all but the first on helper threads. Joins every thread
  // before rethrowing the first error, so no thread outlives a failure.
  std::vector<FrameFeatures> ExtractBatch(const std::vector<Frame>& batch) {
    std::vector<FrameFeatures> items(batch.size());
    std::vector<std::exception_ptr> errors(batch.size());
    auto extract = [&](std::size_t i) {
      try {
        items[i] = {batch[i].index, batch[i].timestamp_s, extractors_[i].Extract(batch[i].bgr)};
      } catch (...) {
        errors[i] = std::current_exception();
      }
    };
    std::vector<std::thread> helpers;
    for (std::size_t i = 1; i < batch.size(); ++i) helpers.emplace_back(extract, i);
    if (!batch.empty()) extract(0);
    for (std::thread& t : helpers) t.join();
    for (const std::exception_ptr& e : errors) {
      if (e) std::rethrow_exception(e);
    }
    return items;
  }

 public:
  double busy_seconds() const { return busy_seconds_; }
  std::int64_t frames() const { return frames_; }
  std::int64_t frames_without_features() const { return frames_without_features_; }

 private:
  FrameSource& source_;
  std::vector<SiftExtractor> extractors_;
  BoundedQueue<FrameFeatures>& queue_;
  CancellationToken cancel_;
  const std::atomic<bool>& stop_;
  const std::size_t min_features_;
  std::exception_ptr error_;
  double busy_seconds_ = 0;
  std::int64_t frames_ = 0;
  std::int64_t frames_without_features_ = 0;
};

// The user-facing explanation of what could not be mapped (see MappingReport::warnings).
std::vector<std::string> Diagnose(const MappingReport& r, int min_features) {
  std::vector<std::string> warnings;
  if (r.input_ended_early) {
    warnings.push_back(fmt::format(
        "the input ended after {} frames were read although {} were expected: the file is "
        "truncated or corrupt; only the frames before the damage were mapped",
        r.frames_decoded, r.frames_total));
  }
  if (r.frames_without_features == r.frames_decoded) {
    warnings.push_back(fmt::format(
        "no features in any of the {} frames (fewer than {} each): the video is black, uniform "
        "or textureless, so nothing can be mapped",
        r.frames_decoded, min_features));
    return warnings;
  }
  if (r.frames_without_features * 10 >= r.frames_decoded) {
    warnings.push_back(fmt::format(
        "no features in {} of {} frames (fewer than {} each): dark, uniform or blurred frames "
        "cannot be posed",
        r.frames_without_features, r.frames_decoded, min_features));
  }
  if (r.submaps == 0 && r.keyframes > 0) {
    warnings.push_back(fmt::format(
        "none of the {} frames could be posed: maps were started but none reached 3 keyframes "
        "(too short a clip or too little motion; tracking lost {} times)",
        r.frames_decoded, r.tracking_losses));
  } else if (r.submaps == 0) {
    warnings.push_back(fmt::format(
        "none of the {} frames could be posed: no pair of frames had enough parallax to start a "
        "map (a static or hovering camera, or too short a clip), or consecutive frames do not "
        "overlap",
        r.frames_decoded));
  } else if (r.frames_unposed * 10 >= r.frames_decoded) {
    warnings.push_back(fmt::format("{} of {} frames could not be posed (see trajectory.tum)",
                                   r.frames_unposed, r.frames_decoded));
  }
  return warnings;
}

}  // namespace

nlohmann::json MappingReport::ToJson() const {
  return {{"input", input},
          {"frames_total", frames_total},
          {"frames_decoded", frames_decoded},
          {"frames_posed", frames_posed},
          {"frames_unposed", frames_unposed},
          {"frames_without_features", frames_without_features},
          {"keyframes", keyframes},
          {"submaps", submaps},
          {"submaps_discarded", submaps_discarded},
          {"disconnected_submaps", disconnected_submaps},
          {"points", points},
          {"tracking_losses", tracking_losses},
          {"initial_focal_px", initial_focal},
          {"focal_px", focal},
          {"focal_original_px", focal_original},
          {"fps", fps},
          {"processing_fps", processing_fps},
          {"processing_size", {processing_width, processing_height}},
          {"input_ended_early", input_ended_early},
          {"warnings", warnings},
          {"timings_s",
           {{"decode_and_features", timings.decode_and_features_s},
            {"builder", timings.builder_s},
            {"bundle_adjustment", timings.bundle_adjust_s},
            {"chaining", timings.chaining_s},
            {"writing", timings.writing_s},
            {"total", timings.total_s}}}};
}

MappingReport RunMapping(const std::filesystem::path& input, const std::filesystem::path& out_dir,
                         const MappingOptions& options, const ProgressCallback& progress,
                         CancellationToken cancel) {
  const auto start = Clock::now();
  options.Check();
  cancel.ThrowIfCancelled();
  std::unique_ptr<FrameSource> source = OpenFrameSource(input, options.source);
  const FrameSourceInfo info = source->info();
  const Intrinsics intrinsics = ResolveIntrinsics(options, info);
  PrepareOutputDirectory(out_dir);
  const std::filesystem::path submaps_root = out_dir / "submaps";

  MappingReport report;
  report.input = input.string();
  report.fps = info.fps > 0 ? info.fps : 1.0;
  report.initial_focal = intrinsics.fx;
  report.processing_width = info.processing_size.width;
  report.processing_height = info.processing_size.height;
  if (info.frame_count > 0) {
    report.frames_total = (info.frame_count + options.source.stride - 1) / options.source.stride;
  }
  GLAM_LOG_INFO("mapping {}: {}x{} -> {}x{}, {:.3g} fps, ~{} frames, initial focal {:.1f} px",
                report.input, info.original_size.width, info.original_size.height,
                info.processing_size.width, info.processing_size.height, report.fps,
                report.frames_total, intrinsics.fx);

  SubmapBuilder builder(intrinsics, options.submap, cancel);
  MapAssembler assembler(options.chaining, options.leveling);
  BoundedQueue<FrameFeatures> queue(options.queue_capacity);
  std::atomic<bool> stop{false};
  const int min_features = options.submap.min_tracking_inliers;
  DecoderWorker worker(*source, options.sift, options.feature_workers, queue, cancel, stop,
                       static_cast<std::size_t>(min_features));
  std::thread decoder([&worker] { worker.Run(); });

  MappingProgress state;
  state.stage = "mapping";
  state.frames_total = report.frames_total;
  auto last_progress = Clock::now() - std::chrono::seconds(1);
  auto emit = [&](bool force) {
    if (!progress) return;
    if (!force && Clock::now() - last_progress < std::chrono::milliseconds(250)) return;
    last_progress = Clock::now();
    const double elapsed = Seconds(start);
    state.fps = elapsed > 0 ? static_cast<double>(state.frames_done) / elapsed : 0;
    state.eta_s = (state.frames_total > 0 && state.fps > 0)
                      ? std::max<double>(0, static_cast<double>(state.frames_total - state.frames_done) / state.fps)
                      : -1;
    state.submaps_completed = static_cast<std::int64_t>(assembler.nodes().size());
    // Until global alignment exists every placed submap is one new map revision.
    state.submaps_aligned = state.submaps_completed - assembler.disconnected();
    state.revision = state.submaps_completed;
    state.keyframes = builder.stats().keyframes;
    state.points = assembler.points();
    progress(state);
  };
  double writing = 0;
  auto consume = [&](std::vector<Submap> completed) {
    for (Submap& submap : completed) {
      const auto write_start = Clock::now();
      WriteSubmap(submap, submaps_root);
      writing += Seconds(write_start);
      assembler.Add(submap);
      GLAM_LOG_INFO("submap {} completed: frames {}-{}, {} keyframes, {} landmarks", submap.id,
                    submap.first_frame, submap.last_frame, submap.keyframes.size(),
                    submap.landmarks.size());
      emit(true);  // every completed submap is reported (the server turns it into an event)
    }
  };

  double builder_seconds = 0;
  std::exception_ptr error;
  try {
    while (true) {
      cancel.ThrowIfCancelled();
      std::optional<FrameFeatures> item = queue.PopFor(std::chrono::milliseconds(100));
      if (!item) {
        if (queue.IsClosed() && queue.Size() == 0) break;
        continue;
      }
      const auto t0 = Clock::now();
      std::vector<Submap> completed = builder.AddFrame(item->index, item->timestamp_s, item->features);
      builder_seconds += Seconds(t0);
      ++state.frames_done;
      consume(std::move(completed));
      emit(false);
    }
  } catch (...) {
    error = std::current_exception();
  }
  stop.store(true);
  queue.Close();
  decoder.join();
  if (error) std::rethrow_exception(error);
  if (worker.error()) std::rethrow_exception(worker.error());
  cancel.ThrowIfCancelled();

  {
    const auto t0 = Clock::now();
    std::vector<Submap> completed = builder.Finish();
    builder_seconds += Seconds(t0);
    consume(std::move(completed));
  }
  if (worker.frames() == 0) {
    throw InputError(fmt::format("{}: no frames could be decoded", report.input));
  }

  state.stage = "writing";
  emit(true);
  const auto write_start = Clock::now();
  assembler.WriteTrajectory(out_dir / "trajectory.tum", report.fps);
  assembler.WritePoints(out_dir / "points.ply");
  assembler.WriteGraph(out_dir / "graph.json");
  writing += Seconds(write_start);

  const SubmapBuilderStats& stats = builder.stats();
  report.frames_decoded = worker.frames();
  report.frames_posed = assembler.frames_posed();
  report.frames_unposed = report.frames_decoded - report.frames_posed;
  report.frames_without_features = worker.frames_without_features();
  report.keyframes = stats.keyframes;
  report.submaps = static_cast<std::int64_t>(assembler.nodes().size());
  report.submaps_discarded = stats.submaps_discarded;
  report.disconnected_submaps = assembler.disconnected();
  report.points = assembler.points();
  report.tracking_losses = stats.tracking_losses;
  report.focal = builder.focal();
  report.focal_original = info.scale > 0 ? builder.focal() / info.scale : builder.focal();
  report.input_ended_early = source->ended_early();
  report.timings.decode_and_features_s = worker.busy_seconds();
  report.timings.builder_s = builder_seconds;
  report.timings.bundle_adjust_s = stats.bundle_adjust_seconds;
  report.timings.chaining_s = assembler.chaining_seconds();
  report.timings.writing_s = writing;
  report.timings.total_s = Seconds(start);
  report.processing_fps = report.timings.total_s > 0
                              ? static_cast<double>(report.frames_decoded) / report.timings.total_s
                              : 0;
  report.warnings = Diagnose(report, min_features);
  for (const std::string& warning : report.warnings) GLAM_LOG_WARN("{}: {}", report.input, warning);
  WriteJson(out_dir / "report.json", report.ToJson());
  state.stage = "done";
  state.frames_done = report.frames_decoded;
  emit(true);
  return report;
}

}  // namespace glam
