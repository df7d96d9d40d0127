#include "tools/synth/synth.h"

#include <chrono>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>

#include "engine/core/error.h"
#include "engine/core/intrinsics_io.h"
#include "engine/core/logging.h"
#include "engine/export/tum_trajectory.h"
#include "tools/synth/gps_srt_writer.h"
#include "tools/synth/ground_truth_writer.h"
#include "tools/synth/renderer.h"
#include "tools/synth/trajectory.h"
#include "tools/synth/video_writer.h"
#include "tools/synth/world.h"

namespace glam::synth {

namespace {

namespace fs = std::filesystem;

constexpr const char* kOutputs[] = {"video.mp4", "gt_trajectory.tum", "intrinsics.json",
                                    "gt_surface.json", "gt_heights.f32"};

bool UpToDate(const SynthOptions& o, const fs::path& dir) {
  if (!fs::exists(dir / "synth.json")) return false;
  for (const char* name : kOutputs) {
    if (!fs::exists(dir / name)) return false;
  }
  try {
    std::ifstream in(dir / "synth.json");
    nlohmann::json old = nlohmann::json::parse(in);
    if (old.is_object()) old.erase("water_share_seen");  // measured, not an option
    return old == o.ToJson() && (!o.write_frames || fs::exists(dir / "frames"));
  } catch (const nlohmann::json::exception&) {
    return false;
  }
}

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace

SynthReport RunSynth(const SynthOptions& o) {
  o.Check();
  if (o.out.empty()) throw InputError("synth: an output directory is required (--out)");
  const fs::path dir(o.out);
  SynthReport report;
  if (!o.force && UpToDate(o, dir)) {
    GLAM_LOG_INFO("synth: {} is up to date, not re-rendering", dir.string());
    report.skipped = true;
    return report;
  }
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw EnvironmentError("cannot create " + dir.string() + ": " + ec.message());
  fs::remove(dir / "synth.json", ec);  // an interrupted run must not look complete
  if (o.write_frames) fs::create_directories(dir / "frames");

  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<SE3> poses =
      MakeTrajectory(o, [&o](double x, double y) { return TerrainHeight(x, y, o); });
  const World world = World::Generate(o, poses);
  const Intrinsics intrinsics = MakeIntrinsics(o);
  WriteIntrinsicsJson(intrinsics, dir / "intrinsics.json");
  std::vector<TimedPose> timed(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) timed[i] = {static_cast<double>(i) / o.fps, poses[i]};
  WriteTumTrajectory(dir / "gt_trajectory.tum", timed);
  fs::remove(dir / "video.SRT", ec);
  if (o.gps_noise_m >= 0) {
    std::ofstream(dir / "video.SRT") << DjiSrtFromTrajectory(timed, o.gps_noise_m, o.seed);
  }
  world.surface().WriteGroundTruth(dir);
  report.world_seconds = Seconds(t0);

  const auto t1 = std::chrono::steady_clock::now();
  const Renderer renderer(world, intrinsics);
  VideoWriter video(dir / "video.mp4", o.width, o.height, o.fps, o.crf);
  const int log_every = std::max(1, static_cast<int>(o.fps * 5));
  // Rolling shutter: one pose per image row, computed for a block of frames at a time (the
  // flight's path is planned once per block; ~1 M poses = 56 MB at most).
  const bool rolling = o.rolling_shutter_ms > 0;
  const int block_frames = std::max(1, 1000000 / o.height);
  std::vector<SE3> row_poses;
  int block_start = 0;
  double water_share_sum = 0;
  for (int f = 0; f < o.frames; ++f) {
    const double time_s = static_cast<double>(f) / o.fps;
    double water_share = 0;
    if (rolling && (f == 0 || f >= block_start + block_frames)) {
      block_start = f;
      const int block_end = std::min(o.frames, f + block_frames);
      std::vector<double> times;
      times.reserve(static_cast<std::size_t>(block_end - f) * o.height);
      for (int g = f; g < block_end; ++g) {
        for (int row = 0; row < o.height; ++row) times.push_back(o.RowTime(g, row));
      }
      row_poses = MakeTrajectoryAt(o, [&o](double x, double y) { return TerrainHeight(x, y, o); }, times);
    }
    const cv::Mat frame =
        rolling ? renderer.Render(std::vector<SE3>(
                      row_poses.begin() + static_cast<std::ptrdiff_t>(f - block_start) * o.height,
                      row_poses.begin() + static_cast<std::ptrdiff_t>(f - block_start + 1) * o.height),
                  time_s, &water_share)
                : renderer.Render(poses[f], time_s, &water_share);
    water_share_sum += water_share;
    video.Write(frame);
    if (o.write_frames) {
      cv::imwrite((dir / "frames" / fmt::format("{:06d}.png", f)).string(), frame);
    }
    if ((f + 1) % log_every == 0 || f + 1 == o.frames) {
      GLAM_LOG_INFO("synth: frame {}/{} ({:.1f} fps)", f + 1, o.frames, (f + 1) / Seconds(t1));
    }
  }
  video.Close();
  report.render_seconds = Seconds(t1);

  nlohmann::json meta = o.ToJson();
  report.water_share_seen = water_share_sum / o.frames;
  if (o.water_fraction > 0) {
    meta["water_share_seen"] = report.water_share_seen;
    GLAM_LOG_INFO("synth: open water covers {:.1f} % of the pixels on average",
                  100.0 * report.water_share_seen);
  }
  WriteJson(meta, dir / "synth.json");
  GLAM_LOG_INFO("synth: wrote {} ({} frames, world {:.1f} s, render {:.1f} s)", dir.string(),
                o.frames, report.world_seconds, report.render_seconds);
  return report;
}

}  // namespace glam::synth
