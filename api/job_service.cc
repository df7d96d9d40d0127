#include "api/job_service.h"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <random>
#include <system_error>

#include <fmt/format.h>

#include "api/api_error.h"
#include "api/ids.h"
#include "api/stream_url.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/video/frame_source.h"
#include "engine/video/stream_source.h"

namespace glam::api {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

MappingReport RunMappingExecutor(const Job& job, const fs::path& job_dir,
                                 const MappingOptions& options, const ProgressCallback& progress,
                                 const CancellationToken& cancel) {
  const fs::path input = IsStreamJob(job) ? fs::path(job.input_info["stream_url"].get<std::string>())
                                          : job_dir / job.input_file;
  return RunMapping(input, job_dir, options, progress, cancel);
}

json ProbeWithEngine(const fs::path& file) {
  const FrameSourceInfo info = ProbeVideo(file);
  constexpr int kMinSide = 16;
  constexpr int kMaxSide = 16384;
  const int w = info.original_size.width;
  const int h = info.original_size.height;
  if (w < kMinSide || h < kMinSide || w > kMaxSide || h > kMaxSide) {
    throw InputError(fmt::format("video size {}x{} is outside {}..{} pixels", w, h, kMinSide, kMaxSide));
  }
  return {{"width", w}, {"height", h}, {"fps", info.fps}, {"frame_count", info.frame_count}};
}

// "clip.MP4" -> "mp4"; anything odd -> "video" (FFmpeg detects containers by content).
std::string SafeExtension(const std::string& original_name) {
  const auto dot = original_name.find_last_of('.');
  if (dot == std::string::npos) return "video";
  std::string ext = original_name.substr(dot + 1);
  if (ext.empty() || ext.size() > 5) return "video";
  for (char& c : ext) {
    if (!std::isalnum(static_cast<unsigned char>(c))) return "video";
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  }
  return ext;
}

std::string DisplayName(const std::string& original_name) {
  const auto slash = original_name.find_last_of("/\\");
  std::string name = slash == std::string::npos ? original_name : original_name.substr(slash + 1);
  if (name.size() > 200) name.resize(200);
  return name.empty() ? "upload" : name;
}

void RemoveQuietly(const fs::path& path) {
  std::error_code ec;
  fs::remove_all(path, ec);
  if (ec) GLAM_LOG_WARN("cannot remove {}: {}", path.string(), ec.message());
}

// The COLMAP text model of the map's keyframes and landmarks (engine/export/colmap_model.h).
const std::set<std::string> kColmapFiles = {"colmap/cameras.txt", "colmap/images.txt", "colmap/points3D.txt"};
// What a disconnected part has of the map's files.
const std::set<std::string> kPartFiles = {"trajectory.tum", "points.ply", "colmap/cameras.txt", "colmap/images.txt",
                                          "colmap/points3D.txt"};

// parts/<n>/<one of kPartFiles>: a disconnected part of a completed job's flight, written on
// its own (report.json "parts").
fs::path PartFile(const fs::path& dir, const std::string& id, const std::string& name) {
  constexpr std::size_t kPrefix = 6;  // "parts/"
  const std::size_t slash = name.find('/', kPrefix);
  const std::string file = slash == std::string::npos ? "" : name.substr(slash + 1);
  long long number = 0;
  if (slash == std::string::npos ||
      !ParseNonNegativeInt(std::string_view(name).substr(kPrefix, slash - kPrefix), &number) ||
      number < 1 || kPartFiles.count(file) == 0) {
    throw ApiError(400, "bad_request",
                   "part files are parts/<part number>/trajectory.tum, points.ply or colmap/{cameras,images,"
                   "points3D}.txt, parts numbered from 1");
  }
  const fs::path path = dir / "parts" / std::to_string(number) / file;
  if (!fs::is_regular_file(path)) {
    throw ApiError(404, "not_found",
                   fmt::format("job {} has no part {} (report.json lists the parts of the flight that "
                               "could not be linked to the map)",
                               id, number));
  }
  return path;
}

}  // namespace

bool IsStreamJob(const Job& job) {
  return job.input_info.is_object() && job.input_info.contains("stream_url") &&
         job.input_info["stream_url"].is_string();
}

