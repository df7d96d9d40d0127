// Random multi-scale texture (a stand-in for aerial ground) for feature tests.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace glam::testing {

// 8-bit BGR image: sum of upsampled uniform noise at several scales, channels tinted
// differently so that sampled colours are not grey. amplitude scales the contrast.
inline cv::Mat RandomTexture(cv::Size size, uint64_t seed, double amplitude = 1.0) {
  cv::RNG rng(seed);
  cv::Mat acc = cv::Mat::zeros(size, CV_32F);
  double weight_sum = 0;
  for (int cell : {3, 6, 12, 24, 48}) {
    cv::Mat small(size.height / cell + 2, size.width / cell + 2, CV_32F);
    rng.fill(small, cv::RNG::UNIFORM, 0.0, 1.0);
    cv::Mat up;
    cv::resize(small, up, cv::Size(small.cols * cell, small.rows * cell), 0, 0, cv::INTER_CUBIC);
    const double w = std::sqrt(static_cast<double>(cell));
    acc += w * up(cv::Rect(0, 0, size.width, size.height));
    weight_sum += w;
  }
  acc = (acc / weight_sum - 0.5) * amplitude + 0.5;
  cv::Mat bgr;
  cv::merge(std::vector<cv::Mat>{acc * 0.7 + 0.1, acc * 0.9, acc * 0.8 + 0.15}, bgr);
  bgr.convertTo(bgr, CV_8UC3, 255.0);
  return bgr;
}

}  // namespace glam::testing
