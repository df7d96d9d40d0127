// The mapping service without HTTP: accepts uploaded videos (and live-stream URLs) as jobs, runs them through the
// JobRunner, persists every state change in the JobStore, turns engine progress into SSE
// events and answers queries. The REST layer (server/) is a thin translation of requests into
// these calls; tests drive it directly.
//
// Data directory layout (docs/operations.md):
//   DIR/glam.db              job store (SQLite, WAL)
//   DIR/uploads/<tmp>.part   uploads being received (removed on startup: incomplete)
//   DIR/jobs/<id>/input.<ext> the accepted video; RunMapping's outputs next to it
//
// State machine: queued -> running -> completed | failed | canceled; queued -> canceled;
// completed | failed | canceled -> queued (restart). A job found `running` at startup was
// interrupted (crash, kill -9, shutdown): it is queued again with resume set.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "api/job.h"
#include "api/job_json.h"
#include "api/job_runner.h"
#include "api/job_store.h"
#include "engine/core/cancellation.h"
#include "engine/pipeline/mapping_job.h"

namespace glam::api {

// The job's GPS telemetry (multipart field "telemetry") inside DIR/jobs/<id>/: the sidecar
// name of input.<ext> (engine/geo/gps_track.h), kept on restart like the video.
inline constexpr const char* kTelemetryFile = "input.SRT";
// A photo job's input (multipart fields "images"): a folder inside DIR/jobs/<id>/, mapped as a
// photo folder (natural name order, EXIF GPS, kPhotoFolderMaxFeatures SIFT features).
inline constexpr const char* kImagesFolder = "input";

// Runs the engine for one job. The default calls RunMapping(job_dir/input_file, job_dir, ...).
using JobExecutor = std::function<MappingReport(const Job& job, const std::filesystem::path& job_dir,
                                                const MappingOptions& options,
                                                const ProgressCallback& progress,
                                                const CancellationToken& cancel)>;
// Checks an uploaded file before a job is created; returns facts about it for the job JSON
// ("input"). Throws InputError when it is not a usable video. Default: ProbeVideo.
using VideoProbe = std::function<nlohmann::json(const std::filesystem::path& file)>;

struct JobServiceOptions {
  std::filesystem::path data_dir;
  int concurrent_jobs = 1;
  int max_queued_jobs = 100;  // CreateJob / Restart answer 503 beyond this
  // Minimum interval between two `progress` events of one job (at most 2 Hz by contract).
  std::chrono::milliseconds progress_interval{500};
  JobExecutor executor;  // empty = RunMapping
  VideoProbe probe;      // empty = ProbeVideo
  // Whether clients may create live-stream jobs (CreateStreamJob): the server then opens the
  // URLs they send, so it is off by default (`glam serve --allow-streams`).
  bool allow_streams = false;
};

// Whether the job maps a live stream (its input JSON holds "stream_url") rather than a file.
bool IsStreamJob(const Job& job);

struct JobPage {
  std::vector<Job> jobs;
  int total = 0;
};

// Events for an SSE stream (see WaitForEvents).
struct EventBatch {
  std::vector<JobEvent> events;  // ascending ids
  bool finished = false;  // the job is in a terminal state and every event has been returned
  bool gone = false;      // the job was deleted or the service is shutting down
};

struct ServiceStats {
  std::map<JobState, int> jobs_by_state;
  std::int64_t frames_processed_total = 0;
  std::size_t queued_in_runner = 0;
  std::size_t running_in_runner = 0;
};

class JobService {
 public:
  // Opens (or creates) the data directory and store, recovers interrupted jobs and starts the
  // workers. Throws EnvironmentError if the directory or database is unusable.
  explicit JobService(JobServiceOptions options);
  ~JobService();  // Shutdown()
  JobService(const JobService&) = delete;
  JobService& operator=(const JobService&) = delete;

  const std::filesystem::path& data_dir() const { return options_.data_dir; }
  // A fresh path in DIR/uploads/ for streaming an upload to.
  std::filesystem::path NewUploadPath() const;
  // Throws ApiError 503 when no more jobs can be queued (checked before receiving a body).
  void CheckCanQueue() const;

  // Takes ownership of `upload` (moved or removed on every path). Probes it (ApiError 422
  // "unsupported_video" if it is not a decodable video), moves it into DIR/jobs/<id>/ and
  // queues the job. `original_name` gives the display name and file extension. `upload` may
  // also be a folder of photos (the server wrote every file name itself), which becomes
  // kImagesFolder (422 "unsupported_images" when none of them decodes). `telemetry`:
  // the video's GPS track (DJI .SRT text, already validated), stored as kTelemetryFile beside
  // the video, where the engine finds it and georeferences the map; empty = none.
  Job CreateJob(const std::filesystem::path& upload, const std::string& original_name,
                const JobOptions& options, const std::string& telemetry = {});