JobService::JobService(JobServiceOptions options) : options_(std::move(options)) {
  if (!options_.executor) options_.executor = RunMappingExecutor;
  if (!options_.probe) options_.probe = ProbeWithEngine;
  std::error_code ec;
  fs::create_directories(options_.data_dir / "jobs", ec);
  if (!ec) fs::create_directories(options_.data_dir / "uploads", ec);
  if (ec) {
    throw EnvironmentError(fmt::format("cannot create data directory {}: {}",
                                       options_.data_dir.string(), ec.message()));
  }
  store_ = std::make_unique<JobStore>(options_.data_dir / "glam.db");
  Recover();
  runner_ = std::make_unique<JobRunner>(
      options_.concurrent_jobs,
      [this](const std::string& id, const CancellationToken& cancel) { RunJob(id, cancel); });
  for (const Job& job : store_->ListInState(JobState::kQueued)) runner_->Enqueue(job.id);
}

JobService::~JobService() { Shutdown(); }

void JobService::Recover() {
  // Uploads that were still being received when the process stopped are incomplete.
  for (const auto& entry : fs::directory_iterator(options_.data_dir / "uploads")) {
    GLAM_LOG_INFO("removing incomplete upload {}", entry.path().string());
    RemoveQuietly(entry.path());
  }
  // A job directory without a row: the process stopped between moving the upload and
  // inserting the job, so the client never got a 201.
  for (const auto& entry : fs::directory_iterator(options_.data_dir / "jobs")) {
    const std::string name = entry.path().filename().string();
    if (!IsValidJobId(name) || !store_->Get(name)) {
      GLAM_LOG_INFO("removing orphaned job directory {}", entry.path().string());
      RemoveQuietly(entry.path());
    }
  }
  std::lock_guard lock(mutex_);
  for (Job job : store_->ListInState(JobState::kRunning)) {
    GLAM_LOG_INFO("job {} was interrupted; queued again to resume", job.id);
    job.resume = true;
    SetStateLocked(job, JobState::kQueued, std::nullopt, "resumed after restart");
  }
}

fs::path JobService::JobDir(const std::string& id) const {
  GLAM_CHECK(IsValidJobId(id), "job id {} reached the file system unvalidated", id);
  return options_.data_dir / "jobs" / id;
}

fs::path JobService::NewUploadPath() const {
  return options_.data_dir / "uploads" / (NewJobId() + ".part");
}

void JobService::CheckCanQueue() const {
  if (shutting_down()) throw ApiError(503, "shutting_down", "the server is shutting down");
  const auto counts = store_->CountByState();
  if (counts.at(JobState::kQueued) >= options_.max_queued_jobs) {
    throw ApiError(503, "queue_full",
                   fmt::format("{} jobs are already queued (limit {}); try again later",
                               counts.at(JobState::kQueued), options_.max_queued_jobs));
  }
}

Job JobService::CreateJob(const fs::path& upload, const std::string& original_name,
                          const JobOptions& job_options, const std::string& telemetry) {
  json input_info;
  const bool photos = fs::is_directory(upload);
  try {
    CheckCanQueue();
    input_info = options_.probe(upload);
  } catch (const InputError& e) {
    RemoveQuietly(upload);
    if (photos) throw ApiError(422, "unsupported_images", fmt::format("no usable photos: {}", e.what()));
    throw ApiError(422, "unsupported_video", fmt::format("not a decodable video: {}", e.what()));
  } catch (...) {
    RemoveQuietly(upload);
    throw;
  }
  std::error_code ec;
  input_info["filename"] = DisplayName(original_name);
  if (photos) {
    std::int64_t bytes = 0, images = 0;
    for (const fs::directory_entry& entry : fs::directory_iterator(upload, ec)) {
      bytes += static_cast<std::int64_t>(entry.file_size(ec));
      ++images;
    }
    input_info["size_bytes"] = bytes;
    input_info["images"] = images;
  } else {
    input_info["size_bytes"] = static_cast<std::int64_t>(fs::file_size(upload, ec));
  }

  Job job = NewQueuedJob(job_options.name.empty() ? DisplayName(original_name) : job_options.name, job_options);
  job.input_file = photos ? std::string(kImagesFolder) : "input." + SafeExtension(original_name);
  job.input_info = input_info;

  const fs::path dir = JobDir(job.id);
  fs::create_directories(dir, ec);
  if (!ec) fs::rename(upload, dir / job.input_file, ec);
  if (!ec && !telemetry.empty()) {
    // Next to the video under its name, where the engine looks for a sidecar (gps_track.h).
    std::ofstream out(dir / kTelemetryFile, std::ios::binary);
    out.write(telemetry.data(), static_cast<std::streamsize>(telemetry.size()));
    out.close();
    if (!out) ec = std::make_error_code(std::errc::io_error);
  }
  if (ec) {
    RemoveQuietly(upload);
    RemoveQuietly(dir);
    throw EnvironmentError(fmt::format("cannot store the upload: {}", ec.message()));
  }
  Queue(job);
  GLAM_LOG_INFO("job {} created ({}, {} bytes)", job.id, job.name,
                input_info["size_bytes"].get<std::int64_t>());
  return Get(job.id);
}

