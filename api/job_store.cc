#include "api/job_store.h"

#include <sqlite3.h>

#include <utility>

#include <fmt/format.h>

#include "api/job_json.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"

namespace glam::api {
namespace {

using nlohmann::json;

// RAII prepared statement with 1-based binds and 0-based column reads.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql) : db_(db) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK) {
      throw EnvironmentError(fmt::format("job store: cannot prepare \"{}\": {}", sql, sqlite3_errmsg(db)));
    }
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& Bind(int i, const std::string& v) {
    sqlite3_bind_text(stmt_, i, v.c_str(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
    return *this;
  }
  Statement& Bind(int i, std::int64_t v) {
    sqlite3_bind_int64(stmt_, i, v);
    return *this;
  }
  Statement& Bind(int i, int v) { return Bind(i, static_cast<std::int64_t>(v)); }
  Statement& BindNull(int i) {
    sqlite3_bind_null(stmt_, i);
    return *this;
  }
  // True while a row is available.
  bool Step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw EnvironmentError(fmt::format("job store: {}", sqlite3_errmsg(db_)));
  }
  std::string Text(int col) const {
    const unsigned char* t = sqlite3_column_text(stmt_, col);
    return t == nullptr ? std::string() : std::string(reinterpret_cast<const char*>(t));
  }
  bool IsNull(int col) const { return sqlite3_column_type(stmt_, col) == SQLITE_NULL; }
  std::int64_t Int(int col) const { return sqlite3_column_int64(stmt_, col); }

 private:
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
};

constexpr const char* kColumns =
    "id, name, state, error, created_ms, updated_ms, options, progress, input_file, input_info, "
    "warnings, resume, last_event_id, parts";

json ParseStored(const std::string& text, json fallback) {
  try {
    return json::parse(text);
  } catch (const json::parse_error&) {
    return fallback;
  }
}

Job ReadJob(const Statement& s) {
  Job job;
  job.id = s.Text(0);
  job.name = s.Text(1);
  if (!ParseJobState(s.Text(2), &job.state)) job.state = JobState::kFailed;
  if (!s.IsNull(3)) job.error = s.Text(3);
  job.created_ms = s.Int(4);
  job.updated_ms = s.Int(5);
  job.options = ParseStored(s.Text(6), json::object());
  job.progress = ProgressFromJson(ParseStored(s.Text(7), json::object()));
  job.input_file = s.Text(8);
  job.input_info = ParseStored(s.Text(9), json::object());
  const json warnings = ParseStored(s.Text(10), json::array());
  if (warnings.is_array()) {
    for (const json& w : warnings) {
      if (w.is_string()) job.warnings.push_back(w.get<std::string>());
    }
  }
  job.resume = s.Int(11) != 0;
  job.last_event_id = s.Int(12);
  job.parts = ParseStored(s.Text(13), json::array());
  if (!job.parts.is_array()) job.parts = json::array();
  return job;
}

// Binds the 14 columns in kColumns order starting at index 1.
void BindJob(Statement& s, const Job& job) {
  s.Bind(1, job.id).Bind(2, job.name).Bind(3, std::string(ToString(job.state)));
  if (job.error) {
    s.Bind(4, *job.error);
  } else {
    s.BindNull(4);
  }
  s.Bind(5, job.created_ms).Bind(6, job.updated_ms).Bind(7, job.options.dump());
  s.Bind(8, ProgressToJson(job.progress).dump()).Bind(9, job.input_file);
  s.Bind(10, job.input_info.dump()).Bind(11, json(job.warnings).dump());
  s.Bind(12, static_cast<std::int64_t>(job.resume ? 1 : 0)).Bind(13, job.last_event_id);
  s.Bind(14, job.parts.dump());
}

}  // namespace

JobStore::JobStore(const std::filesystem::path& db_path) {
  if (sqlite3_open_v2(db_path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE,
                      nullptr) != SQLITE_OK) {
    const std::string message = db_ != nullptr ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw EnvironmentError(fmt::format("cannot open job store {}: {}", db_path.string(), message));
  }
  sqlite3_busy_timeout(db_, 5000);
  try {
    Exec("PRAGMA journal_mode=WAL");
    Exec("PRAGMA synchronous=NORMAL");
    Exec("PRAGMA foreign_keys=ON");
    Migrate();
  } catch (...) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw;
  }
}

JobStore::~JobStore() { sqlite3_close(db_); }

void JobStore::Exec(const char* sql) const {
  char* error = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &error) != SQLITE_OK) {
    const std::string message = error != nullptr ? error : "unknown error";
    sqlite3_free(error);
    throw EnvironmentError(fmt::format("job store: {} ({})", message, sql));
  }
}

void JobStore::Migrate() {
  Statement version_query(db_, "PRAGMA user_version");
  version_query.Step();
  const std::int64_t version = version_query.Int(0);
  if (version > kSchemaVersion) {
    throw EnvironmentError(fmt::format(
        "job store schema version {} is newer than this server understands ({}); upgrade glam",
        version, kSchemaVersion));
  }
  if (version == kSchemaVersion) return;
  // Each step migrates one version up, in a transaction.
  if (version < 1) MigrateTo1();
  if (version < 2) {
    // Version 1 -> 2: the disconnected parts of a completed run (Job::parts).
    Exec("BEGIN");
    try {
      Exec("ALTER TABLE jobs ADD COLUMN parts TEXT NOT NULL DEFAULT '[]'; PRAGMA user_version = 2;");
      Exec("COMMIT");
    } catch (...) {
      sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
      throw;
    }
  }
}

