// One video stream decoded with FFmpeg's libraries (libavformat, libavcodec, libswscale)
// directly, each wanted frame converted to 8-bit BGR *at the size the caller asks for* in a
// single swscale pass.
//
// Why not cv::VideoCapture (which GLAM used before): it converts every frame to full-size BGR
// before the caller can downscale it. Drone footage is mostly 4K; for 10-bit H.265 the
// full-size conversion plus the 4K -> 1280x720 resize took ~38 ms of CPU per frame on top of
// ~55 ms of decoding; converting and scaling in one swscale pass from the decoder's YUV planes
// takes ~11 ms (build/bench/glam_bench_video_decode, docs/benchmarks.md). At the processing
// size itself nothing changes.
//
// What the class keeps from the OpenCV backend, because the rest of GLAM and its users rely on
// it: frames are numbered in presentation order from the first decoded frame, seeks land
// exactly on the asked frame (seek to the key frame before it, decode forward), the
// display rotation stored by phones and some drones is applied, and an undecodable packet is
// skipped rather than ending the stream (the caller compares the frames it got with the
// container's frame count to tell a truncated file).
//
// Not thread-safe; one decoder per reader.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace glam {

struct VideoDecoderOptions {
  // Decoder threads (libavcodec frame/slice threading); 0 = libavcodec's choice (cores + 1).
  // Two: on the 2-core reference machine a 4K H.265 run took the same time with two threads
  // as with libavcodec's three (24.6 s against 24.2-29.5 s) and held ~100 MB fewer 4K frames;
  // one thread was slower (25.3-27.4 s). The SIFT helpers need the cores too.
  int threads = 2;
  // Options for FFmpeg's demuxer and protocol (avformat_open_input), e.g. {"rtsp_transport",
  // "tcp"} or {"listen", "1"}; an option FFmpeg does not know is logged and ignored.
  std::vector<std::pair<std::string, std::string>> format_options;
  // Polled by FFmpeg while it blocks on I/O (opening, reading a network stream); returning true
  // aborts the wait, and the stream then ends as if the input had ended. Empty: never.
  // Network streams need it: a sender that goes silent would otherwise block a read forever.
  std::function<bool()> interrupt;
  // How log lines and error messages name the input; empty = its path. A stream URL's
  // credentials must not reach logs (stream_source.h passes the redacted URL).
  std::string display_name;

  void Check() const;  // throws InputError
};

class VideoDecoder {
 public:
  // Opens the file (or FFmpeg URL: rtsp://, udp://, pipe:0, ...) and its best video stream. Throws InputError when the file is not a
  // container FFmpeg can read, has no video stream, or its codec has no decoder here.
  VideoDecoder(const std::filesystem::path& path, const VideoDecoderOptions& options = {});
  ~VideoDecoder();
  VideoDecoder(const VideoDecoder&) = delete;
  VideoDecoder& operator=(const VideoDecoder&) = delete;

  // Frames per second from the stream (average rate, else the base rate); 0 when unknown.
  double fps() const;
  // Frame count the container announces (or duration x fps); -1 when unknown. An estimate:
  // the decoder may deliver fewer (truncated file) or a few more.
  int64_t announced_frame_count() const;

  // Decodes the next frame; false at the end of the stream (or when nothing more decodes).
  bool Grab();
  // Index of the frame the last Grab() produced (0 for the first frame of the stream).
  int64_t index() const { return index_; }
  // Presentation time of the last grabbed frame in seconds after the first frame's, from the
  // stream's timestamps; nullopt when either has none. Live streams use it to number frames
  // by time, so that frames lost in transit leave gaps instead of shifting the later ones.
  std::optional<double> seconds_since_first() const;
  // Size of the grabbed frame as displayed (after the stream's rotation); empty before Grab().
  cv::Size display_size() const;
  // The grabbed frame as 8-bit BGR scaled to `size` (display orientation), area-filtered when
  // downscaling. Requires a successful Grab(). Throws InputError for a pixel format swscale
  // cannot convert.
  void Retrieve(cv::Size size, cv::Mat* bgr);

  // Prepares the decoder so that the next Grab() yields frame `index`: seeks to the key frame
  // before it and decodes forward. Returns false when the stream ends before `index` (index()
  // is then the last frame there is).
  bool Seek(int64_t index);

 private:
  // With frame `at` decoded (at <= target), decodes up to frame `target` and leaves it for the
  // next Grab(); false when the stream ends first.
  bool DecodeForwardTo(int64_t at, int64_t target);

  struct Impl;
  std::unique_ptr<Impl> impl_;
  int64_t index_ = -1;
};

}  // namespace glam
