#include "engine/video/image_folder_source.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <string_view>
#include <utility>

#include <opencv2/imgcodecs.hpp>

#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/video/photo_capture_time.h"

namespace glam {
namespace {

cv::Mat ReadImage(const std::filesystem::path& path) {
  return cv::imread(path.string(), cv::IMREAD_COLOR);
}

// JPEG by content (SOI marker), whatever the file is called.
bool IsJpeg(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char magic[3] = {0, 0, 0};
  in.read(reinterpret_cast<char*>(magic), 3);
  return in.gcount() == 3 && magic[0] == 0xFF && magic[1] == 0xD8 && magic[2] == 0xFF;
}

int ReducedSide(int side, int reduction) { return (side + reduction - 1) / reduction; }

// Largest of 8, 4, 2 by which a JPEG of `original` size can be decoded and still cover
// `processing`, else 1. libjpeg then scales in the DCT while decoding: a 20-megapixel photo
// (5472x3648) takes ~50 ms to 1280 px instead of ~250 ms decoded in full and resized.
int DecodeReduction(cv::Size original, cv::Size processing) {
  for (int reduction = 8; reduction > 1; reduction /= 2) {
    if (ReducedSide(original.width, reduction) >= processing.width &&
        ReducedSide(original.height, reduction) >= processing.height) {
      return reduction;
    }
  }
  return 1;
}

// Decodes at 1/reduction of the full size (JPEG only: OpenCV reduces other formats by
// INTER_LINEAR_EXACT after a full decode, which aliases; those are decoded in full).
cv::Mat ReadImageReduced(const std::filesystem::path& path, int reduction) {
  if (reduction == 1 || !IsJpeg(path)) return ReadImage(path);
  const int flag = reduction == 8   ? cv::IMREAD_REDUCED_COLOR_8
                   : reduction == 4 ? cv::IMREAD_REDUCED_COLOR_4
                                    : cv::IMREAD_REDUCED_COLOR_2;
  return cv::imread(path.string(), flag);
}

// Whether `decoded` (at 1/reduction of the full size, or in full) is an image of `original`
// size (a reduced side is within one pixel of side / reduction, rounded up).
bool HasOriginalSize(const cv::Mat& decoded, cv::Size original, int reduction) {
  if (decoded.size() == original) return true;
  if (reduction == 1) return false;
  return std::abs(decoded.cols - ReducedSide(original.width, reduction)) <= 1 &&
         std::abs(decoded.rows - ReducedSide(original.height, reduction)) <= 1;
}

}  // namespace

bool HasImageExtension(const std::filesystem::path& path) {
  static constexpr std::array<std::string_view, 10> kExtensions = {
      ".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff", ".webp", ".ppm", ".pgm", ".jp2"};
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return std::find(kExtensions.begin(), kExtensions.end(), ext) != kExtensions.end();
}

bool NaturalLess(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])) != 0;
    const bool db = std::isdigit(static_cast<unsigned char>(b[j])) != 0;
    if (da && db) {
      size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      // Compare numerically without overflow: strip leading zeros, then length, then digits.
      size_t ia = i, jb = j;
      while (ia + 1 < ie && a[ia] == '0') ++ia;
      while (jb + 1 < je && b[jb] == '0') ++jb;
      const std::string_view na(a.data() + ia, ie - ia), nb(b.data() + jb, je - jb);
      if (na.size() != nb.size()) return na.size() < nb.size();
      if (na != nb) return na < nb;
      if (ie - i != je - j) return ie - i < je - j;  // fewer leading zeros first
      i = ie;
      j = je;
    } else {
      if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

ImageFolderSource::ImageFolderSource(const std::filesystem::path& folder,
                                     const FrameSourceOptions& options)
    : options_(options) {
  options_.Check();
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec)) {
    throw InputError(fmt::format("image folder '{}' does not exist", folder.string()));
  }
  size_t ignored = 0;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    if (entry.is_regular_file(ec) && HasImageExtension(entry.path())) {
      files_.push_back(entry.path());
    } else {
      ++ignored;
    }
  }
  if (ec) {
    throw InputError(fmt::format("cannot list image folder '{}': {}", folder.string(), ec.message()));
  }
  if (files_.empty()) {
    throw InputError(fmt::format("image folder '{}' contains no image files", folder.string()));
  }
  if (ignored > 0) {
    GLAM_LOG_INFO("image folder '{}': ignoring {} entries that are not images", folder.string(),
                  ignored);
  }
  std::sort(files_.begin(), files_.end(), [](const auto& a, const auto& b) {
    return NaturalLess(a.filename().string(), b.filename().string());
  });
  if (options_.photos_by_capture_time) OrderByCaptureTime();

  // The first *decodable* image sets the size: junk with an image name that sorts first (macOS
  // "._0001.jpg" resource forks on SD cards) must not reject the whole folder. Next() skips
  // the undecodable ones again, with a warning each.
  cv::Mat first;
  for (std::size_t i = 0; i < files_.size() && first.empty(); ++i) first = ReadImage(files_[i]);
  if (first.empty()) {
    throw InputError(fmt::format("image folder '{}': none of its {} image files can be decoded",
                                 folder.string(), files_.size()));
  }
  info_.fps = 1.0;
  info_.frame_count = static_cast<int64_t>(files_.size());
  info_.original_size = first.size();
  info_.processing_size = ProcessingSize(info_.original_size, options_.max_image_size);
  info_.scale = static_cast<double>(info_.processing_size.width) / info_.original_size.width;
  decode_reduction_ = DecodeReduction(info_.original_size, info_.processing_size);
}

