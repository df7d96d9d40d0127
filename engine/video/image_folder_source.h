// A folder of photos or extracted frames, in natural name order (frame_2 before frame_10), at
// fps = 1 so that timestamp = index. Files that are not images (by extension) are ignored;
// images that fail to decode or whose size differs from the first image are skipped with a
// warning (their index stays reserved, so indices always match the sorted file list). The
// first image that decodes sets the size.
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

 private:
  FrameSourceOptions options_;
  std::vector<std::filesystem::path> files_;
  FrameSourceInfo info_;
  int64_t next_index_ = 0;
  int64_t delivered_ = 0;
};

// True for file names with a common image extension (case-insensitive).
bool HasImageExtension(const std::filesystem::path& path);

// Natural order: runs of digits compare by value, everything else byte-wise.
bool NaturalLess(const std::string& a, const std::string& b);

}  // namespace glam
