// The COLMAP model of a run describes the input's own images, whatever size GLAM mapped at:
// a 640x360 video mapped at 320x180 (--max-image-size 320) must give a 640x360 camera, the
// calibration it was given (known answer), and 2D points that sit on the same ground in the
// full-size frames: a point's observations, cut out of two of its images as extracted from the
// video at full size, show the same texture (normalised cross-correlation), which a model at
// the processing size would not.
#include <algorithm>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "engine/core/intrinsics_io.h"
#include "engine/core/logging.h"
#include "engine/core/median.h"
#include "engine/pipeline/mapping_job.h"
#include "tests/support/colmap_text_model.h"
#include "tests/support/temp_dir.h"

namespace glam {
namespace {

namespace fs = std::filesystem;

const fs::path kClip = fs::path(GLAM_TEST_FIXTURES_DIR) / "lawnmower_small";
constexpr int kPatchRadius = 6;

// The patch around a COLMAP pixel (centre of the top-left pixel at 0.5), or empty when it
// does not fit in the image.
cv::Mat PatchAt(const cv::Mat& gray, const Eigen::Vector2d& colmap_pixel) {
  const cv::Point2f centre(static_cast<float>(colmap_pixel.x() - 0.5), static_cast<float>(colmap_pixel.y() - 0.5));
  if (centre.x < kPatchRadius + 1 || centre.y < kPatchRadius + 1 || centre.x > gray.cols - kPatchRadius - 2 ||
      centre.y > gray.rows - kPatchRadius - 2) {
    return {};
  }
  cv::Mat patch;
  cv::getRectSubPix(gray, cv::Size(2 * kPatchRadius + 1, 2 * kPatchRadius + 1), centre, patch, CV_32F);
  return patch;
}

double Ncc(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat result;
  cv::matchTemplate(a, b, result, cv::TM_CCOEFF_NORMED);
  return result.at<float>(0, 0);
}

// Median NCC between the first two observations of each point, with the 2D points scaled by
// `scale` (1: as written).
double MedianPointNcc(const testing::ColmapTextModel& model, const std::map<std::uint32_t, cv::Mat>& frames,
                      double scale) {
  std::vector<double> scores;
  for (const auto& [id, point] : model.points) {
    const auto& [first_image, first_index] = point.track[0];
    const auto& [second_image, second_index] = point.track[1];
    const cv::Mat a = PatchAt(frames.at(first_image), model.images.at(first_image).points2d[first_index] * scale);
    const cv::Mat b = PatchAt(frames.at(second_image), model.images.at(second_image).points2d[second_index] * scale);
    if (!a.empty() && !b.empty()) scores.push_back(Ncc(a, b));
  }
  EXPECT_GT(scores.size(), 100u);
  return scores.empty() ? 0.0 : UpperMedian(std::move(scores));
}

TEST(ColmapInputSize, AModelMappedAtHalfSizeDescribesTheFullSizeFrames) {
  const fs::path out = testing::FreshTempDir("colmap_input_size");
  const Intrinsics truth = ReadIntrinsicsJson(kClip / "intrinsics.json");
  ASSERT_EQ(truth.width, 640);
  MappingOptions options;
  UseCalibration(&options, truth);
  options.source.max_image_size = 320;
  const MappingReport report = RunMapping(kClip / "video.mp4", out, options);
  ASSERT_EQ(report.processing_width, 320);

  const testing::ColmapTextModel model = testing::ReadColmapTextModel(out / "colmap");
  ASSERT_EQ(model.cameras.size(), 1u);
  const testing::ColmapTextCamera& camera = model.cameras.begin()->second;
  EXPECT_EQ(camera.model, "PINHOLE");
  EXPECT_EQ(camera.width, 640);
  EXPECT_EQ(camera.height, 360);
  const std::vector<double> expected = {truth.fx, truth.fy, truth.cx + 0.5, truth.cy + 0.5};
  ASSERT_EQ(camera.params.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_NEAR(camera.params[i], expected[i], 1e-6) << i;
  ASSERT_GE(model.images.size(), 5u);

  // The model's images, extracted from the video at full size by their names' frame index.
  std::map<std::int64_t, std::uint32_t> image_of_frame;
  for (const auto& [id, image] : model.images) image_of_frame[std::stoll(image.name.substr(6, 6))] = id;
  std::map<std::uint32_t, cv::Mat> frames;
  cv::VideoCapture video((kClip / "video.mp4").string(), cv::CAP_FFMPEG);
  ASSERT_TRUE(video.isOpened());
  cv::Mat bgr;
  for (std::int64_t index = 0; video.read(bgr); ++index) {
    const auto it = image_of_frame.find(index);
    if (it == image_of_frame.end()) continue;
    ASSERT_EQ(bgr.cols, camera.width);
    cv::cvtColor(bgr, frames[it->second], cv::COLOR_BGR2GRAY);
  }
  ASSERT_EQ(frames.size(), model.images.size());

  // Measured: median 0.95 as written; 2D points at the processing size (x 0.5) -0.01.
  const double as_written = MedianPointNcc(model, frames, 1.0);
  const double at_processing_size = MedianPointNcc(model, frames, 0.5);
  GLAM_LOG_INFO("{} images, {} points: median patch correlation {:.3f} (at the processing size {:.3f})",
                model.images.size(), model.points.size(), as_written, at_processing_size);
  EXPECT_GT(as_written, 0.8);
  EXPECT_LT(at_processing_size, 0.5);
  fs::remove_all(out);
}

}  // namespace
}  // namespace glam
