// Durable job records in SQLite (DIR/glam.db): one row per job plus the persisted SSE events
// (state / submap / revision) so that a client reconnecting with Last-Event-ID misses nothing,
// even across a server restart. WAL journal + synchronous=NORMAL: a committed row survives a
// crash or kill -9 of the process. One connection guarded by a mutex: the server writes a few
// rows per second at most, so serialising is simpler than a connection per thread and never
// the bottleneck. The schema is versioned with PRAGMA user_version; Open() migrates older
// versions and refuses newer ones.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "api/job.h"

struct sqlite3;

namespace glam::api {

class JobStore {
 public:
  static constexpr int kSchemaVersion = 2;

  // Creates the file and schema if needed. Throws EnvironmentError if the database cannot be
  // opened or was written by a newer version.
  explicit JobStore(const std::filesystem::path& db_path);
  ~JobStore();
  JobStore(const JobStore&) = delete;
  JobStore& operator=(const JobStore&) = delete;

  void Insert(const Job& job);
  // Replaces every column of an existing row; returns false if the id is unknown.
  bool Update(const Job& job);
  std::optional<Job> Get(const std::string& id) const;
  // Newest first.
  std::vector<Job> List(int limit, int offset) const;
  std::vector<Job> ListInState(JobState state) const;  // oldest first (queue order)
  int Count() const;
  std::map<JobState, int> CountByState() const;
  // Removes the job and its events; returns false if the id is unknown.
  bool Remove(const std::string& id);

  // Persists an event and raises the job's last_event_id to event.id in one transaction.
  void AppendEvent(const std::string& job_id, const JobEvent& event);
  // Persisted events with id > after_id, in id order.
  std::vector<JobEvent> EventsAfter(const std::string& job_id, std::int64_t after_id) const;
  std::int64_t MaxEventId(const std::string& job_id) const;

 private:
  void Exec(const char* sql) const;
  void Migrate();
  void MigrateTo1();  // the initial schema

  mutable std::mutex mutex_;
  sqlite3* db_ = nullptr;
};

}  // namespace glam::api
