// The service's state machine and durability with a fake engine (no video, no HTTP): the
// executor emits progress like RunMapping does and can be held mid-run by the test.
#include "api/job_service.h"
#include "tests/api/api_error_test_util.h"

#include <atomic>
#include <chrono>
#include <unistd.h>

#include <filesystem>
#include <vector>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

#include "tests/support/fake_mapping.h"
#include "tests/support/temp_dir.h"

#include "api/api_error.h"
#include "engine/core/error.h"

namespace glam::api {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using testing::StatusOf;

fs::path FreshDir(const std::string& name) { return glam::testing::FreshTempDir("api_service_" + name); }

// The fake run (10 steps of 10 frames, held at step 5), plus what the service passed to it.
// A stream job's fake run maps "frames" until its input is ended (Finish) or canceled.
struct FakeEngine : glam::testing::FakeMapping {
  std::atomic<int> runs{0};
  std::atomic<bool> last_resume{false};
  std::atomic<bool> stream_running{false};
  std::atomic<bool> stream_allowed{false};
  std::string stream_url;  // written before stream_running is set

  MappingReport Run(const Job& job, const fs::path& dir, const MappingOptions& options,
                    const ProgressCallback& progress, const CancellationToken& cancel) {
    ++runs;
    last_resume = options.resume;
    if (IsStreamJob(job)) {
      stream_url = job.input_info["stream_url"].get<std::string>();
      stream_allowed = options.source.allow_streams;
      stream_running = true;
      MappingProgress p;
      p.stage = "mapping";
      while (!options.source.end_stream.IsCancelled()) {
        cancel.ThrowIfCancelled();
        ++p.frames_done;
        progress(p);
        std::this_thread::sleep_for(1ms);
      }
      stream_running = false;
      return MappingReport{};
    }
    if (job.name == "fail-input") throw InputError("the video has no texture");
    if (job.name == "fail-env") throw EnvironmentError("disk on fire");
    FakeMapping::Run(dir, progress, cancel);
    MappingReport report;
    report.warnings = {"fake warning"};
    return report;
  }
};

JobServiceOptions Options(const fs::path& dir, FakeEngine& engine) {
  JobServiceOptions o;
  o.data_dir = dir;
  o.progress_interval = 0ms;
  o.executor = [&engine](const Job& job, const fs::path& d, const MappingOptions& m,
                         const ProgressCallback& p, const CancellationToken& c) {
    return engine.Run(job, d, m, p, c);
  };
  o.probe = [](const fs::path& file) {
    std::ifstream in(file);
    std::string head;
    in >> head;
    if (head != "VIDEO") throw InputError("no video stream");
    return nlohmann::json{{"width", 64}, {"height", 48}};
  };
  return o;
}

fs::path Upload(JobService& service, const std::string& content = "VIDEO frames") {
  const fs::path path = service.NewUploadPath();
  std::ofstream(path) << content;
  return path;
}

// Follows the event stream until the job is finished; returns every event seen.
std::vector<JobEvent> FollowToEnd(JobService& service, const std::string& id, std::int64_t after = 0) {
  std::vector<JobEvent> all;
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (std::chrono::steady_clock::now() < deadline) {
    const EventBatch batch = service.WaitForEvents(id, after, 1s);
    for (const JobEvent& e : batch.events) {
      all.push_back(e);
      after = e.id;
    }
    if (batch.finished || batch.gone) return all;
  }
  ADD_FAILURE() << "job " << id << " did not finish";
  return all;
}

void WaitFor(const std::function<bool()>& condition) {
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!condition() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(2ms);
  ASSERT_TRUE(condition());
}

TEST(JobService, RunsAJobToCompletionWithOrderedEvents) {
  FakeEngine engine;
  const fs::path dir = FreshDir("complete");
  JobService service(Options(dir, engine));
  const fs::path upload = Upload(service);
  JobOptions options;
  options.stride = 1;
  const Job created = service.CreateJob(upload, "clip.MP4", options);
  EXPECT_EQ(created.name, "clip.MP4");
  EXPECT_FALSE(fs::exists(upload));
  EXPECT_TRUE(fs::exists(dir / "jobs" / created.id / "input.mp4"));

  const std::vector<JobEvent> events = FollowToEnd(service, created.id);
  ASSERT_FALSE(events.empty());
  std::vector<std::string> states;
  int submaps = 0;
  int revisions = 0;
  int previews = 0;
  for (std::size_t i = 0; i < events.size(); ++i) {
    if (i > 0) {
      EXPECT_GT(events[i].id, events[i - 1].id);
    }
    if (events[i].type == "state") states.push_back(events[i].data["state"]);
    if (events[i].type == "submap") {
      EXPECT_EQ(events[i].data["submap_id"], submaps);
      ++submaps;
    }
    if (events[i].type == "revision") ++revisions;
    if (events[i].type == "preview") {  // the open submap: the one after those completed
      EXPECT_EQ(events[i].data["submap_id"], submaps);
      EXPECT_TRUE(events[i].data.contains("keyframes"));
      ++previews;
    }
  }
  EXPECT_GE(previews, 1);
  EXPECT_EQ(states, (std::vector<std::string>{"queued", "running", "completed"}));
  EXPECT_EQ(submaps, 3);  // submaps_completed went 0 -> 3
  EXPECT_EQ(revisions, 3);
  const Job done = service.Get(created.id);
  EXPECT_EQ(done.state, JobState::kCompleted);
  EXPECT_EQ(done.progress.frames_done, 100);
  EXPECT_EQ(done.progress.stage, "completed");
  ASSERT_EQ(done.warnings.size(), 1u);
  EXPECT_TRUE(fs::exists(service.ResultFile(created.id, "trajectory.tum")));
  EXPECT_EQ(StatusOf([&] { service.ResultFile(created.id, "points.ply"); }), 404);
  EXPECT_EQ(StatusOf([&] { service.ResultFile(created.id, "tileset.json"); }), 404);
  EXPECT_EQ(StatusOf([&] { service.ResultFile(created.id, "tiles/x.glb"); }), 400);
  EXPECT_EQ(StatusOf([&] { service.ResultFile(created.id, "tiles/x.open.glb"); }), 400);
  EXPECT_EQ(StatusOf([&] { service.ResultFile(created.id, "tiles/1.quantized.open.glb"); }), 400);
  EXPECT_EQ(StatusOf([&] { service.ResultFile(created.id, "tiles/1.open.glb"); }), 404);  // none left
  EXPECT_EQ(StatusOf([&] { service.ResultFile(created.id, "../glam.db"); }), 404);
  EXPECT_EQ(service.Stats().frames_processed_total, 100);
  EXPECT_EQ(service.Stats().jobs_by_state[JobState::kCompleted], 1);

  // Replay after an event id: exactly the persisted events after it, no progress or preview
  // (only ever the latest of those, while the job runs).
  const EventBatch replay = service.WaitForEvents(created.id, events[1].id, 0ms);
  for (const JobEvent& e : replay.events) {
    EXPECT_GT(e.id, events[1].id);
    EXPECT_NE(e.type, "progress");
    EXPECT_NE(e.type, "preview");
  }
  EXPECT_TRUE(replay.finished);
}

TEST(JobService, RejectsBadUploadsIdsAndStates) {
  FakeEngine engine;
  engine.hold = true;
  JobService service(Options(FreshDir("errors"), engine));
  const fs::path not_video = Upload(service, "garbage");
  EXPECT_EQ(StatusOf([&] { service.CreateJob(not_video, "x.mp4", {}); }), 422);
  EXPECT_FALSE(fs::exists(not_video));
  EXPECT_EQ(StatusOf([&] { service.Get("../../etc/passwd"); }), 400);
  EXPECT_EQ(StatusOf([&] { service.Get("ffffffffffffffff"); }), 404);
  EXPECT_EQ(StatusOf([&] { service.List(0, 0); }), 400);

  const Job job = service.CreateJob(Upload(service), "a.mp4", {});
  WaitFor([&] { return engine.at_hold.load(); });
  EXPECT_EQ(service.Get(job.id).state, JobState::kRunning);
  EXPECT_EQ(StatusOf([&] { service.Restart(job.id); }), 409);
  EXPECT_EQ(StatusOf([&] { service.ResultFile(job.id, "trajectory.tum"); }), 409);
  const Job canceled = service.Cancel(job.id);
  EXPECT_EQ(canceled.state, JobState::kCanceled);
  EXPECT_EQ(StatusOf([&] { service.Cancel(job.id); }), 409);

  // Restart clears outputs and runs again.
  engine.hold = false;
  std::ofstream(service.data_dir() / "jobs" / job.id / "points.ply") << "stale";
  const Job restarted = service.Restart(job.id);
  EXPECT_EQ(restarted.state, JobState::kQueued);
  FollowToEnd(service, job.id);
  EXPECT_EQ(service.Get(job.id).state, JobState::kCompleted);
  EXPECT_FALSE(fs::exists(service.data_dir() / "jobs" / job.id / "points.ply"));
  EXPECT_TRUE(fs::exists(service.data_dir() / "jobs" / job.id / "input.mp4"));
}

TEST(JobService, FailuresCarryTheEngineMessage) {
  FakeEngine engine;
  JobService service(Options(FreshDir("fail"), engine));
  JobOptions input;
  input.name = "fail-input";
  JobOptions env;
  env.name = "fail-env";
  const Job a = service.CreateJob(Upload(service), "a.mp4", input);
  const Job b = service.CreateJob(Upload(service), "b.mp4", env);
  FollowToEnd(service, a.id);
  FollowToEnd(service, b.id);
  EXPECT_EQ(service.Get(a.id).state, JobState::kFailed);
  EXPECT_EQ(service.Get(a.id).error.value_or(""), "the video has no texture");
  EXPECT_EQ(service.Get(b.id).state, JobState::kFailed);
  EXPECT_NE(service.Get(b.id).error.value_or("").find("disk on fire"), std::string::npos);
}

TEST(JobService, QueueLimitAndCancelOfQueuedJob) {
  FakeEngine engine;
  engine.hold = true;
  JobServiceOptions o = Options(FreshDir("queue"), engine);
  o.max_queued_jobs = 1;
  JobService service(o);
  const Job running = service.CreateJob(Upload(service), "a.mp4", {});
  WaitFor([&] { return engine.at_hold.load(); });
  const Job queued = service.CreateJob(Upload(service), "b.mp4", {});
  const fs::path third = Upload(service);
  EXPECT_EQ(StatusOf([&] { service.CreateJob(third, "c.mp4", {}); }), 503);
  EXPECT_FALSE(fs::exists(third));
  EXPECT_EQ(service.Cancel(queued.id).state, JobState::kCanceled);
  EXPECT_EQ(service.Get(running.id).state, JobState::kRunning);
  service.Delete(running.id);
  EXPECT_EQ(StatusOf([&] { service.Get(running.id); }), 404);
  EXPECT_FALSE(fs::exists(service.data_dir() / "jobs" / running.id));
  EXPECT_EQ(engine.runs.load(), 1);
}

TEST(JobService, InterruptedJobResumesAfterReopen) {
  const fs::path dir = FreshDir("resume");
  std::string id;
  std::int64_t last_event = 0;
  {
    FakeEngine engine;
    engine.hold = true;
    JobService service(Options(dir, engine));
    id = service.CreateJob(Upload(service), "a.mp4", {}).id;
    WaitFor([&] { return engine.at_hold.load(); });
    last_event = service.Get(id).last_event_id;
    std::ofstream(service.NewUploadPath()) << "half an upload";
  }  // destructor = shutdown: the job stays running
  fs::create_directories(dir / "jobs" / "0000000000000000");  // orphan
  FakeEngine engine;
  JobService service(Options(dir, engine));
  EXPECT_TRUE(fs::is_empty(dir / "uploads"));
  EXPECT_FALSE(fs::exists(dir / "jobs" / "0000000000000000"));
  const std::vector<JobEvent> events = FollowToEnd(service, id, last_event);
  EXPECT_EQ(service.Get(id).state, JobState::kCompleted);
  EXPECT_TRUE(engine.last_resume.load());
  ASSERT_FALSE(events.empty());
  EXPECT_GT(events.front().id, last_event);  // ids stay monotonic across the restart
  EXPECT_EQ(events.front().type, "state");
  EXPECT_EQ(events.front().data["state"], "queued");
}

TEST(JobService, StreamJobsNeedPermissionAndANetworkUrl) {
  {
    FakeEngine engine;
    JobService service(Options(FreshDir("streams_off"), engine));
    EXPECT_EQ(StatusOf([&] { service.CreateStreamJob("rtsp://cam/live", {}); }), 403);
  }
  FakeEngine engine;
  JobServiceOptions options = Options(FreshDir("streams_urls"), engine);
  options.allow_streams = true;
  JobService service(options);
  // Standard input, pipes and FFmpeg's file-reading protocols would reach the server's own
  // files or descriptors.
  for (const char* url : {"", "-", "pipe:0", "file:///etc/passwd", "/etc/passwd", "concat:a.ts|b.ts",
                          "subfile,,start,0,end,0,,:/etc/passwd", "ftp://host/x.ts", "rtsp://cam/a b",
                          "rtsp://cam/\nlive"}) {
    EXPECT_EQ(StatusOf([&] { service.CreateStreamJob(url, {}); }), 400) << url;
  }
  EXPECT_EQ(StatusOf([&] { service.CreateStreamJob("rtsp://cam/" + std::string(3000, 'x'), {}); }), 400);
  EXPECT_EQ(service.List(10, 0).total, 0);

  const Job job = service.CreateStreamJob("rtsp://admin:secret@10.0.0.2:554/live", {});
  EXPECT_TRUE(IsStreamJob(job));
  const nlohmann::json shown = JobToJson(job);
  EXPECT_EQ(shown["input"]["stream_url"], "rtsp://***@10.0.0.2:554/live");
  EXPECT_EQ(shown["name"], "rtsp://***@10.0.0.2:554/live");
  EXPECT_EQ(shown.dump().find("secret"), std::string::npos);
  WaitFor([&] { return engine.stream_running.load(); });
  // The engine gets the URL itself, credentials included, and may open it.
  EXPECT_EQ(engine.stream_url, "rtsp://admin:secret@10.0.0.2:554/live");
  EXPECT_TRUE(engine.stream_allowed.load());
  service.Cancel(job.id);
}

TEST(JobService, FinishEndsARunningStreamJobWhichCompletes) {
  FakeEngine engine;
  engine.hold = true;
  JobServiceOptions options = Options(FreshDir("stream_finish"), engine);
  options.allow_streams = true;
  JobService service(options);
  // A file job holds the single worker: a stream job queued behind it cannot be finished yet.
  const std::string file_job = service.CreateJob(Upload(service), "a.mp4", {}).id;
  WaitFor([&] { return engine.at_hold.load(); });
  JobOptions named;
  named.name = "live";
  const std::string stream_job = service.CreateStreamJob("udp://0.0.0.0:5004", named).id;
  EXPECT_EQ(service.Get(stream_job).name, "live");
  EXPECT_EQ(StatusOf([&] { service.Finish(stream_job); }), 409);  // queued
  EXPECT_EQ(StatusOf([&] { service.Finish(file_job); }), 409);    // a file ends by itself
  engine.hold = false;
  WaitFor([&] { return engine.stream_running.load(); });
  EXPECT_EQ(service.Finish(stream_job).state, JobState::kRunning);
  FollowToEnd(service, stream_job);
  EXPECT_EQ(service.Get(stream_job).state, JobState::kCompleted);
  EXPECT_FALSE(engine.stream_running.load());
  EXPECT_EQ(StatusOf([&] { service.Finish(stream_job); }), 409);  // completed
}

}  // namespace
}  // namespace glam::api
