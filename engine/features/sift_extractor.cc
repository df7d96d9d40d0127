#include "engine/features/sift_extractor.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "engine/core/error.h"
#include "engine/core/options.h"
#include "engine/features/gray_image.h"

namespace glam {

std::vector<Eigen::Vector2d> Features::points() const {
  std::vector<Eigen::Vector2d> out;
  out.reserve(keypoints.size());
  for (const auto& kp : keypoints) out.emplace_back(kp.pt.x, kp.pt.y);
  return out;
}

void SiftOptions::Check() const {
  CheckGreater("SiftOptions.max_features", max_features, 0);
  CheckInRange("SiftOptions.contrast_threshold", contrast_threshold, 1e-5, 1.0);
  CheckGreater("SiftOptions.edge_threshold", edge_threshold, 0.0);
  CheckGreater("SiftOptions.sigma", sigma, 0.0);
  CheckInRange("SiftOptions.octave_layers", octave_layers, 1, 10);
  CheckInRange("SiftOptions.grid_cols", grid_cols, 0, 1000);
  CheckInRange("SiftOptions.grid_rows", grid_rows, 0, 1000);
  if (grid_cols == 0 && grid_rows > 0) {
    throw InputError("SiftOptions.grid_rows needs grid_cols > 0 (grid_cols = 0 turns bucketing off)");
  }
  CheckInRange("SiftOptions.extraction_scale", extraction_scale, 0.05, 1.0);
  CheckInRange("SiftOptions.single_pass_extra_keypoints", single_pass_extra_keypoints, -1, 1000000);
}

void ApplyRootSift(cv::Mat* descriptors) {
  GLAM_CHECK(descriptors->type() == CV_32F);
  for (int r = 0; r < descriptors->rows; ++r) {
    float* row = descriptors->ptr<float>(r);
    double l1 = 0.0;
    for (int c = 0; c < descriptors->cols; ++c) l1 += std::abs(row[c]);
    const double inv = l1 > 0.0 ? 1.0 / l1 : 0.0;
    for (int c = 0; c < descriptors->cols; ++c) {
      row[c] = static_cast<float>(std::sqrt(std::abs(row[c]) * inv));
    }
  }
}

SiftExtractor::SiftExtractor(const SiftOptions& options) : options_(options) {
  options_.Check();
  // With bucketing, detect everything and choose per cell; otherwise cv::SIFT retains the
  // max_features strongest itself before computing descriptors.
  const bool bucketing = options_.grid_cols > 0;
  sift_ = cv::SIFT::create(bucketing ? 0 : options_.max_features, options_.octave_layers,
                           options_.contrast_threshold, options_.edge_threshold, options_.sigma);
}

std::vector<std::size_t> SiftExtractor::Bucket(const std::vector<cv::KeyPoint>& keypoints,
                                               cv::Size size) const {
  const size_t budget = static_cast<size_t>(options_.max_features);
  std::vector<std::size_t> order(keypoints.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  if (keypoints.size() <= budget) return order;
  const int cols = options_.grid_cols;
  const int rows = options_.grid_rows > 0 ? options_.grid_rows
                                          : std::max(1, cols * size.height / std::max(1, size.width));
  const size_t per_cell = (budget + static_cast<size_t>(cols * rows) - 1) / (cols * rows);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return keypoints[a].response > keypoints[b].response;
  });
  std::vector<size_t> count(static_cast<size_t>(cols * rows), 0);
  std::vector<std::size_t> kept, leftovers;
  kept.reserve(budget);
  for (const std::size_t i : order) {
    const cv::KeyPoint& kp = keypoints[i];
    const int cx = std::clamp(static_cast<int>(kp.pt.x * cols / size.width), 0, cols - 1);
    const int cy = std::clamp(static_cast<int>(kp.pt.y * rows / size.height), 0, rows - 1);
    size_t& n = count[static_cast<size_t>(cy * cols + cx)];
    if (n < per_cell && kept.size() < budget) {
      ++n;
      kept.push_back(i);
    } else {
      leftovers.push_back(i);
    }
  }
  for (size_t i = 0; i < leftovers.size() && kept.size() < budget; ++i) kept.push_back(leftovers[i]);
  return kept;
}

