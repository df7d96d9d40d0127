// The job record shared by the store, the service and the runner: plain data, copied between
// threads. Field meanings follow the job JSON of docs/architecture.md (Contracts); the JSON
// itself is produced in job_json.h.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/pipeline/progress.h"

namespace glam::api {

enum class JobState { kQueued, kRunning, kCompleted, kFailed, kCanceled };

std::string_view ToString(JobState state);
// Returns false for an unknown name.
bool ParseJobState(std::string_view name, JobState* state);
// completed, failed and canceled: the runner will not touch the job again unless restarted.
bool IsTerminal(JobState state);
inline constexpr JobState kAllJobStates[] = {JobState::kQueued, JobState::kRunning,
                                             JobState::kCompleted, JobState::kFailed,
                                             JobState::kCanceled};

struct Job {
  std::string id;
  std::string name;
  JobState state = JobState::kQueued;
  std::optional<std::string> error;
  std::int64_t created_ms = 0;  // Unix epoch milliseconds
  std::int64_t updated_ms = 0;
  nlohmann::json options = nlohmann::json::object();  // JobOptions as JSON (job_json.h)
  MappingProgress progress;
  std::string input_file;  // file name inside the job directory, e.g. "input.mp4"
  nlohmann::json input_info = nlohmann::json::object();  // probe result: size, fps, frames
  std::vector<std::string> warnings;  // MappingReport::warnings of the last run
  // The disconnected parts of the last completed run (MappingReport::parts), each
  // {part, first_frame, last_frame, frames_posed, points}; their files are under parts/<n>/.
  nlohmann::json parts = nlohmann::json::array();
  // Set when a running job was interrupted (crash, shutdown): the next run continues from
  // the persisted submaps (MappingOptions::resume).
  bool resume = false;
  // Highest SSE event id handed out for this job (persisted so that ids stay monotonic across
  // restarts even for progress events, which are not stored).
  std::int64_t last_event_id = 0;
};

// One SSE event. state / submap / revision events are persisted for Last-Event-ID replay;
// progress events are not.
struct JobEvent {
  std::int64_t id = 0;
  std::string type;  // "state" | "progress" | "submap" | "revision"
  nlohmann::json data;
};

std::int64_t NowMs();

}  // namespace glam::api
