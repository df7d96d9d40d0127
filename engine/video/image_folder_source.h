// A folder of photos or extracted frames, in natural name order (frame_2 before frame_10), at
// fps = 1 so that timestamp = index. Photos with an EXIF capture time (photo_capture_time.h)
// are then put in capture order among themselves: they fill the places the timed photos held in
// name order, sorted by time (ties keep name order), and files without a time (extracted frames,
// junk such as macOS "._" resource forks) keep their places, so a folder without EXIF times is
// in plain name order (FrameSourceOptions::photos_by_capture_time = false: always). Files that are not images (by extension) are ignored;
// images that fail to decode or whose size differs from the first image are skipped with a
// warning (their index stays reserved, so indices always match the sorted file list). The
// first image that decodes sets the size. JPEGs larger than the processing size are decoded
// at 1/2, 1/4 or 1/8 of their size by libjpeg (never below the processing size), then resized.
#pragma once

#include <filesystem>
#include <optional>
#include <vector>

#include "engine/video/frame_source.h"

namespace glam {

class ImageFolderSource : public FrameSource {
 public:
  // Throws InputError when the folder is missing, holds no image files, or none of them
  // decodes.
  ImageFolderSource(const std::filesystem::path& folder, const FrameSourceOptions& options);

  std::optional<Frame> Next() override;
  const FrameSourceInfo& info() const override { return info_; }
  void SeekTo(int64_t index) override;
  int64_t frames_delivered() const override { return delivered_; }
  bool ended_early() const override { return false; }

  const std::vector<std::filesystem::path>& files() const { return files_; }
  // Photos that got a place other than their place in name order (0: name order).
  std::size_t photos_reordered_by_time() const { return photos_reordered_by_time_; }

 private:
  // Reorders the timed photos of the name-ordered files_ by capture time (header comment).
  void OrderByCaptureTime();

  FrameSourceOptions options_;
  std::vector<std::filesystem::path> files_;
  FrameSourceInfo info_;
  int64_t next_index_ = 0;
  int64_t delivered_ = 0;
  std::size_t photos_reordered_by_time_ = 0;
  int decode_reduction_ = 1;  // JPEGs are decoded at 1/decode_reduction_ of the original size
};

// True for file names with a common image extension (case-insensitive).
bool HasImageExtension(const std::filesystem::path& path);

// Natural order: runs of digits compare by value, everything else byte-wise.
bool NaturalLess(const std::string& a, const std::string& b);

}  // namespace glam