Features SiftExtractor::Extract(const cv::Mat& image) const {
  GLAM_CHECK(!image.empty() && image.depth() == CV_8U &&
             (image.channels() == 3 || image.channels() == 1));
  cv::Mat gray = ToGray(image);
  const double scale = options_.extraction_scale;
  if (scale < 1.0) cv::resize(gray, gray, cv::Size(), scale, scale, cv::INTER_AREA);

  Features features;
  if (options_.grid_cols > 0) {
    const bool single_pass =
        options_.single_pass_extra_keypoints >= 0 &&
        last_detected_ <= static_cast<std::size_t>(options_.max_features + options_.single_pass_extra_keypoints);
    std::vector<cv::KeyPoint> detected;
    cv::Mat described;
    if (single_pass) {
      sift_->detectAndCompute(gray, cv::noArray(), detected, described);
    } else {
      sift_->detect(gray, detected);
    }
    last_detected_ = detected.size();
    const std::vector<std::size_t> kept = Bucket(detected, gray.size());
    features.keypoints.reserve(kept.size());
    for (const std::size_t i : kept) features.keypoints.push_back(detected[i]);
    if (single_pass) {
      features.descriptors.create(static_cast<int>(kept.size()), described.cols, described.type());
      for (std::size_t r = 0; r < kept.size(); ++r) {
        described.row(static_cast<int>(kept[r])).copyTo(features.descriptors.row(static_cast<int>(r)));
      }
    } else {
      sift_->compute(gray, features.keypoints, features.descriptors);
    }
  } else {
    sift_->detectAndCompute(gray, cv::noArray(), features.keypoints, features.descriptors);
  }
  if (features.descriptors.empty()) features.descriptors.create(0, 128, CV_32F);
  if (options_.root_sift) ApplyRootSift(&features.descriptors);

  // cv::SIFT (4.6) detects on the image upsampled x2 (cv::resize, half-pixel-centre
  // convention: upsampled pixel u sits at u / 2 - 0.25) but reports u / 2, so every keypoint is
  // 0.25 px right of and below the feature in the integer-pixel-centre convention of the camera
  // model (measured: +0.250 px in x and y at every octave, by detecting on an image and on its
  // 180-degree rotation). Uncorrected, that constant offset acts as a principal-point error
  // (on the oblique focal test clip the focal estimate moved from -0.17 % to +0.01 % with it).
  for (auto& kp : features.keypoints) kp.pt -= cv::Point2f(kSiftKeypointOffset, kSiftKeypointOffset);

  if (scale < 1.0) {
    // Pixel centres at integer coordinates: x_full = (x_small + 0.5) / s - 0.5.
    const float inv = static_cast<float>(1.0 / scale);
    for (auto& kp : features.keypoints) {
      kp.pt = (kp.pt + cv::Point2f(0.5f, 0.5f)) * inv - cv::Point2f(0.5f, 0.5f);
      kp.size *= inv;
    }
  }

  // class_id = index in this detection frame: KLT keeps it, so the frames propagated from
  // here name their keypoints by it (rolling-shutter correction finds a point's track by it).
  for (std::size_t i = 0; i < features.keypoints.size(); ++i) features.keypoints[i].class_id = static_cast<int>(i);

  features.colors.reserve(features.keypoints.size());
  for (const auto& kp : features.keypoints) {
    const int x = std::clamp(static_cast<int>(std::lround(kp.pt.x)), 0, image.cols - 1);
    const int y = std::clamp(static_cast<int>(std::lround(kp.pt.y)), 0, image.rows - 1);
    if (image.channels() == 3) {
      const cv::Vec3b& bgr = image.at<cv::Vec3b>(y, x);
      features.colors.push_back({bgr[2], bgr[1], bgr[0]});
    } else {
      const uint8_t g = image.at<uint8_t>(y, x);
      features.colors.push_back({g, g, g});
    }
  }
  return features;
}

}  // namespace glam