Job JobService::NewQueuedJob(const std::string& name, const JobOptions& job_options) const {
  Job job;
  do {
    job.id = NewJobId();
  } while (fs::exists(JobDir(job.id)) || store_->Get(job.id));
  job.name = name;
  job.state = JobState::kQueued;
  job.created_ms = job.updated_ms = NowMs();
  job.options = ToJson(job_options);
  job.progress.stage = "queued";
  return job;
}

void JobService::Queue(Job& job) {
  {
    std::lock_guard lock(mutex_);
    store_->Insert(job);
    EmitLocked(job, "state", {{"state", "queued"}, {"error", nullptr}});
  }
  runner_->Enqueue(job.id);
}

Job JobService::CreateStreamJob(const std::string& url, const JobOptions& job_options) {
  if (!options_.allow_streams) {
    throw ApiError(403, "streams_disabled",
                   "this server does not map live streams (start it with --allow-streams)");
  }
  CheckStreamUrl(url);
  CheckCanQueue();
  Job job = NewQueuedJob(job_options.name.empty() ? RedactStreamUrl(url) : job_options.name, job_options);
  job.input_info = {{"stream_url", url}};  // shown redacted (JobToJson)
  std::error_code ec;
  fs::create_directories(JobDir(job.id), ec);
  if (ec) throw EnvironmentError(fmt::format("cannot create the job directory: {}", ec.message()));
  Queue(job);
  GLAM_LOG_INFO("job {} created (live stream {})", job.id, RedactStreamUrl(url));
  return Get(job.id);
}

Job JobService::Finish(const std::string& id) {
  std::lock_guard lock(mutex_);
  Job job = GetLocked(id);
  const auto live = live_.find(id);
  if (!IsStreamJob(job) || job.state != JobState::kRunning || live == live_.end()) {
    throw ApiError(409, "invalid_state",
                   IsStreamJob(job)
                       ? fmt::format("job {} is {}; only a running stream job can be finished", id, ToString(job.state))
                       : fmt::format("job {} maps a file, which ends by itself; only a live-stream job can be "
                                     "finished (cancel stops a file job)",
                                     id));
  }
  live->second.end_stream.Cancel();
  GLAM_LOG_INFO("job {}: the stream input ends by request; finishing the map", id);
  return job;
}

Job JobService::GetLocked(const std::string& id) const {
  if (!IsValidJobId(id)) {
    throw ApiError(400, "invalid_id", "job ids are 16 lower-case hexadecimal characters");
  }
  std::optional<Job> job = store_->Get(id);
  if (!job) throw ApiError(404, "not_found", fmt::format("no job with id {}", id));
  return *job;
}

Job JobService::Get(const std::string& id) const { return GetLocked(id); }

JobPage JobService::List(int limit, int offset) const {
  if (limit < 1 || limit > 1000) throw ApiError(400, "bad_request", "limit must be in 1..1000");
  if (offset < 0) throw ApiError(400, "bad_request", "offset must be >= 0");
  return JobPage{store_->List(limit, offset), store_->Count()};
}

JobEvent JobService::EmitLocked(Job& job, const std::string& type, json data) {
  JobEvent event{job.last_event_id + 1, type, std::move(data)};
  job.last_event_id = event.id;
  if (type == "progress" || type == "preview") {
    store_->Update(job);  // keeps last_event_id, so ids stay unique across a restart
    (type == "progress" ? live_[job.id].latest_progress : live_[job.id].latest_preview) = event;
  } else {
    store_->AppendEvent(job.id, event);
  }
  events_changed_.notify_all();
  return event;
}

