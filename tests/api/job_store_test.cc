#include "api/job_store.h"

#include <sqlite3.h>

#include <unistd.h>

#include <filesystem>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/temp_dir.h"

#include "api/ids.h"
#include "engine/core/error.h"

namespace glam::api {
namespace {

namespace fs = std::filesystem;

fs::path FreshDir(const std::string& name) { return glam::testing::FreshTempDir("api_store_" + name); }

Job MakeJob(std::int64_t created_ms) {
  Job job;
  job.id = NewJobId();
  job.name = "job " + std::to_string(created_ms);
  job.created_ms = job.updated_ms = created_ms;
  job.input_file = "input.mp4";
  job.options = {{"stride", 2}};
  return job;
}

TEST(JobStore, PersistsJobsAndEventsAcrossReopen) {
  const fs::path dir = FreshDir("reopen");
  Job a = MakeJob(1000);
  Job b = MakeJob(2000);
  {
    JobStore store(dir / "glam.db");
    store.Insert(a);
    store.Insert(b);
    b.state = JobState::kFailed;
    b.error = "decoder exploded";
    b.progress.frames_done = 42;
    b.progress.stage = "mapping";
    b.warnings = {"too dark"};
    b.parts = nlohmann::json::array({{{"part", 1}, {"first_frame", 300}}});
    b.resume = true;
    EXPECT_TRUE(store.Update(b));
    store.AppendEvent(a.id, JobEvent{1, "state", {{"state", "queued"}}});
    store.AppendEvent(a.id, JobEvent{3, "submap", {{"submap_id", 0}}});
  }
  JobStore store(dir / "glam.db");
  EXPECT_EQ(store.Count(), 2);
  const auto got = store.Get(b.id);
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(got->state, JobState::kFailed);
  EXPECT_EQ(got->error.value_or(""), "decoder exploded");
  EXPECT_EQ(got->progress.frames_done, 42);
  EXPECT_EQ(got->progress.stage, "mapping");
  ASSERT_EQ(got->warnings.size(), 1u);
  ASSERT_EQ(got->parts.size(), 1u);
  EXPECT_EQ(got->parts[0]["first_frame"], 300);
  EXPECT_EQ(store.Get(a.id)->parts, nlohmann::json::array());
  EXPECT_TRUE(got->resume);
  EXPECT_EQ(got->options["stride"], 2);
  EXPECT_FALSE(store.Get(a.id)->error.has_value());
  EXPECT_EQ(store.Get(a.id)->last_event_id, 3);  // raised by AppendEvent
  const auto events = store.EventsAfter(a.id, 1);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].id, 3);
  EXPECT_EQ(events[0].type, "submap");
  EXPECT_EQ(store.MaxEventId(a.id), 3);
  EXPECT_EQ(store.CountByState()[JobState::kQueued], 1);
  EXPECT_EQ(store.CountByState()[JobState::kFailed], 1);
  EXPECT_FALSE(store.Get("ffffffffffffffff").has_value());
}

TEST(JobStore, ListsNewestFirstWithPaging) {
  JobStore store(FreshDir("list") / "glam.db");
  std::vector<Job> jobs;
  for (int i = 0; i < 5; ++i) {
    jobs.push_back(MakeJob(1000 + i));
    store.Insert(jobs.back());
  }
  const auto page1 = store.List(2, 0);
  const auto page2 = store.List(2, 2);
  const auto page3 = store.List(2, 4);
  ASSERT_EQ(page1.size(), 2u);
  ASSERT_EQ(page2.size(), 2u);
  ASSERT_EQ(page3.size(), 1u);
  EXPECT_EQ(page1[0].id, jobs[4].id);
  EXPECT_EQ(page1[1].id, jobs[3].id);
  EXPECT_EQ(page3[0].id, jobs[0].id);
  const auto queued = store.ListInState(JobState::kQueued);
  ASSERT_EQ(queued.size(), 5u);
  EXPECT_EQ(queued.front().id, jobs[0].id);  // queue order: oldest first
}

TEST(JobStore, RemoveDeletesJobAndEvents) {
  JobStore store(FreshDir("remove") / "glam.db");
  Job a = MakeJob(1);
  store.Insert(a);
  store.AppendEvent(a.id, JobEvent{1, "state", {}});
  EXPECT_TRUE(store.Remove(a.id));
  EXPECT_FALSE(store.Remove(a.id));
  EXPECT_FALSE(store.Get(a.id).has_value());
  EXPECT_TRUE(store.EventsAfter(a.id, 0).empty());
}

// A store written by the version-1 schema (before Job::parts) opens, keeps its jobs and
// gets the new column; parts written afterwards persist.
TEST(JobStore, MigratesAVersionOneStore) {
  const fs::path db = FreshDir("migrate") / "glam.db";
  sqlite3* raw = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &raw), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(raw, R"sql(
      CREATE TABLE jobs (id TEXT PRIMARY KEY, name TEXT NOT NULL, state TEXT NOT NULL, error TEXT,
        created_ms INTEGER NOT NULL, updated_ms INTEGER NOT NULL, options TEXT NOT NULL,
        progress TEXT NOT NULL, input_file TEXT NOT NULL, input_info TEXT NOT NULL,
        warnings TEXT NOT NULL, resume INTEGER NOT NULL DEFAULT 0,
        last_event_id INTEGER NOT NULL DEFAULT 0);
      CREATE TABLE events (job_id TEXT NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,
        id INTEGER NOT NULL, type TEXT NOT NULL, data TEXT NOT NULL, created_ms INTEGER NOT NULL,
        PRIMARY KEY (job_id, id));
      INSERT INTO jobs VALUES ('00000000000000aa', 'old run', 'completed', NULL, 5, 6, '{}', '{}',
        'input.mp4', '{}', '["a warning"]', 0, 4);
      PRAGMA user_version = 1;
    )sql", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(raw);
  {
    JobStore store(db);
    std::optional<Job> old = store.Get("00000000000000aa");
    ASSERT_TRUE(old.has_value());
    EXPECT_EQ(old->name, "old run");
    EXPECT_EQ(old->state, JobState::kCompleted);
    ASSERT_EQ(old->warnings.size(), 1u);
    EXPECT_EQ(old->last_event_id, 4);
    EXPECT_EQ(old->parts, nlohmann::json::array());
    old->parts = nlohmann::json::array({{{"part", 1}, {"frames_posed", 120}}});
    EXPECT_TRUE(store.Update(*old));
  }
  JobStore reopened(db);  // now version 2: no second migration
  EXPECT_EQ(reopened.Get("00000000000000aa")->parts[0]["frames_posed"], 120);
  ASSERT_EQ(sqlite3_open(db.c_str(), &raw), SQLITE_OK);
  sqlite3_stmt* version = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(raw, "PRAGMA user_version", -1, &version, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(version), SQLITE_ROW);
  EXPECT_EQ(sqlite3_column_int(version, 0), JobStore::kSchemaVersion);
  sqlite3_finalize(version);
  sqlite3_close(raw);
}

TEST(JobStore, RefusesNewerSchemaVersion) {
  const fs::path db = FreshDir("version") / "glam.db";
  { JobStore store(db); }
  sqlite3* raw = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &raw), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(raw, "PRAGMA user_version = 99", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(raw);
  EXPECT_THROW(JobStore store(db), EnvironmentError);
}

}  // namespace
}  // namespace glam::api
