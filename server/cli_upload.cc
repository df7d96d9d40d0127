// `glam upload VIDEO|FOLDER`: sends a video (and its DJI .SRT GPS track, found next to it as
// `glam map` finds it) to a GLAM server as resumable uploads, or a folder's photos as a
// resumable image set, creates the job, and with --follow shows its progress until it ends;
// --download DIR then fetches the results. Exit codes (as
// every glam command, server/main.cc): 0 job created (or, when followed, completed), 2 bad
// input or a request the server refused (4xx), 3 server unreachable or failing, or the
// followed job failed or was canceled.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "api/job_json.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/geo/gps_track.h"
#include "engine/video/image_folder_source.h"
#include "server/cli_progress.h"
#include "server/commands.h"
#include "server/upload_client.h"

namespace glam::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct UploadArgs {
  std::string input;  // a video, or a folder of photos
  std::string gps_path;
  bool no_gps = false;
  std::string name;
  std::string options_json;
  std::string upload_id;
  double chunk_mb = 16;
  bool follow = false;
  std::string download_dir;
  double poll_s = 1.0;
  UploadClientOptions client;
};

// The results a completed job offers, as `glam map` writes them.
constexpr const char* kResults[] = {"trajectory.tum",     "points.ply",        "report.json",
                                    "graph.json",         "map.glb",           "colmap/cameras.txt",
                                    "colmap/images.txt",  "colmap/points3D.txt"};

// Draws the progress bar of an upload labelled `label`; the rate counts this run's bytes only.
std::function<void(const UploadProgress&)> ProgressDrawer(std::string label, bool tty) {
  const auto start = std::chrono::steady_clock::now();
  auto first_offset = std::make_shared<std::int64_t>(-1);
  return [=](const UploadProgress& p) {
    if (*first_offset < 0) *first_offset = p.offset;  // bytes the server had before this run
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double rate = s > 0 ? static_cast<double>(p.offset - *first_offset) / s : 0;
    DrawUploadProgress(label, p.offset, p.size, rate, p.retry, tty);
  };
}

std::string SendFile(UploadClient& client, const fs::path& file, const std::string& upload_id, bool tty) {
  const std::string id = client.UploadFile(file, upload_id, ProgressDrawer(file.filename().string(), tty));
  if (tty) std::cerr << "\n";
  return id;
}

// The photos of a folder (not its subfolders), in natural name order; InputError when none.
std::vector<fs::path> PhotosIn(const fs::path& folder) {
  std::vector<fs::path> photos;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder)) {
    if (entry.is_regular_file() && HasImageExtension(entry.path())) photos.push_back(entry.path());
  }
  if (photos.empty()) {
    throw InputError(fmt::format("{} holds no photos (.jpg, .jpeg, .png, .tif, .tiff, .bmp, .webp)", folder.string()));
  }
  std::sort(photos.begin(), photos.end(),
            [](const fs::path& a, const fs::path& b) { return NaturalLess(a.filename().string(), b.filename().string()); });
  return photos;
}

std::string SendPhotos(UploadClient& client, const fs::path& folder, const std::string& upload_id, bool tty) {
  const std::vector<fs::path> photos = PhotosIn(folder);
  fs::path normal = fs::absolute(folder).lexically_normal();
  if (normal.filename().empty()) normal = normal.parent_path();  // "survey/"
  const std::string name = normal.filename().string();
  const std::string id = client.UploadImages(photos, name, upload_id,
                                             ProgressDrawer(fmt::format("{} photos", photos.size()), tty));
  if (tty) std::cerr << "\n";
  return id;
}

// Polls the job until it ends; returns its final JSON.
json Follow(UploadClient& client, const std::string& job_id, double poll_s, bool tty) {
  std::int64_t last_frames = -1;
  while (true) {
    json job = client.GetJob(job_id);
    const std::string state = job.value("state", "");
    if (job.contains("progress")) {
      const MappingProgress p = api::ProgressFromJson(job["progress"]);
      if (tty || p.frames_done != last_frames) DrawProgress(p, tty);
      last_frames = p.frames_done;
    }
    if (state == "completed" || state == "failed" || state == "canceled") {
      if (tty) std::cerr << "\n";
      return job;
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(poll_s));
  }
}