void JobService::SetStateLocked(Job& job, JobState state, std::optional<std::string> error,
                                const std::string& reason) {
  job.state = state;
  job.error = std::move(error);
  job.updated_ms = NowMs();
  store_->Update(job);
  json data = {{"state", std::string(ToString(state))},
               {"error", job.error ? json(*job.error) : json(nullptr)}};
  if (!reason.empty()) data["reason"] = reason;
  EmitLocked(job, "state", std::move(data));
}

Job JobService::Cancel(const std::string& id, std::chrono::milliseconds wait) {
  {
    std::lock_guard lock(mutex_);
    Job job = GetLocked(id);
    if (IsTerminal(job.state)) {
      throw ApiError(409, "invalid_state",
                     fmt::format("job {} is {}; only queued or running jobs can be canceled", id,
                                 ToString(job.state)));
    }
    if (runner_->RemoveQueued(id) || job.state == JobState::kQueued) {
      job.progress.stage = "canceled";
      SetStateLocked(job, JobState::kCanceled, std::nullopt, "canceled by request");
      return job;
    }
    runner_->CancelRunning(id);
  }
  runner_->WaitUntilIdle(id, wait);
  return Get(id);
}

void JobService::RemoveOutputs(const Job& job) const {
  const fs::path dir = JobDir(job.id);
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const fs::path name = entry.path().filename();
    if (name != job.input_file && name != kTelemetryFile) RemoveQuietly(entry.path());
  }
}

Job JobService::Restart(const std::string& id) {
  CheckCanQueue();
  std::lock_guard lock(mutex_);
  Job job = GetLocked(id);
  if (!IsTerminal(job.state)) {
    throw ApiError(409, "invalid_state",
                   fmt::format("job {} is {}; only completed, failed or canceled jobs can be "
                               "restarted",
                               id, ToString(job.state)));
  }
  RemoveOutputs(job);
  job.progress = MappingProgress{};
  job.progress.stage = "queued";
  job.warnings.clear();
  job.parts = nlohmann::json::array();
  job.resume = false;
  SetStateLocked(job, JobState::kQueued, std::nullopt, "restarted by request");
  runner_->Enqueue(id);
  return job;
}

void JobService::Delete(const std::string& id) {
  {
    std::lock_guard lock(mutex_);
    GetLocked(id);
    deleting_.insert(id);
    runner_->RemoveQueued(id);
    runner_->CancelRunning(id);
  }
  runner_->WaitUntilIdle(id, std::chrono::seconds(60));
  {
    std::lock_guard lock(mutex_);
    store_->Remove(id);
    live_.erase(id);
    deleting_.erase(id);
    events_changed_.notify_all();
  }
  RemoveQuietly(JobDir(id));
  GLAM_LOG_INFO("job {} deleted", id);
}

