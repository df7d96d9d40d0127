#include "engine/pipeline/mapping_job.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <fstream>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "engine/core/atomic_file.h"
#include "engine/core/bounded_queue.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/core/thread_name.h"
#include "engine/pipeline/decoder_worker.h"
#include "engine/map/submap_io.h"
#include "engine/alignment/vocabulary_tree.h"
#include "engine/pipeline/alignment_thread.h"
#include "engine/geo/exif_gps.h"
#include "engine/geo/geodetic.h"
#include "engine/geo/geojson_track.h"
#include "engine/geo/gps_track.h"
#include "engine/pipeline/georeference_map.h"
#include "engine/pipeline/live_georeference.h"
#include "engine/pipeline/map_refinement.h"
#include "engine/pipeline/map_export.h"
#include "engine/pipeline/open_submap_preview.h"
#include "engine/pipeline/resume_checkpoint.h"
#include "engine/pipeline/tile_writer.h"
#include "engine/submap/submap_builder.h"
#include "engine/video/frame_source.h"
#include "engine/video/image_folder_source.h"
#include "engine/video/stream_source.h"

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
  WriteFileAtomically(path, json.dump(2) + "\n");
}

// trajectory.geojson (engine/geo/geojson_track.h) of a georeferenced map: its camera centres
// (as in trajectory.tum) in WGS84. Removed otherwise, so a map made again without GPS in the
// same directory keeps no stale path.
void WriteGeoJsonTrack(const MapSnapshot& snapshot, const std::filesystem::path& submaps_root,
                       const std::filesystem::path& out_dir, const MappingReport& report) {
  const std::filesystem::path file = out_dir / kGeoJsonTrackFile;
  if (!report.georeference.ok) {
    std::error_code ec;
    std::filesystem::remove(file, ec);
    return;
  }
  const EnuFrame enu(report.georeference.origin);
  std::vector<GeoPathPoint> path;
  for (const auto& [frame, centre] : WorldCameraCentres(snapshot, submaps_root)) {
    path.push_back({frame, static_cast<double>(frame) / report.fps, enu.GeodeticFromEnu(centre)});
  }
  WriteFileAtomically(file, GeoJsonTrack(path, std::filesystem::path(report.input).filename().string()));
}

// A fresh run owns out_dir's submaps/ and checkpoint: leftovers of an earlier run there would
// otherwise be mixed into this one's map.
void ClearPreviousRun(const std::filesystem::path& out_dir) {
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(out_dir / "submaps", ec)) {
    std::filesystem::remove_all(entry.path(), ec);
  }
  std::filesystem::remove(out_dir / kCheckpointFile, ec);
}

// The checkpoint of out_dir if it belongs to this input and every submap it names is
// readable; otherwise nullopt (the run starts from the beginning, and says why).
std::optional<ResumeCheckpoint> UsableCheckpoint(const std::filesystem::path& out_dir,
                                                 const MappingReport& report) {
  std::optional<ResumeCheckpoint> checkpoint;
  try {
    checkpoint = ReadCheckpoint(out_dir);
  } catch (const InputError& e) {
    GLAM_LOG_WARN("cannot resume: {}", e.what());
    return std::nullopt;
  }
  if (!checkpoint) {
    GLAM_LOG_INFO("nothing to resume in {}: starting from the first frame", out_dir.string());
    return std::nullopt;
  }
  if (checkpoint->processing_width != report.processing_width ||
      checkpoint->processing_height != report.processing_height) {
    GLAM_LOG_WARN("cannot resume: {} was made at another processing size", kCheckpointFile);
    return std::nullopt;
  }
  if (checkpoint->photos_reordered_by_time != report.photos_reordered_by_time) {
    GLAM_LOG_WARN("cannot resume: {} was made with the photos in another order", kCheckpointFile);
    return std::nullopt;
  }
  for (std::uint32_t id = 0; id < checkpoint->next_submap_id; ++id) {
    if (!std::filesystem::exists(SubmapDirectory(out_dir / "submaps", id))) {
      GLAM_LOG_WARN("cannot resume: submap {} is missing", id);
      return std::nullopt;
    }
  }
  return checkpoint;
}

