// `glam map INPUT --out DIR [...]`: mapping of a video file, image folder or live stream. Draws a
// progress bar on stderr when stderr is a terminal (log lines otherwise, e.g. in CI), and
// turns Ctrl-C into a cooperative cancel so that threads are joined and no half-written file
// is left behind by a killed process (on a live stream the first Ctrl-C ends the input instead,
// and the map of what arrived is finished).
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "engine/core/cancellation.h"
#include "engine/core/error.h"
#include "engine/core/intrinsics_io.h"
#include "engine/core/logging.h"
#include "engine/pipeline/mapping_job.h"
#include "engine/video/frame_source.h"
#include "server/cli_progress.h"
#include "server/commands.h"

namespace glam::cli {
namespace {

struct MapArgs {
  std::string input;
  std::string out;
  std::string intrinsics_path;
  double focal = 0;
  bool refine_focal = false;
  bool per_keyframe_focal = false;
  bool fixed_k1 = false;
  std::string vocabulary_path;
  std::string gps_path;
  bool no_gps = false;
  bool max_features_given = false;  // --max-features on the command line
  std::string rolling_shutter = "auto";  // --rolling-shutter-ms: milliseconds or "auto"
  std::string stream_drop = "auto";       // --stream-drop: auto, yes, no
  std::vector<std::string> stream_options;  // --stream-option KEY=VALUE (parsed by its callback)
  bool paper = false;
  MappingOptions options;
};

CancellationToken& InterruptToken() {
  static CancellationToken token;
  return token;
}

// Ends a live stream input (FrameSourceOptions::end_stream): the map of what arrived is finished.
CancellationToken& EndStreamToken() {
  static CancellationToken token;
  return token;
}

// A live stream has no end of its own, so the first Ctrl-C ends the input and the map is
// finished and written; a second one (or any Ctrl-C on a file) cancels.
std::atomic<bool> g_input_is_stream{false};

extern "C" void OnInterrupt(int) {
  if (g_input_is_stream.load() && !EndStreamToken().IsCancelled()) {
    EndStreamToken().Cancel();
    static const char kMessage[] =
        "\nglam map: ending the stream; finishing the map of what arrived (Ctrl-C again to abort)\n";
    const ssize_t written = write(STDERR_FILENO, kMessage, sizeof(kMessage) - 1);
    (void)written;
    return;
  }
  InterruptToken().Cancel();
}

void RunMap(MapArgs& args) {
  // The calibration first: --paper then undoes what it turns on beyond the paper (epipolar
  // matching); the options --paper sets exclude the flags below.
  if (!args.intrinsics_path.empty()) UseCalibration(&args.options, ReadIntrinsicsJson(args.intrinsics_path));
  if (args.paper) UsePaperMethod(&args.options);
  if (!args.intrinsics_path.empty()) {
    args.options.submap.bundle_adjustment.refine_focal = args.refine_focal;  // --refine-focal
  }
  if (args.fixed_k1) args.options.submap.bundle_adjustment.refine_k1 = false;
  if (args.focal != 0) args.options.focal_px = args.focal;
  if (args.per_keyframe_focal) args.options.submap.bundle_adjustment.share_focal = false;
  if (!args.vocabulary_path.empty()) args.options.vocabulary = args.vocabulary_path;
  if (!args.gps_path.empty()) args.options.gps_track = args.gps_path;
  if (args.no_gps) args.options.find_gps = false;
  using StreamDrop = FrameSourceOptions::StreamDrop;
  args.options.source.stream_drop = args.stream_drop == "yes"  ? StreamDrop::kDrop
                                    : args.stream_drop == "no" ? StreamDrop::kWait
                                                               : StreamDrop::kAuto;
  const bool stream = IsStreamInput(args.input);
  args.options.source.allow_streams = true;  // the user named the input
  args.options.source.end_stream = EndStreamToken();
  args.options.Check();
  if (!stream && !std::filesystem::exists(args.input)) {
    throw InputError(fmt::format("input {} does not exist", args.input));
  }
  g_input_is_stream.store(stream);
  if (std::filesystem::is_directory(args.input) && !args.max_features_given) {
    args.options.sift.max_features = kPhotoFolderMaxFeatures;
    GLAM_LOG_INFO("image folder: {} SIFT features per photo (--max-features to change)",
                  kPhotoFolderMaxFeatures);
  }
  const bool tty = isatty(STDERR_FILENO) != 0;
  CancellationToken cancel = InterruptToken();
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);
  MappingReport report;
  try {
    report = RunMapping(args.input, args.out, args.options,
                        [tty](const MappingProgress& p) { DrawProgress(p, tty); }, cancel);
  } catch (...) {
    if (tty) std::cerr << "\n";
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
    throw;
  }
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  if (tty) std::cerr << "\n";
  std::cerr << fmt::format(
      "glam map: {} frames, {} posed, {} unposed, {} submaps ({} disconnected), {} keyframes, "
      "{} points, focal {:.1f} px, {:.1f} fps -> {}\n",
      report.frames_decoded, report.frames_posed, report.frames_unposed, report.submaps,
      report.disconnected_submaps, report.keyframes, report.points, report.focal_original,
      report.processing_fps, args.out);
  if (report.georeference.ok) {
    const Geodetic& o = report.georeference.origin;
    std::cerr << fmt::format(
        "glam map: georeferenced by {} ({} GPS positions, rms {:.2f} m): metres, east-north-up around "
        "{:.6f}, {:.6f}, {:.1f} m\n",
        report.gps_track, report.georeference.samples_used, report.georeference.rms_m, o.latitude_deg,
        o.longitude_deg, o.altitude_m);
  }
  // Repeated after the progress output so the reason for a poor result is the last thing read.
  for (const std::string& warning : report.warnings) {
    std::cerr << "glam map: warning: " << warning << "\n";
  }
}

}  // namespace