void ImageFolderSource::OrderByCaptureTime() {
  std::vector<std::size_t> slots;  // places of the timed photos in name order
  std::vector<std::pair<std::int64_t, std::filesystem::path>> timed;
  for (std::size_t i = 0; i < files_.size(); ++i) {
    if (const std::optional<std::int64_t> ms = ReadPhotoCaptureTimeMs(files_[i])) {
      slots.push_back(i);
      timed.emplace_back(*ms, files_[i]);
    }
  }
  std::stable_sort(timed.begin(), timed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (std::size_t k = 0; k < slots.size(); ++k) {
    if (files_[slots[k]] != timed[k].second) ++photos_reordered_by_time_;
    files_[slots[k]] = timed[k].second;
  }
  if (photos_reordered_by_time_ > 0) {
    GLAM_LOG_INFO("image folder: {} of {} photos are out of name order by their EXIF capture time; mapping them in "
                  "capture order",
                  photos_reordered_by_time_, files_.size());
  }
}

std::optional<Frame> ImageFolderSource::Next() {
  while (next_index_ < static_cast<int64_t>(files_.size())) {
    const int64_t index = next_index_;
    next_index_ += options_.stride;
    const auto& file = files_[static_cast<size_t>(index)];
    cv::Mat image = ReadImageReduced(file, decode_reduction_);
    if (image.empty()) {
      GLAM_LOG_WARN("skipping image '{}': cannot decode it", file.string());
      continue;
    }
    if (!HasOriginalSize(image, info_.original_size, decode_reduction_)) {
      const cv::Mat full = ReadImage(file);  // for the message: its real size
      GLAM_LOG_WARN("skipping image '{}': size {}x{} differs from the first image's {}x{}",
                    file.string(), full.cols, full.rows, info_.original_size.width,
                    info_.original_size.height);
      continue;
    }
    Frame frame;
    frame.index = index;
    frame.timestamp_s = static_cast<double>(index);
    frame.original_size = info_.original_size;
    frame.bgr = ToProcessingSize(image, info_.processing_size);
    ++delivered_;
    return frame;
  }
  return std::nullopt;
}

void ImageFolderSource::SeekTo(int64_t index) {
  if (index < 0 || index > static_cast<int64_t>(files_.size())) {  // == size: at the end
    throw InputError(
        fmt::format("cannot seek to image {} of a folder with {} images", index, files_.size()));
  }
  next_index_ = index;
}

}  // namespace glam