void JobStore::MigrateTo1() {
  // Version 0 -> 1: the initial schema.
  Exec("BEGIN");
  try {
    Exec(R"sql(
      CREATE TABLE IF NOT EXISTS jobs (
        id TEXT PRIMARY KEY,
        name TEXT NOT NULL,
        state TEXT NOT NULL,
        error TEXT,
        created_ms INTEGER NOT NULL,
        updated_ms INTEGER NOT NULL,
        options TEXT NOT NULL,
        progress TEXT NOT NULL,
        input_file TEXT NOT NULL,
        input_info TEXT NOT NULL,
        warnings TEXT NOT NULL,
        resume INTEGER NOT NULL DEFAULT 0,
        last_event_id INTEGER NOT NULL DEFAULT 0);
      CREATE INDEX IF NOT EXISTS jobs_by_created ON jobs(created_ms);
      CREATE TABLE IF NOT EXISTS events (
        job_id TEXT NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,
        id INTEGER NOT NULL,
        type TEXT NOT NULL,
        data TEXT NOT NULL,
        created_ms INTEGER NOT NULL,
        PRIMARY KEY (job_id, id));
      PRAGMA user_version = 1;
    )sql");
    Exec("COMMIT");
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

void JobStore::Insert(const Job& job) {
  std::lock_guard lock(mutex_);
  Statement s(db_, fmt::format("INSERT INTO jobs ({}) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?)", kColumns).c_str());
  BindJob(s, job);
  s.Step();
}

bool JobStore::Update(const Job& job) {
  std::lock_guard lock(mutex_);
  Statement s(db_,
              "UPDATE jobs SET id=?1, name=?2, state=?3, error=?4, created_ms=?5, updated_ms=?6, "
              "options=?7, progress=?8, input_file=?9, input_info=?10, warnings=?11, resume=?12, "
              "last_event_id=?13, parts=?14 WHERE id=?1");
  BindJob(s, job);
  s.Step();
  return sqlite3_changes(db_) > 0;
}

std::optional<Job> JobStore::Get(const std::string& id) const {
  std::lock_guard lock(mutex_);
  Statement s(db_, fmt::format("SELECT {} FROM jobs WHERE id=?", kColumns).c_str());
  s.Bind(1, id);
  if (!s.Step()) return std::nullopt;
  return ReadJob(s);
}

std::vector<Job> JobStore::List(int limit, int offset) const {
  std::lock_guard lock(mutex_);
  Statement s(db_, fmt::format("SELECT {} FROM jobs ORDER BY created_ms DESC, rowid DESC "
                               "LIMIT ? OFFSET ?",
                               kColumns)
                       .c_str());
  s.Bind(1, limit).Bind(2, offset);
  std::vector<Job> jobs;
  while (s.Step()) jobs.push_back(ReadJob(s));
  return jobs;
}

std::vector<Job> JobStore::ListInState(JobState state) const {
  std::lock_guard lock(mutex_);
  Statement s(db_, fmt::format("SELECT {} FROM jobs WHERE state=? ORDER BY created_ms, rowid",
                               kColumns)
                       .c_str());
  s.Bind(1, std::string(ToString(state)));
  std::vector<Job> jobs;
  while (s.Step()) jobs.push_back(ReadJob(s));
  return jobs;
}

int JobStore::Count() const {
  std::lock_guard lock(mutex_);
  Statement s(db_, "SELECT COUNT(*) FROM jobs");
  s.Step();
  return static_cast<int>(s.Int(0));
}

std::map<JobState, int> JobStore::CountByState() const {
  std::lock_guard lock(mutex_);
  std::map<JobState, int> counts;
  for (const JobState state : kAllJobStates) counts[state] = 0;
  Statement s(db_, "SELECT state, COUNT(*) FROM jobs GROUP BY state");
  while (s.Step()) {
    JobState state;
    if (ParseJobState(s.Text(0), &state)) counts[state] = static_cast<int>(s.Int(1));
  }
  return counts;
}

bool JobStore::Remove(const std::string& id) {
  std::lock_guard lock(mutex_);
  Statement events(db_, "DELETE FROM events WHERE job_id=?");
  events.Bind(1, id);
  events.Step();
  Statement s(db_, "DELETE FROM jobs WHERE id=?");
  s.Bind(1, id);
  s.Step();
  return sqlite3_changes(db_) > 0;
}

void JobStore::AppendEvent(const std::string& job_id, const JobEvent& event) {
  std::lock_guard lock(mutex_);
  Exec("BEGIN");
  try {
    Statement s(db_, "INSERT INTO events (job_id, id, type, data, created_ms) VALUES (?,?,?,?,?)");
    s.Bind(1, job_id).Bind(2, event.id).Bind(3, event.type).Bind(4, event.data.dump()).Bind(5, NowMs());
    s.Step();
    Statement u(db_, "UPDATE jobs SET last_event_id=MAX(last_event_id, ?) WHERE id=?");
    u.Bind(1, event.id).Bind(2, job_id);
    u.Step();
    Exec("COMMIT");
  } catch (...) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    throw;
  }
}

std::vector<JobEvent> JobStore::EventsAfter(const std::string& job_id, std::int64_t after_id) const {
  std::lock_guard lock(mutex_);
  Statement s(db_, "SELECT id, type, data FROM events WHERE job_id=? AND id>? ORDER BY id");
  s.Bind(1, job_id).Bind(2, after_id);
  std::vector<JobEvent> events;
  while (s.Step()) {
    events.push_back(JobEvent{s.Int(0), s.Text(1), ParseStored(s.Text(2), json::object())});
  }
  return events;
}

std::int64_t JobStore::MaxEventId(const std::string& job_id) const {
  std::lock_guard lock(mutex_);
  Statement s(db_, "SELECT COALESCE(MAX(id), 0) FROM events WHERE job_id=?");
  s.Bind(1, job_id);
  s.Step();
  return s.Int(0);
}

}  // namespace glam::api
