// Where frames come from. The submap builder only ever sees this interface, so a video file,
// a folder of photos (and later a live stream) are interchangeable. Frames are delivered at
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

#include <opencv2/core.hpp>

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
};

// Opens a directory as ImageFolderSource, anything else as VideoFileSource.
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
