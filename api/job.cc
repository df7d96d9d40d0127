#include "api/job.h"

#include <chrono>

namespace glam::api {

std::string_view ToString(JobState state) {
  switch (state) {
    case JobState::kQueued: return "queued";
    case JobState::kRunning: return "running";
    case JobState::kCompleted: return "completed";
    case JobState::kFailed: return "failed";
    case JobState::kCanceled: return "canceled";
  }
  return "unknown";
}

bool ParseJobState(std::string_view name, JobState* state) {
  for (const JobState s : kAllJobStates) {
    if (ToString(s) == name) {
      *state = s;
      return true;
    }
  }
  return false;
}

bool IsTerminal(JobState state) {
  return state == JobState::kCompleted || state == JobState::kFailed ||
         state == JobState::kCanceled;
}

std::int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace glam::api
