// Where frames come from. The submap builder only ever sees this interface, so a video file,
// a folder of photos and a live stream (stream_source.h) are interchangeable. Frames are delivered at
// *processing* size: anything larger than FrameSourceOptions::max_image_size on its long side
// is downscaled once here, so 4K footage costs what 720p costs downstream, and every later
// stage works in one pixel unit (processing pixels). The original size travels along so that
// intrinsics given for the original resolution can be rescaled by the caller.
//
// Frame indices are positions in the *input* (before striding), so timestamps, resume points
// and trajectory lines (t = index / fps, see Contracts) mean the same thing whatever stride is.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "engine/core/cancellation.h"

namespace glam {

struct Frame {
  int64_t index = 0;          // position in the input sequence (0-based, before stride)
  double timestamp_s = 0.0;   // index / fps
  cv::Mat bgr;                // 8-bit BGR at processing size
  cv::Size original_size;     // size as stored in the input
};

struct FrameSourceInfo {
  double fps = 0.0;             // image folders: 1
  int64_t frame_count = -1;     // estimate from the container; -1 when unknown (streams)
  cv::Size original_size;
  cv::Size processing_size;
  // processing_size / original_size (the same factor on both axes up to rounding); multiply
  // intrinsics given for the original resolution by this.
  double scale = 1.0;
};

struct FrameSourceOptions {
  // Longest side of processed frames in pixels; larger inputs are downscaled (INTER_AREA).
  // 0 disables downscaling.
  int max_image_size = 1280;
  // Deliver every stride-th frame (indices start, start + stride, ...).
  int stride = 1;
  // Image folders: the photos that carry an EXIF capture time are put in capture order (each
  // taking a place a timed photo had in name order); false: natural name order only
  // (image_folder_source.h).
  bool photos_by_capture_time = true;

  // Live streams (stream_source.h). An input is only opened as a stream URL (rtsp://, srt://,
  // udp://, tcp://, http://, "-" for standard input, ...) when this is true: a program that
  // passes paths it did not choose itself (the server) must never make FFmpeg open a URL.
  bool allow_streams = false;
  // Frames decoded ahead of mapping, in seconds of stream (at least 2 frames), and at most
  // stream_buffer_max_mb of them. 2 s: a submap's completion holds the builder for ~1-2 s, and
  // with 1 s a 640x360 stream that maps at 44 fps from its file still lost 9 of 600 frames
  // there (bench/live_stream.sh); at 1280x720 two seconds are ~170 MB.
  double stream_buffer_s = 2.0;
  int stream_buffer_max_mb = 256;
  // What happens when mapping falls behind a stream and the buffer is full: kDrop discards the
  // oldest buffered frame (a live sender does not wait: unread network data is lost, or the
  // sender drops the connection), kWait stops reading until there is room (a pipe or a file
  // served over HTTP just waits). kAuto: kDrop for the protocols that carry live video
  // (rtsp, rtmp, srt, udp, rtp), kWait for the others.
  enum class StreamDrop { kAuto, kDrop, kWait };
  StreamDrop stream_drop = StreamDrop::kAuto;
  // Seconds to wait for a stream to open (a listening socket: for the sender to connect).
  double stream_open_timeout_s = 60.0;
  // Seconds without a new frame after which a stream counts as ended.
  double stream_stall_timeout_s = 10.0;
  // FFmpeg demuxer / protocol options for stream inputs (VideoDecoderOptions::format_options);
  // rtsp:// gets rtsp_transport=tcp unless given here.
  std::vector<std::pair<std::string, std::string>> stream_options;
  // Cancelled: a stream input ends as if the sender had stopped (frames already buffered are
  // still delivered), so the map of what was received is finished and written. How a user
  // stops mapping a live feed (glam map: the first Ctrl-C).
  CancellationToken end_stream;

  void Check() const;  // throws InputError
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;

  // Next frame, or nullopt at the end of the input. A decoder that stops before the container
  // said it would (truncated file) ends the sequence and logs a warning; see ended_early().
  virtual std::optional<Frame> Next() = 0;

  virtual const FrameSourceInfo& info() const = 0;

  // The next Next() returns the frame with this input index (then index + stride, ...).
  // Seeking to the end (index == frame count) is allowed: Next() then returns nullopt (a run
  // interrupted after its last submap resumes there). Throws InputError beyond the end.
  virtual void SeekTo(int64_t index) = 0;

  // Number of frames delivered by Next() so far.
  virtual int64_t frames_delivered() const = 0;

  // True once the input ended before info().frame_count frames were seen (truncated video).
  virtual bool ended_early() const = 0;

  // Frames decoded but discarded because mapping fell behind a live stream (stream_source.h);
  // 0 for files and folders, which wait for the reader.
  virtual int64_t frames_dropped() const { return 0; }

  // The input is abandoned (a cancelled run): a Next() waiting for a live stream's next frame
  // returns nullopt at once, and so does every later one. Thread-safe. Files and folders never
  // wait, so for them it does nothing.
  virtual void Abort() {}
};

// The lower-case scheme of a URL ("rtsp" for "RTSP://cam/live"); empty without "://".
std::string UrlScheme(const std::string& input);

// True when `input` names a stream for FFmpeg rather than a file or folder: a URL with a
// network protocol FFmpeg reads (rtsp, rtsps, rtmp, rtmps, srt, udp, rtp, tcp, http, https),
// "pipe:N", or "-" (standard input).
bool IsStreamInput(const std::string& input);

// Opens a directory as ImageFolderSource, a stream URL (IsStreamInput, when
// options.allow_streams) as StreamSource, anything else as VideoFileSource.
// Throws InputError for missing / unreadable / empty input, with a message naming the path.
std::unique_ptr<FrameSource> OpenFrameSource(const std::filesystem::path& path,
                                             const FrameSourceOptions& options = {});

// Checks that the input exists and yields at least one frame, and returns its info (the
// server calls this before accepting an upload). Throws InputError otherwise.
FrameSourceInfo ProbeVideo(const std::filesystem::path& path,
                           const FrameSourceOptions& options = {});

// Processing size for an input of `original` size under `max_image_size` (0 = unlimited).
cv::Size ProcessingSize(cv::Size original, int max_image_size);

// Downscales `image` to `processing_size` with INTER_AREA (no copy when sizes agree).
cv::Mat ToProcessingSize(const cv::Mat& image, cv::Size processing_size);

}  // namespace glam
