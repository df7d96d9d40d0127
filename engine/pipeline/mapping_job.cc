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
#include "engine/pipeline/decoder_worker.h"
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

}  // namespace

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
