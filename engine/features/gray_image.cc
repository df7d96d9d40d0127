#include "engine/features/gray_image.h"

#include <opencv2/imgproc.hpp>

namespace glam {

cv::Mat ToGray(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat gray;
  cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  return gray;
}

}  // namespace glam