fs::path JobService::ResultFile(const std::string& id, const std::string& name) const {
  const Job job = Get(id);
  static const std::set<std::string> kWholeMap = {"trajectory.tum", "trajectory.geojson", "points.ply",
                                                  "report.json", "graph.json"};
  const fs::path dir = JobDir(id);
  const bool part = name.rfind("parts/", 0) == 0;
  if (kWholeMap.count(name) != 0 || kColmapFiles.count(name) != 0 || part) {
    if (job.state != JobState::kCompleted) {
      throw ApiError(409, "not_ready",
                     fmt::format("{} is produced when the job completes; job {} is {}", name, id,
                                 ToString(job.state)));
    }
    if (part) return PartFile(dir, id, name);
    const fs::path path = dir / name;
    if (!fs::is_regular_file(path)) {
      throw ApiError(404, "not_found",
                     fmt::format("job {} has no {}{}", id, name,
                                 name == "trajectory.geojson" ? " (written for georeferenced maps only: upload the "
                                                                "video's GPS track, or photos with EXIF GPS)"
                                                              : ""));
    }
    return path;
  }
  fs::path path;
  if (name == "tileset.json" || name == "tileset.quantized.json" || name == "map.glb") {
    path = dir / name;
  } else if (name.rfind("tiles/", 0) == 0 && name.size() > 10 &&
             name.compare(name.size() - 4, 4, ".glb") == 0) {
    // tiles/<n>.glb (Draco) or tiles/<n>.quantized.glb (KHR_mesh_quantization variant), and
    // the open submap's preview tiles/<n>.open.glb / tiles/<n>.open.quantized.glb.
    std::string_view stem = std::string_view(name).substr(6, name.size() - 10);
    const auto strip = [&stem](std::string_view suffix) {
      const bool has = stem.size() > suffix.size() && stem.substr(stem.size() - suffix.size()) == suffix;
      if (has) stem.remove_suffix(suffix.size());
      return has;
    };
    const bool quantized = strip(".quantized");
    const bool open = strip(".open");
    long long submap = 0;
    if (!ParseNonNegativeInt(stem, &submap)) {
      throw ApiError(400, "bad_request", "tile names are tiles/<submap number>.glb (or .open.glb)");
    }
    path = dir / "tiles" / fmt::format("{}{}{}.glb", submap, open ? ".open" : "", quantized ? ".quantized" : "");
  } else {
    throw ApiError(404, "not_found", fmt::format("unknown result file {}", name));
  }
  if (!fs::is_regular_file(path)) {
    throw ApiError(404, "not_available",
                   fmt::format("{} is not available for job {}: map tiles appear as submaps "
                               "complete, the tileset with the first map revision, map.glb "
                               "when the job completes",
                               name, id));
  }
  return path;
}

EventBatch JobService::WaitForEvents(const std::string& id, std::int64_t after_id,
                                     std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  EventBatch batch;
  auto collect = [&]() -> bool {
    if (shutting_down_) {
      batch.gone = true;
      return true;
    }
    std::optional<Job> job = store_->Get(id);
    if (!job || deleting_.count(id) != 0) {
      batch.gone = true;
      return true;
    }
    batch.events = store_->EventsAfter(id, after_id);
    const auto live = live_.find(id);
    if (live != live_.end()) {
      for (const std::optional<JobEvent>& latest : {live->second.latest_progress, live->second.latest_preview}) {
        if (!latest || latest->id <= after_id) continue;
        const auto pos = std::lower_bound(batch.events.begin(), batch.events.end(), latest->id,
                                          [](const JobEvent& e, std::int64_t v) { return e.id < v; });
        batch.events.insert(pos, *latest);
      }
    }
    const std::int64_t last_seen = batch.events.empty() ? after_id : batch.events.back().id;
    batch.finished = IsTerminal(job->state) && last_seen >= store_->MaxEventId(id);
    return !batch.events.empty() || batch.finished;
  };
  events_changed_.wait_for(lock, timeout, collect);
  return batch;
}

ServiceStats JobService::Stats() const {
  ServiceStats stats;
  stats.jobs_by_state = store_->CountByState();
  {
    std::lock_guard lock(mutex_);
    stats.frames_processed_total = frames_processed_total_;
  }
  stats.queued_in_runner = runner_->queued();
  stats.running_in_runner = runner_->running();
  return stats;
}

void JobService::Shutdown() {
  {
    std::lock_guard lock(mutex_);
    if (shutting_down_) return;
    shutting_down_ = true;
    events_changed_.notify_all();
  }
  if (runner_) runner_->Shutdown();
}

bool JobService::shutting_down() const {
  std::lock_guard lock(mutex_);
  return shutting_down_;
}

