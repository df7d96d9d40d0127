// Point features of one image: what the tracker matches, what landmarks inherit (descriptor,
// colour), what the vocabulary tree indexes. Keypoint coordinates are in processing pixels
// (OpenCV convention: pixel centres at integer coordinates).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace glam {

using Rgb = std::array<uint8_t, 3>;

struct Features {
  std::vector<cv::KeyPoint> keypoints;
  // N x 128, CV_32F, one row per keypoint (RootSIFT-normalised when the extractor was asked
  // to: then every row has unit L2 norm).
  cv::Mat descriptors;
  std::vector<Rgb> colors;  // RGB sampled at each keypoint (for landmark colour)
  // True when SIFT ran on this image; false when the keypoints were carried here from the last
  // detection frame by optical flow (KltPropagator: positions new, descriptors and colours
  // inherited, no features of newly visible ground). Keyframes prefer detected frames.
  bool detected = true;
  // Rolling shutter (engine/pipeline/rolling_shutter.h), when the readout is being estimated:
  // per keypoint, how far it moves per second of readout time, (y / (H - 1) - 0.5) times its
  // image velocity (pixels per second); the keypoint at readout T is keypoints[i].pt - T *
  // rolling_shutter_rates[i]. Empty otherwise.
  std::vector<cv::Point2f> rolling_shutter_rates;

  size_t size() const { return keypoints.size(); }
  bool empty() const { return keypoints.empty(); }
  Eigen::Vector2d point(size_t i) const {
    return {keypoints[i].pt.x, keypoints[i].pt.y};
  }
  std::vector<Eigen::Vector2d> points() const;
};

}  // namespace glam