void RegisterMapCommand(CLI::App& app) {
  auto args = std::make_shared<MapArgs>();
  CLI::App* cmd = app.add_subcommand(
      "map", "Build submaps, align them (loop closure) and write trajectory.tum, points.ply, "
             "report.json, graph.json and colmap/ (the map as a COLMAP sparse model) from a video, image folder "
             "or live stream (parts of the flight that cannot be linked to the map: parts/<n>/)");
  cmd->add_option("input", args->input,
                  "Video file (anything FFmpeg decodes: MP4/MOV/MKV/TS/AVI, H.264/H.265/VP9/AV1/ProRes), "
                  "folder of images, or a live stream: an rtsp://, rtmp://, srt://, udp://, rtp://, "
                  "tcp:// or http(s):// URL, or - for standard input (Ctrl-C ends a stream and "
                  "finishes the map)")
      ->required();
  cmd->add_option("--out", args->out, "Output directory")->required();
  cmd->add_option("--intrinsics", args->intrinsics_path,
                  "intrinsics.json at the input's original resolution (a calibration: its focal is "
                  "kept fixed unless --refine-focal; for a focal from EXIF or a data sheet add --refine-focal "
                  "or use --focal)");
  cmd->add_option("--focal", args->focal,
                  "Focal length in pixels at original resolution (default: 0.8 x long side), refined; "
                  "kept as given when the footage does not determine it (report.json focal_held)");
  cmd->add_flag("--refine-focal", args->refine_focal,
               "Refine the focal length of --intrinsics too (always refined without them)");
  cmd->add_flag("--fixed-k1", args->fixed_k1,
               "Do not estimate the lens' radial distortion k1 (0, or the k1 of --intrinsics, "
               "which is never re-estimated); by default k1 is estimated and kept where the first "
               "submap fits clearly better with it (report.json k1, k1_held)");
  cmd->add_flag("--per-keyframe-focal", args->per_keyframe_focal,
               "Bundle adjustment refines one focal per keyframe (the paper) instead of one per "
               "submap");
  cmd->add_option("--max-image-size", args->options.source.max_image_size,
                  "Downscale frames to this long side (px); 0 = never")
      ->capture_default_str();
  cmd->add_option("--stride", args->options.source.stride, "Use every N-th frame")->capture_default_str();
  cmd->add_option("--stream-buffer", args->options.source.stream_buffer_s,
                  "Live streams: seconds of frames decoded ahead of mapping (at most 256 MB of "
                  "frames)")
      ->capture_default_str();
  cmd->add_option("--stream-drop", args->stream_drop,
                  "Live streams: when mapping falls behind and the buffer is full, drop the oldest "
                  "buffered frame (yes) or stop reading until there is room (no); auto = yes for "
                  "rtsp, rtmp, srt, udp and rtp, whose senders do not wait")
      ->check(CLI::IsMember({"auto", "yes", "no"}))
      ->capture_default_str();
  cmd->add_option("--stream-open-timeout", args->options.source.stream_open_timeout_s,
                  "Live streams: seconds to wait for the stream to open (a listening URL such as "
                  "tcp://0.0.0.0:5000?listen=1: for the sender to connect)")
      ->capture_default_str();
  cmd->add_option("--stream-timeout", args->options.source.stream_stall_timeout_s,
                  "Live streams: seconds without a frame after which the stream counts as ended")
      ->capture_default_str();
  cmd->add_option("--stream-option", args->stream_options,
                  "Live streams: an FFmpeg protocol or demuxer option KEY=VALUE (repeatable), e.g. "
                  "rtsp_transport=udp (rtsp:// uses tcp by default) or listen=1")
      ->each([args](const std::string& text) {
        const std::size_t eq = text.find('=');
        if (eq == 0 || eq == std::string::npos) {
          throw CLI::ValidationError("--stream-option", "expected KEY=VALUE, got '" + text + "'");
        }
        args->options.source.stream_options.emplace_back(text.substr(0, eq), text.substr(eq + 1));
      });
  cmd->add_flag_callback(
      "--name-order", [args] { args->options.source.photos_by_capture_time = false; },
      "Photo folders: map the photos in name order; by default photos with an EXIF capture time are "
      "mapped in capture order (report.json photos_reordered_by_time)");
  cmd->add_option("--keyframes-per-submap", args->options.submap.keyframes_per_submap,
                  "Keyframes at which a submap is completed (try 12 for footage that is one short "
                  "orbit: smaller submaps bend less; docs/benchmarks.md)")
      ->capture_default_str();
  cmd->add_option("--keyframe-parallax", args->options.submap.max_keyframe_parallax_deg,
                  "A tracked frame at this median parallax (deg) to the last keyframe becomes a "
                  "keyframe even with many PnP inliers; 0 = the paper's inlier rule alone")
      ->capture_default_str();
  cmd->add_option("--keyframe-coverage", args->options.submap.min_map_coverage,
                  "A detected frame of whose textured view the map covers less than this fraction "
                  "becomes a keyframe (climbs over the take-off point); 0 = the paper's rules alone")
      ->capture_default_str();
  cmd->add_option("--bootstrap-parallax", args->options.submap.bootstrap_accept_parallax_deg,
                  "The bootstrap takes its second keyframe at this median parallax (deg) even "
                  "with many essential inliers; 0 = the paper's rule alone")
      ->capture_default_str();
  cmd->add_option("--completion-ba-frames", args->options.submap.completion_ba_max_frames,
                  "Tracked frames that join each submap's final bundle adjustment; 0 = the "
                  "paper's completion (PnP relocalisation only)")
      ->capture_default_str();
  cmd->add_option("--smooth-window", args->options.submap.centre_smoothing.half_window_s,
                  "Camera centres are smoothed over +- this many seconds of video (a robust local "
                  "quadratic fit; rotations re-solved), which removes the sideways jitter of "
                  "compressed footage; 0 = per-frame PnP poses (the paper)")
      ->capture_default_str();
  cmd->add_option("--global-refinement-keyframes", args->options.global_refinement.max_keyframes,
                  "After the last submap, one bundle adjustment of the whole map (tracks joined "
                  "across submaps) when it has at most this many keyframes; 0 = never (the paper: "
                  "submaps stay rigid)")
      ->capture_default_str();
  cmd->add_option("--preview-interval", args->options.preview.interval_s,
                  "While a submap is built, write it as a provisional map tile (tiles/<id>.open.glb, "
                  "listed in tileset.json) at most every this many seconds, so viewers see the map grow "
                  "before the submap completes; 0 = off")
      ->capture_default_str();
  cmd->add_option("--feature-workers", args->options.feature_workers,
                  "Frames whose SIFT features are extracted in parallel")
      ->capture_default_str();
  cmd->add_option("--detect-every", args->options.detection_interval,
                  "SIFT on every N-th frame, KLT optical flow in between; 1 = SIFT on every frame "
                  "(the paper); 0 = automatic (one detection per 0.2 s of video, every photo of a folder)")
      ->capture_default_str();
  cmd->add_option("--detect-max-seconds", args->options.max_detection_seconds,
                  "Automatic schedule: stretch the time between SIFT detections up to this where the "
                  "image moves slowly (faster, slightly less accurate, docs/benchmarks.md); 0 = one "
                  "detection per 0.2 s")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  cmd->add_option("--detect-motion", args->options.detection_motion_fraction,
                  "With --detect-max-seconds: the image motion between detections it aims at (median "
                  "keypoint displacement, fraction of the image diagonal)")
      ->check(CLI::Range(0.001, 1.0))
      ->capture_default_str();
  cmd->add_option("--klt-window", args->options.klt.window_px,
                  "KLT window size in pixels (odd) for the frames between detections")
      ->capture_default_str();
  cmd->add_option("--klt-levels", args->options.klt.pyramid_levels, "KLT pyramid levels above the image")
      ->capture_default_str();
  cmd->add_option("--rolling-shutter-ms", args->rolling_shutter,
                  "The camera's rolling-shutter readout time (ms, first to last image row): "
                  "keypoints are corrected for the motion during the readout; auto = estimated on "
                  "the first submap; 0 = global shutter")
      ->capture_default_str()
      ->each([args](const std::string& text) { args->options.rolling_shutter = RollingShutterFromText(text); });
  cmd->add_option("--max-features", args->options.sift.max_features,
                  fmt::format("SIFT features per frame (image folders: {})", kPhotoFolderMaxFeatures))
      ->capture_default_str()
      ->each([args](const std::string&) { args->max_features_given = true; });
  cmd->add_option("--sift-scale", args->options.sift.extraction_scale,
                  "Detect SIFT on the frame resized by this factor (keypoints in full-resolution "
                  "coordinates); 0.5 drops the finest scales, which cv::SIFT finds on the frame "
                  "upsampled x2: about half the CPU time of a run, at a clearly less accurate map "
                  "(docs/benchmarks.md)")
      ->capture_default_str();
  cmd->add_option("--local-ba-keyframes", args->options.submap.local_ba_keyframes,
                  "Adjust only the last N keyframes (and the landmarks they see) after each new "
                  "keyframe, the older ones held; 0 = the whole submap every time (the paper)")
      ->capture_default_str();
  cmd->add_option("--moving-landmark-frames", args->options.submap.moving_landmark_frames,
                  "Remove a landmark that PnP rejects in this many tracked frames in a row with a "
                  "residual that keeps its direction and grows (water ripples, cloud-shadow "
                  "edges); 0 = keep every landmark (the paper)")
      ->capture_default_str();
  cmd->add_option("--feature-grid", args->options.sift.grid_cols,
                  "Spread each frame's SIFT features over a grid of this many columns (rows from "
                  "the aspect ratio), strongest first per cell; 0 = strongest over the frame (the paper)")
      ->capture_default_str();
  // The paper's method: the options it sets cannot be combined with it (CLI11 reports which).
  CLI::Option* paper = cmd->add_flag(
      "--paper", args->paper,
      "Run the paper's method where the defaults deviate from it (SIFT on every frame, no "
      "feature grid, no parallax keyframe rules, per-keyframe focal, no completion bundle "
      "adjustment, ...; docs/algorithm.md); slower");
  for (const char* name : {"--detect-every", "--feature-grid", "--keyframe-parallax", "--keyframe-coverage",
                           "--bootstrap-parallax", "--completion-ba-frames", "--smooth-window",
                           "--per-keyframe-focal", "--global-refinement-keyframes", "--rolling-shutter-ms",
                           "--local-ba-keyframes", "--moving-landmark-frames"}) {
    paper->excludes(name);
  }
  cmd->add_flag("--resume", args->options.resume,
               "Continue an interrupted run in the same --out from its last completed submap "
               "(checkpoint.json); without a usable checkpoint the run starts from the beginning");
  CLI::Option* gps = cmd->add_option(
      "--gps", args->gps_path,
      "GPS telemetry of the video (DJI subtitle file, .SRT): the map is written in metres, east-north-up "
      "(report.json georeference); default: the video's own .SRT next to it, or the EXIF GPS of a photo folder");
  cmd->add_flag("--no-gps", args->no_gps,
                "Do not georeference with the .SRT next to the video or the EXIF GPS of a photo folder")
      ->excludes(gps);
  cmd->add_option("--vocabulary", args->vocabulary_path,
                  "Vocabulary tree for finding overlapping submaps (glam vocab train); default: built in");
  cmd->callback([args] { RunMap(*args); });
}

}  // namespace glam::cli