  // A live stream as a job's input (JobServiceOptions::allow_streams; 403 "streams_disabled"
  // otherwise): an rtsp, rtsps, rtmp, rtmps, srt, udp, rtp, tcp, http or https URL (400
  // "bad_request" for anything else, standard input and pipes included). Not probed: the job
  // opens it when it starts (a stream that does not open fails the job with the reason). The
  // job JSON's input is {"stream_url"} with any user:password shown as ***; the name defaults
  // to that URL. The job ends when the sender stops, after the stall timeout, or at Finish().
  Job CreateStreamJob(const std::string& url, const JobOptions& options);

  // All of these throw ApiError: 400 "invalid_id" for a malformed id, 404 "not_found".
  Job Get(const std::string& id) const;
  JobPage List(int limit, int offset) const;
  // queued -> canceled at once; running -> cancel requested, waits up to `wait` for the
  // engine to stop; 409 "invalid_state" for finished jobs.
  Job Cancel(const std::string& id, std::chrono::milliseconds wait = std::chrono::seconds(10));
  // completed | failed | canceled -> queued, outputs removed; 409 for queued / running.
  Job Restart(const std::string& id);
  // Ends a running live-stream job's input: the map of what arrived is finished and the job
  // completes as if the sender had stopped. Returns at once (the job is still running). 409
  // "invalid_state" for a job that is not a running stream job.
  Job Finish(const std::string& id);
  // Cancels a running job, then removes its record, events and files.
  void Delete(const std::string& id);

  // Path of a result file of the job. `name` is one of trajectory.tum, points.ply,
  // report.json, graph.json (409 "not_ready" unless the job is completed, 404 if missing),
  // tileset.json, map.glb or tiles/<n>.glb (404 "not_available" until the tiles exist).
  // Anything else: 404.
  std::filesystem::path ResultFile(const std::string& id, const std::string& name) const;

  // Blocks up to `timeout` until the job has an event with id > after_id. Returns the
  // persisted events after after_id plus the latest progress event if it is newer (progress
  // is never replayed from the store).
  EventBatch WaitForEvents(const std::string& id, std::int64_t after_id,
                           std::chrono::milliseconds timeout) const;

  ServiceStats Stats() const;

  // Stops the workers: running jobs are cancelled but stay `running` with resume set, so the
  // next start continues them. Wakes every WaitForEvents caller (gone = true). Idempotent.
  void Shutdown();
  bool shutting_down() const;

 private:
  struct Live {  // per running job, guarded by mutex_
    CancellationToken end_stream;  // stream jobs: Finish() ends the input
    MappingProgress last;
    std::int64_t last_progress_ms = 0;
    // Events that only matter while they are the latest (not stored, not replayed beyond the
    // latest): `progress`, and `preview` (the open submap's tile changed, about once a second).
    std::optional<JobEvent> latest_progress;
    std::optional<JobEvent> latest_preview;
  };

  void Recover();
  // A queued job record under a fresh id (no row, no directory yet) with `name` and options.
  Job NewQueuedJob(const std::string& name, const JobOptions& job_options) const;
  // Inserts the job (its directory holds its input), emits its first state event, queues it.
  void Queue(Job& job);
  void RunJob(const std::string& id, const CancellationToken& cancel);
  void OnProgress(const std::string& id, const MappingProgress& progress);
  // Under mutex_: assigns the next event id, persists it unless it is a progress event.
  JobEvent EmitLocked(Job& job, const std::string& type, nlohmann::json data);
  void SetStateLocked(Job& job, JobState state, std::optional<std::string> error,
                      const std::string& reason = {});
  Job GetLocked(const std::string& id) const;
  std::filesystem::path JobDir(const std::string& id) const;
  void RemoveOutputs(const Job& job) const;

  JobServiceOptions options_;
  std::unique_ptr<JobStore> store_;
  mutable std::mutex mutex_;  // state transitions, live_, events
  mutable std::condition_variable events_changed_;
  std::map<std::string, Live> live_;
  std::set<std::string> deleting_;
  std::int64_t frames_processed_total_ = 0;
  bool shutting_down_ = false;
  std::unique_ptr<JobRunner> runner_;  // last: its workers use everything above
};

}  // namespace glam::api