void RunUpload(UploadArgs& args) {
  if (args.client.token.empty()) {
    if (const char* env = std::getenv("GLAM_API_TOKEN")) args.client.token = env;
  }
  if (!(args.chunk_mb >= 0.001 && args.chunk_mb <= 4096)) {
    throw InputError(fmt::format("--chunk-mb must be in 0.001..4096, got {}", args.chunk_mb));
  }
  if (!(args.poll_s >= 0.05 && args.poll_s <= 60)) throw InputError("--poll must be in 0.05..60 seconds");
  args.client.chunk_bytes = static_cast<std::int64_t>(args.chunk_mb * (1 << 20));
  const fs::path input = args.input;
  const bool photos = fs::is_directory(input);
  if (!photos && !fs::is_regular_file(input)) {
    throw InputError(fmt::format("{} is neither a video file nor a folder of photos", input.string()));
  }
  if (photos && !args.gps_path.empty()) {
    throw InputError("--gps goes with a video; photos carry their GPS positions in their EXIF data");
  }
  json options = json::object();
  if (!args.options_json.empty()) {
    options = json::parse(args.options_json, nullptr, /*allow_exceptions=*/false);
    if (!options.is_object()) throw InputError("--options must be a JSON object (the job options of docs/api.md)");
  }
  if (!args.name.empty()) options["name"] = args.name;
  api::ParseJobOptions(options);  // refused here rather than after the upload
  std::optional<fs::path> track;
  if (!args.gps_path.empty()) {
    track = fs::path(args.gps_path);
  } else if (!args.no_gps && !photos) {
    track = FindGpsSidecar(input);
  }
  if (track) {
    try {
      ReadGpsTrack(*track);  // a track without positions is refused before the upload
    } catch (const InputError& e) {
      throw InputError(fmt::format("GPS track {}: {} (--no-gps to upload without it)", track->string(), e.what()));
    }
  }
  if (!args.download_dir.empty()) {
    args.follow = true;
    fs::create_directories(args.download_dir);
  }

  const bool tty = isatty(STDERR_FILENO) != 0;
  UploadClient client(args.client);
  const std::string upload_id =
      photos ? SendPhotos(client, input, args.upload_id, tty) : SendFile(client, input, args.upload_id, tty);
  std::string track_id;
  if (track) {
    GLAM_LOG_INFO("sending the GPS track {}", track->string());
    track_id = SendFile(client, *track, "", tty);
  }
  const json job = client.CreateJob(upload_id, track_id, options);
  const std::string job_id = job.at("id").get<std::string>();
  GLAM_LOG_INFO("job {} created ({}); viewer: {}", job_id, job.value("state", ""), client.UrlOf("/?job=" + job_id));
  std::cout << job.dump() << std::endl;
  if (!args.follow) return;

  const json done = Follow(client, job_id, args.poll_s, tty);
  const std::string state = done.value("state", "");
  if (state != "completed") {
    throw EnvironmentError(fmt::format("job {} {}: {}", job_id, state,
                                       done.contains("error") && done["error"].is_string()
                                           ? done["error"].get<std::string>()
                                           : std::string("no error given")));
  }
  std::cerr << fmt::format("glam upload: job {} completed: {} points; viewer {}\n", job_id,
                           done["progress"].value("points", 0), client.UrlOf("/?job=" + job_id));
  if (!args.download_dir.empty()) {
    for (const char* name : kResults) {
      const fs::path destination = fs::path(args.download_dir) / name;
      std::error_code ec;
      fs::create_directories(destination.parent_path(), ec);
      if (ec) throw EnvironmentError(fmt::format("cannot create {}: {}", destination.parent_path().string(), ec.message()));
      client.Download(job_id, name, destination);
    }
    std::cerr << fmt::format("glam upload: results in {}\n", args.download_dir);
  }
}

}  // namespace

void RegisterUploadCommand(CLI::App& app) {
  auto args = std::make_shared<UploadArgs>();
  CLI::App* cmd = app.add_subcommand(
      "upload",
      "Send a video (or a folder of photos) to a GLAM server as a resumable upload (a dropped link costs a retry, "
      "not the file), create the job, and optionally follow it and download the results");
  cmd->add_option("input", args->input,
                  "Video file, or a folder of photos (its .jpg/.png/.tif files, sent one by one as an image set)")
      ->required();
  cmd->add_option("--server", args->client.server, "Server URL (env GLAM_SERVER)")
      ->envname("GLAM_SERVER")
      ->capture_default_str();
  cmd->add_option("--token", args->client.token, "API token (env GLAM_API_TOKEN)");
  cmd->add_option("--gps", args->gps_path,
                  "GPS track sent with the video (default: the DJI .SRT beside it, as glam map finds it)");
  cmd->add_flag("--no-gps", args->no_gps, "Do not send a GPS track")->excludes("--gps");
  cmd->add_option("--name", args->name, "Job name (default: the file name)");
  cmd->add_option("--options", args->options_json,
                  "Job options as JSON, e.g. '{\"stride\": 2, \"focal\": 1450}' (docs/api.md)");
  cmd->add_option("--upload-id", args->upload_id,
                  "Continue this upload (from the bytes, or photos, the server has) instead of opening a new one");
  cmd->add_option("--chunk-mb", args->chunk_mb, "Bytes per request (MiB)")->capture_default_str();
  cmd->add_option("--retries", args->client.max_attempts, "Tries per chunk (or photo) before giving up")
      ->capture_default_str();
  cmd->add_flag("--follow", args->follow, "Show the job's progress until it ends (exit 3 unless it completes)");
  cmd->add_option("--download", args->download_dir,
                  "With --follow: write trajectory.tum, points.ply, report.json, graph.json, map.glb and colmap/ here");
  cmd->add_option("--poll", args->poll_s, "Seconds between progress requests with --follow")->capture_default_str();
  cmd->callback([args] {
    try {
      RunUpload(*args);
    } catch (const api::ApiError& e) {
      // A refusal is the user's to fix (exit 2); a failing server is not (exit 3).
      if (e.status() >= 400 && e.status() < 500) throw InputError(e.what());
      throw EnvironmentError(e.what());
    }
  });
}

}  // namespace glam::cli