// 64 random bits as 16 hex digits: tells this run's tiles from an earlier run's.
std::string NewRunId() {
  std::random_device device;
  const std::uint64_t bits = (static_cast<std::uint64_t>(device()) << 32) ^ device();
  return fmt::format("{:016x}", bits);
}

// After `completed[i]` is on disk: the next submap starts at completed[i + 1]'s first frame,
// or where the builder's open submap starts.
ResumeCheckpoint MakeCheckpoint(const SubmapBuilder& builder, const std::vector<Submap>& completed,
                                std::size_t i, const MappingReport& report, const std::string& run_id) {
  ResumeCheckpoint c;
  c.next_submap_id = completed[i].id + 1;
  c.resume_frame = i + 1 < completed.size()
                       ? completed[i + 1].first_frame
                       : builder.open_submap_first_frame().value_or(completed[i].last_frame + 1);
  c.focal = builder.focal();
  c.focal_held = builder.stats().focal_held;
  c.k1 = builder.k1();
  c.k1_held = builder.stats().k1_held;
  c.readout_ms = builder.stats().readout_ms;
  c.input = report.input;
  c.processing_width = report.processing_width;
  c.processing_height = report.processing_height;
  c.run_id = run_id;
  c.photos_reordered_by_time = report.photos_reordered_by_time;
  return c;
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
  Intrinsics intrinsics = ResolveIntrinsics(options, info);
  PrepareOutputDirectory(out_dir);
  const std::filesystem::path submaps_root = out_dir / "submaps";
  const VocabularyTree loaded_vocabulary =
      options.vocabulary.empty() ? VocabularyTree() : VocabularyTree::Load(options.vocabulary);
  const VocabularyTree& vocabulary =
      options.vocabulary.empty() ? VocabularyTree::Default() : loaded_vocabulary;

  MappingReport report;
  report.input = input.string();
  // A live stream has no frame count, cannot seek (a resumed run goes on with what arrives
  // now) and has no sidecar.
  const bool stream = dynamic_cast<const StreamSource*>(source.get()) != nullptr;
  report.input_is_stream = stream;
  if (stream) report.input = RedactStreamUrl(report.input);
  const auto* folder = dynamic_cast<const ImageFolderSource*>(source.get());  // null unless photos
  // A photo's frame index is its place in the folder's mapping order; the COLMAP model names
  // its images by their files.
  std::vector<std::string> photo_names;
  if (folder != nullptr) {
    report.photos_reordered_by_time = static_cast<std::int64_t>(folder->photos_reordered_by_time());
    for (const std::filesystem::path& file : folder->files()) photo_names.push_back(file.filename().string());
  }
  report.fps = info.fps > 0 ? info.fps : 1.0;
  report.initial_focal = intrinsics.fx;
  report.sift_max_features = options.sift.max_features;
  report.processing_width = info.processing_size.width;
  report.processing_height = info.processing_size.height;
  if (info.frame_count > 0) {
    report.frames_total = (info.frame_count + options.source.stride - 1) / options.source.stride;
  }
  // GPS telemetry for georeferencing (engine/geo): a track given explicitly must parse (before
  // any mapping); one found next to the video only warns when it does not.
  std::optional<std::vector<GpsSample>> gps;
  if (options.gps_track) {
    gps = ReadGpsTrack(*options.gps_track);
    report.gps_track = options.gps_track->string();
  } else if (folder != nullptr && options.find_gps) {
    std::vector<GpsSample> exif = ExifGpsTrack(folder->files());
    if (!exif.empty()) {
      report.gps_track = "EXIF GPS of the photos";
      gps = std::move(exif);
    }
  } else if (options.find_gps && !stream) {
    if (const std::optional<std::filesystem::path> sidecar = FindGpsSidecar(input)) {
      report.gps_track = sidecar->string();
      try {
        gps = ReadGpsTrack(*sidecar);
      } catch (const InputError& e) {
        // The warning names the file already.
        std::string reason = e.what();
        const std::string prefix = sidecar->string() + ": ";
        if (reason.rfind(prefix, 0) == 0) reason.erase(0, prefix.size());
        report.georeference.reason = reason;
      }
    }
  }
  if (gps) GLAM_LOG_INFO("GPS track {}: {} positions", report.gps_track, gps->size());
  const std::optional<ResumeCheckpoint> resume =
      options.resume ? UsableCheckpoint(out_dir, report) : std::nullopt;
  // Where the input goes on: a file at the checkpoint's frame; a live stream, which cannot go
  // back, with what arrives now, numbered after every frame the persisted submaps hold (the
  // frames in between were seen by the interrupted run only; the next submap is linked to the
  // earlier ones by retrieval where it sees their ground, else it starts a part of its own).
  std::int64_t resume_frame = 0;
  if (resume) {
    resume_frame = resume->resume_frame;
    if (stream && resume->next_submap_id > 0) {
      const Submap last = ReadSubmap(submaps_root, resume->next_submap_id - 1);
      resume_frame = std::max<std::int64_t>(resume_frame, static_cast<std::int64_t>(last.last_frame) + 1);
    }
    intrinsics.fx = intrinsics.fy = resume->focal;
    intrinsics.SetK1(resume->k1);
    report.resumed_from_frame = resume_frame;
    source->SeekTo(resume_frame);
    GLAM_LOG_INFO("resuming {} at frame {} with submap {} (focal {:.1f} px, k1 {:.4f})", report.input,
                  resume_frame, resume->next_submap_id, resume->focal, resume->k1);
  } else {
    ClearPreviousRun(out_dir);
  }
  // Map tiles for the viewer (written once per submap) and tileset.json (per revision).
  const std::string run_id = resume && !resume->run_id.empty() ? resume->run_id : NewRunId();
  TileWriter tiles(out_dir, run_id);
  OpenSubmapPreviewer previewer(options.preview, options.alignment.leveling, tiles);
  GLAM_LOG_INFO("mapping {}: {}x{} -> {}x{}, {:.3g} fps, ~{} frames, initial focal {:.1f} px",
                report.input, info.original_size.width, info.original_size.height,
                info.processing_size.width, info.processing_size.height, report.fps,
                report.frames_total, intrinsics.fx);

  SubmapOptions submap_options = options.submap;
  submap_options.estimate_readout =
      options.rolling_shutter.estimate && options.EffectiveDetectionInterval(info.fps) > 1;
  // Photos: every photo is a keyframe and overlaps only its neighbours, so a window of the last
  // few held by older ones drifts where adjusting the whole submap does not (the 18 Brighton
  // Beach photos: 0.58 -> 0.81 m with the EXIF focal fixed, 0.50 -> 1.15 m with COLMAP's), and
  // a submap of photos is small enough for the whole adjustment to cost little.
  if (folder != nullptr) submap_options.local_ba_keyframes = 0;
  SubmapBuilder builder(intrinsics, submap_options, cancel);
  if (resume) builder.ResumeAt(resume->next_submap_id, resume->focal_held, resume->k1_held, resume->readout_ms);
  SubmapAligner aligner(vocabulary, options.alignment, submaps_root, cancel);
  // Each published revision aligned at most one submap, so the interrupted run never got past
  // revision next_submap_id: continuing after it keeps revisions growing for the job's readers.
  if (resume) aligner.ContinueRevisionsAfter(resume->next_submap_id);
  AlignmentThread alignment(aligner, options.alignment_queue_capacity);
  if (resume) {
    // Thread 2 rebuilds its database and graph from the persisted submaps.
    for (std::uint32_t id = 0; id < resume->next_submap_id; ++id) {
      auto submap = std::make_shared<const Submap>(ReadSubmap(submaps_root, id));
      if (id + 1 == resume->next_submap_id) previewer.OnSubmapCompleted(submap);
      alignment.Push(std::move(submap));
    }
  }
  // Revisions go out in metres, east-north-up as soon as the GPS fit succeeds (live_georeference.h).
  std::optional<LiveGeoreferencer> live_geo;
  if (gps) {
    live_geo.emplace(*gps, report.fps, options.georeference, submaps_root);
    previewer.GeoreferenceWith(&*live_geo);
  }
  auto publishable = [&live_geo](std::shared_ptr<const MapSnapshot> snapshot) {
    return live_geo ? live_geo->Apply(snapshot) : snapshot;
  };
  BoundedQueue<FrameFeatures> queue(options.queue_capacity);
  std::atomic<bool> stop{false};
  const int min_features = options.submap.min_tracking_inliers;
  FeatureStageOptions feature_stage;
  feature_stage.sift = options.sift;
  feature_stage.klt = options.klt;
  feature_stage.workers = options.feature_workers;
  feature_stage.detection_interval = options.EffectiveDetectionInterval(info.fps);
  feature_stage.max_detection_interval = options.EffectiveMaxDetectionInterval(info.fps);
  feature_stage.detection_motion_fraction = options.detection_motion_fraction;
  feature_stage.min_features = static_cast<std::size_t>(min_features);
  feature_stage.rolling_shutter = options.rolling_shutter;
  // Without KLT tracks there is no image motion to estimate the readout from (photo folders,
  // SIFT on every frame); a readout given is warned about by the feature stage.
  if (feature_stage.detection_interval == 1) feature_stage.rolling_shutter.estimate = false;
  report.detection_interval = feature_stage.detection_interval;
  report.max_detection_interval = feature_stage.max_detection_interval;  // = detection_interval when fixed
  DecoderWorker worker(*source, feature_stage, queue, cancel, stop);
  std::thread decoder([&worker] {
    NameCurrentThread("glam-decode");
    worker.Run();
  });

  MappingProgress state;
  state.stage = "mapping";
  state.frames_total = report.frames_total;
  const std::int64_t first_frame = resume_frame / options.source.stride;
  state.frames_done = first_frame;
  auto last_progress = Clock::now() - std::chrono::seconds(1);
  std::int64_t submaps_completed = resume ? resume->next_submap_id : 0;
  // The map revision clients are told about: the one whose tileset.json is on disk, not thread
  // 2's latest, so a client told about a revision can fetch its tileset (0 before the first).
  auto published_revision = [&tiles] { return std::max<std::int64_t>(0, tiles.last_revision_written()); };
  auto emit = [&](bool force) {
    if (!progress) return;
    if (!force && Clock::now() - last_progress < std::chrono::milliseconds(250)) return;
    last_progress = Clock::now();
    const double elapsed = Seconds(start);
    const double done_here = static_cast<double>(state.frames_done - first_frame);
    state.fps = elapsed > 0 ? done_here / elapsed : 0;
    state.eta_s = (state.frames_total > 0 && state.fps > 0)
                      ? std::max<double>(0, static_cast<double>(state.frames_total - state.frames_done) / state.fps)
                      : -1;
    state.submaps_completed = submaps_completed;
    state.submaps_aligned = alignment.submaps_aligned();
    state.revision = published_revision();
    state.keyframes = builder.stats().keyframes;
    state.points = alignment.points();
    state.previews = previewer.previews();
    state.preview_submap = previewer.last_submap();
    state.preview_keyframes = previewer.last_keyframes();
    progress(state);
  };
  double writing = 0;
  double tile_writing = 0;
  auto consume = [&](std::vector<Submap> completed) {
    for (std::size_t i = 0; i < completed.size(); ++i) {
      Submap& submap = completed[i];
      const auto write_start = Clock::now();
      WriteSubmap(submap, submaps_root);
      const auto tiles_start = Clock::now();
      tiles.OnSubmapCompleted(submap);
      tile_writing += Seconds(tiles_start);
      if (live_geo) live_geo->AddSubmap(submap);
      WriteCheckpoint(out_dir, MakeCheckpoint(builder, completed, i, report, run_id));
      writing += Seconds(write_start);
      GLAM_LOG_INFO("submap {} completed: frames {}-{}, {} keyframes, {} landmarks", submap.id,
                    submap.first_frame, submap.last_frame, submap.keyframes.size(),
                    submap.landmarks.size());
      ++submaps_completed;
      auto shared = std::make_shared<const Submap>(std::move(submap));
      previewer.OnSubmapCompleted(shared);
      alignment.Push(std::move(shared));
      emit(true);  // every completed submap is reported (the server turns it into an event)
    }
  };

  double builder_seconds = 0;
  std::exception_ptr error;
  try {
    while (true) {
      cancel.ThrowIfCancelled();
      alignment.RethrowIfFailed();
      std::optional<FrameFeatures> item = queue.PopFor(std::chrono::milliseconds(100));
      if (alignment.revision() > published_revision()) {  // a new map revision
        tiles.OnRevision(*publishable(aligner.snapshot()));
        emit(true);
      }
      if (!item) {
        if (queue.IsClosed() && queue.Size() == 0) break;
        continue;
      }
      const auto t0 = Clock::now();
      std::vector<Submap> completed = builder.AddFrame(item->index, item->timestamp_s, item->features);
      builder_seconds += Seconds(t0);
      ++state.frames_done;
      consume(std::move(completed));
      const bool previewed = previewer.Update(builder);
      emit(previewed);  // a preview is reported at once (the server turns it into an event)
    }
  } catch (...) {
    error = std::current_exception();
  }
  stop.store(true);
  queue.Close();
  // A cancelled run's decoder thread may wait for a live stream's next frame; the input is
  // abandoned (a finished input has nothing left to abandon).
  if (error) source->Abort();
  decoder.join();
  if (error) {
    alignment.Abort();
    std::rethrow_exception(error);
  }
  if (worker.error()) {
    alignment.Abort();
    std::rethrow_exception(worker.error());
  }
  try {
    cancel.ThrowIfCancelled();
    const auto t0 = Clock::now();
    std::vector<Submap> completed = builder.Finish();
    builder_seconds += Seconds(t0);
    consume(std::move(completed));
  } catch (...) {
    alignment.Abort();
    throw;
  }
  alignment.Finish();  // joins thread 2; rethrows its error
  if (worker.frames() == 0 && !resume) {
    throw InputError(fmt::format("{}: no frames could be decoded", report.input));
  }

  state.stage = "refining";
  emit(true);
  MapRefinementResult refined = RefineFinishedMap(aligner.snapshot(), aligner.LandmarkGroups(), submaps_root,
                                                  tiles, options.global_refinement, cancel);
  report.global_refinement = refined.summary;
  report.timings.global_refinement_s = refined.summary.seconds;
  std::shared_ptr<const MapSnapshot> snapshot = std::move(refined.snapshot);

  state.stage = "writing";
  emit(true);
  const auto write_start = Clock::now();
  if (gps) {
    MapGeoreference geo = GeoreferenceMap(*snapshot, submaps_root, report.fps, *gps, options.georeference);
    report.georeference = geo.map;
    report.georeferenced_parts = std::move(geo.parts);
    if (geo.snapshot) {
      snapshot = std::move(geo.snapshot);
    } else if (live_geo && live_geo->fit()) {
      // Revisions went out in ENU during the run but the whole map's fit failed: the files are
      // in the mapping frame, so the tileset must be too, as one more revision.
      auto plain = std::make_shared<MapSnapshot>(*snapshot);
      plain->revision = snapshot->revision + 1;
      snapshot = std::move(plain);
    }
  }
  // The COLMAP model describes the input's own frames and photos (full resolution).
  ColmapImageSize colmap_image_size;
  if (info.original_size.area() > 0 && info.scale > 0) {
    colmap_image_size = {info.original_size.width, info.original_size.height, info.scale};
  }
  const MapExportCounts exported =
      ExportWorldMap(*snapshot, submaps_root, out_dir, report.fps, photo_names, colmap_image_size);
  WriteGeoJsonTrack(*snapshot, submaps_root, out_dir, report);
  tiles.OnRevision(*snapshot);
  tiles.ClearOpenPreview();  // normally gone with the revision that placed its submap
  tiles.WriteMapGlb(*snapshot, submaps_root);
  WriteJson(out_dir / "graph.json", aligner.GraphJson());
  writing += Seconds(write_start);

  const SubmapBuilderStats& stats = builder.stats();
  report.frames_decoded = worker.frames() + (resume ? first_frame : 0);
  report.frames_posed = exported.frames_posed;
  report.frames_unposed = std::max<std::int64_t>(0, report.frames_decoded - report.frames_posed);
  report.frames_without_features = worker.frames_without_features();
  report.frames_detected = worker.frames_detected();
  report.rolling_shutter_ms = stats.readout_ms.value_or(worker.rolling_shutter_ms());
  report.rolling_shutter_estimated = submap_options.estimate_readout;
  report.rolling_shutter_determined = stats.readout_ms.has_value();
  report.rolling_shutter_profile = stats.readout_profile;
  report.rolling_shutter_decided_at_submap = stats.readout_decided_at_submap;
  report.rolling_shutter_mean_shift_px = worker.rolling_shutter_mean_shift_px();
  report.rolling_shutter_max_shift_px = worker.rolling_shutter_max_shift_px();
  report.keyframes = stats.keyframes;
  report.submaps = static_cast<std::int64_t>(snapshot->submaps.size());
  report.submaps_discarded = stats.submaps_discarded;
  report.disconnected_submaps = report.submaps - exported.submaps_exported;
  report.parts = exported.parts;
  report.points = exported.points;
  report.tracking_losses = stats.tracking_losses;
  report.frames_matched_globally = stats.frames_matched_globally;
  report.frames_rotation_only = stats.frames_rotation_only;
  report.moving_landmarks_removed = stats.moving_landmarks_removed;
  report.submap_rebuilds = stats.submap_rebuilds;
  report.bootstrap_twin_checks = stats.bootstrap_twin_checks;
  report.bootstrap_twins_kept = stats.bootstrap_twins_kept;
  report.revision = snapshot->revision;
  report.graph_edges = static_cast<std::int64_t>(aligner.edges().size());
  for (const AlignmentEdge& e : aligner.edges()) report.retrieved_edges += e.temporal ? 0 : 1;
  report.graph_landmarks = static_cast<std::int64_t>(aligner.graph_landmarks());
  report.alignment = aligner.timings();
  report.focal = builder.focal();
  // Focal lengths in processing pixels -> original-resolution pixels (ResolveIntrinsics' inverse).
  const auto to_original = [&info](double px) { return info.scale > 0 ? px / info.scale : px; };
  report.focal_original = to_original(builder.focal());
  if (stats.free_focal_px) report.free_focal_original = to_original(*stats.free_focal_px);
  report.free_focal_rms_gain = stats.free_focal_rms_gain;
  report.focal_held = stats.focal_held;
  report.focal_profile_rms_increase = stats.focal_profile_rms_increase;
  report.k1 = builder.k1();
  report.k1_estimated = options.submap.bundle_adjustment.refine_k1 && !stats.k1_held;
  report.k1_held = stats.k1_held;
  report.k1_profile_rms_increase = stats.k1_profile_rms_increase;
  report.input_ended_early = source->ended_early();
  report.frames_dropped = source->frames_dropped();
  report.timings.decode_and_features_s = worker.busy_seconds();
  report.timings.builder_s = builder_seconds;
  report.timings.bundle_adjust_s = stats.bundle_adjust_seconds;
  report.timings.alignment_s = alignment.busy_seconds();
  report.timings.writing_s = writing;
  report.timings.tiles_s = tile_writing;
  report.timings.total_s = Seconds(start);
  report.processing_fps = report.timings.total_s > 0
                              ? static_cast<double>(worker.frames()) / report.timings.total_s
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