void JobService::RunJob(const std::string& id, const CancellationToken& cancel) {
  Job job;
  MappingOptions mapping_options;
  {
    std::lock_guard lock(mutex_);
    std::optional<Job> stored = store_->Get(id);
    if (!stored || stored->state != JobState::kQueued || deleting_.count(id) != 0) return;
    job = *stored;
    live_[id] = Live{};
    job.progress = MappingProgress{};
    job.progress.stage = "starting";
    job.warnings.clear();
    job.parts = nlohmann::json::array();
    bool max_features_given = false;
    try {
      const JobOptions job_options = ParseJobOptions(job.options);
      max_features_given = job_options.max_features.has_value();
      mapping_options = ToMappingOptions(job_options);
    } catch (const std::exception& e) {
      SetStateLocked(job, JobState::kFailed, fmt::format("invalid job options: {}", e.what()));
      live_.erase(id);
      return;
    }
    mapping_options.resume = job.resume;
    if (IsStreamJob(job)) {
      mapping_options.source.allow_streams = true;  // CreateStreamJob checked the URL
      mapping_options.source.end_stream = live_[id].end_stream;
    }
    if (job.input_file == kImagesFolder && !max_features_given) {
      mapping_options.sift.max_features = kPhotoFolderMaxFeatures;
    }
    SetStateLocked(job, JobState::kRunning, std::nullopt, job.resume ? "resuming" : "");
  }
  GLAM_LOG_INFO("job {}: mapping started{}", id, job.resume ? " (resume)" : "");

  MappingReport report;
  JobState final_state = JobState::kCompleted;
  std::optional<std::string> error;
  bool interrupted = false;
  try {
    report = options_.executor(
        job, JobDir(id), mapping_options,
        [this, &id](const MappingProgress& p) { OnProgress(id, p); }, cancel);
  } catch (const Cancelled&) {
    if (runner_->shutting_down()) {
      interrupted = true;
    } else {
      final_state = JobState::kCanceled;
    }
  } catch (const InputError& e) {
    final_state = JobState::kFailed;
    error = e.what();
  } catch (const std::exception& e) {
    final_state = JobState::kFailed;
    error = fmt::format("mapping failed: {}", e.what());
  }

  std::lock_guard lock(mutex_);
  std::optional<Job> stored = store_->Get(id);
  if (!stored) {
    live_.erase(id);
    return;
  }
  job = *stored;
  if (interrupted) {
    // Stays `running`: the next start re-queues it with resume (Recover()).
    job.resume = true;
    store_->Update(job);
    GLAM_LOG_INFO("job {}: interrupted by shutdown; it resumes on the next start", id);
    live_.erase(id);
    return;
  }
  const auto live = live_.find(id);
  if (live != live_.end()) job.progress = live->second.last;
  job.progress.stage = std::string(ToString(final_state));
  if (final_state == JobState::kCompleted) {
    job.progress.eta_s = 0;
    job.warnings = report.warnings;
    job.parts = nlohmann::json::array();
    for (const PartExport& part : report.parts) {
      job.parts.push_back({{"part", part.number},
                           {"first_frame", part.first_frame},
                           {"last_frame", part.last_frame},
                           {"frames_posed", part.frames_posed},
                           {"points", part.points}});
    }
  }
  job.resume = false;
  EmitLocked(job, "progress", ProgressToJson(job.progress));
  SetStateLocked(job, final_state, error);
  live_.erase(id);
  GLAM_LOG_INFO("job {}: {}{}", id, ToString(final_state), error ? ": " + *error : "");
}

void JobService::OnProgress(const std::string& id, const MappingProgress& progress) {
  try {
    std::lock_guard lock(mutex_);
    Live& live = live_[id];
    std::optional<Job> stored = store_->Get(id);
    if (!stored) return;
    Job& job = *stored;
    if (progress.frames_done > live.last.frames_done) {
      frames_processed_total_ += progress.frames_done - live.last.frames_done;
    }
    for (std::int64_t s = live.last.submaps_completed; s < progress.submaps_completed; ++s) {
      EmitLocked(job, "submap", {{"submap_id", s}, {"revision", progress.revision}});
    }
    if (progress.revision > live.last.revision) {
      EmitLocked(job, "revision", {{"revision", progress.revision}});
    }
    if (progress.previews > live.last.previews) {  // the open submap's tile in tileset.json changed
      EmitLocked(job, "preview", {{"submap_id", progress.preview_submap},
                                  {"keyframes", progress.preview_keyframes},
                                  {"revision", progress.revision}});
    }
    const bool stage_changed = progress.stage != live.last.stage;
    live.last = progress;
    job.progress = progress;
    const std::int64_t now = NowMs();
    if (stage_changed || now - live.last_progress_ms >= options_.progress_interval.count()) {
      live.last_progress_ms = now;
      job.updated_ms = now;
      EmitLocked(job, "progress", ProgressToJson(progress));
    }
  } catch (const std::exception& e) {
    // The engine's callback must not throw; a store failure here only loses a progress update.
    GLAM_LOG_WARN("job {}: progress update failed: {}", id, e.what());
  }
}

}  // namespace glam::api
