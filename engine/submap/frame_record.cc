#include "engine/submap/frame_record.h"

#include <algorithm>
#include <cmath>

namespace glam {

Descriptor QuantizeDescriptor(const float* row) {
  // min(255, max(0, lround(512 v))) without a libm call per value (lroundf was ~1.6 % of a
  // run's CPU: every frame's 2000 x 128 values). After clamping to [0, 255], x - trunc(x) is
  // exact, so rounding half away from zero is the comparison below: bit for bit lround's result.
  Descriptor d;
  for (int i = 0; i < kDescriptorSize; ++i) {
    float x = 512.0f * row[i];
    x = x > 0.0f ? x : 0.0f;  // also NaN
    x = x < 255.0f ? x : 255.0f;
    const int whole = static_cast<int>(x);
    d[i] = static_cast<std::uint8_t>(whole + (x - static_cast<float>(whole) >= 0.5f ? 1 : 0));
  }
  return d;
}

void DequantizeDescriptor(const Descriptor& d, float* row) {
  for (int i = 0; i < kDescriptorSize; ++i) row[i] = static_cast<float>(d[i]) / 512.0f;
}

cv::Mat LandmarkDescriptorMatrix(const std::vector<Landmark>& landmarks) {
  cv::Mat out(static_cast<int>(landmarks.size()), kDescriptorSize, CV_32F);
  for (int r = 0; r < out.rows; ++r) DequantizeDescriptor(landmarks[r].descriptor, out.ptr<float>(r));
  return out;
}

cv::Mat LandmarkDescriptorMatrix(const std::vector<Landmark>& landmarks, const std::vector<int>& rows) {
  cv::Mat out(static_cast<int>(rows.size()), kDescriptorSize, CV_32F);
  for (int r = 0; r < out.rows; ++r) DequantizeDescriptor(landmarks[rows[r]].descriptor, out.ptr<float>(r));
  return out;
}

std::vector<Eigen::Vector2d> CompactFeatures::PixelPoints() const {
  std::vector<Eigen::Vector2d> out(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = points[i].cast<double>();
  return out;
}

CompactFeatures CompactFeatures::From(const Features& features) {
  CompactFeatures c;
  c.points.reserve(features.size());
  c.descriptors.reserve(features.size());
  for (std::size_t i = 0; i < features.size(); ++i) {
    c.points.emplace_back(features.keypoints[i].pt.x, features.keypoints[i].pt.y);
    c.descriptors.push_back(QuantizeDescriptor(features.descriptors.ptr<float>(static_cast<int>(i))));
  }
  c.colors = features.colors;
  c.rolling_shutter_rates.reserve(features.rolling_shutter_rates.size());
  for (const cv::Point2f& r : features.rolling_shutter_rates) c.rolling_shutter_rates.emplace_back(r.x, r.y);
  return c;
}

void CompactFeatures::ApplyReadout(double readout_s) {
  if (rolling_shutter_rates.size() != points.size() || readout_s == readout_applied_s) return;
  const auto step = static_cast<float>(readout_s - readout_applied_s);
  for (std::size_t i = 0; i < points.size(); ++i) points[i] -= step * rolling_shutter_rates[i];
  readout_applied_s = readout_s;
}


cv::Mat CompactFeatures::FloatDescriptors() const {
  cv::Mat out(static_cast<int>(descriptors.size()), kDescriptorSize, CV_32F);
  for (int i = 0; i < out.rows; ++i) DequantizeDescriptor(descriptors[i], out.ptr<float>(i));
  return out;
}

cv::Mat CompactFeatures::FloatDescriptors(const std::vector<int>& rows) const {
  cv::Mat out(static_cast<int>(rows.size()), kDescriptorSize, CV_32F);
  for (int i = 0; i < out.rows; ++i) DequantizeDescriptor(descriptors[rows[i]], out.ptr<float>(i));
  return out;
}

double MapCoverage(const std::vector<Eigen::Vector2f>& keypoints, const std::vector<Eigen::Vector2d>& mapped,
                   int width, int height, int columns, int min_features) {
  const int rows = std::max(1, static_cast<int>(std::lround(columns * static_cast<double>(height) / width)));
  const auto cell_of = [&](double x, double y) {
    const int c = std::clamp(static_cast<int>(x * columns / width), 0, columns - 1);
    const int r = std::clamp(static_cast<int>(y * rows / height), 0, rows - 1);
    return r * columns + c;
  };
  std::vector<int> features(static_cast<std::size_t>(rows * columns), 0);
  std::vector<bool> covered(features.size(), false);
  for (const Eigen::Vector2f& p : keypoints) ++features[cell_of(p.x(), p.y())];
  for (const Eigen::Vector2d& p : mapped) covered[cell_of(p.x(), p.y())] = true;
  int textured = 0, explained = 0;
  for (std::size_t i = 0; i < features.size(); ++i) {
    if (features[i] < min_features) continue;
    ++textured;
    if (covered[i]) ++explained;
  }
  return textured > 0 ? static_cast<double>(explained) / textured : 1.0;
}

FramePose FrameRecord::ToFramePose() const {
  FramePose pose;
  pose.frame_index = index;
  pose.timestamp_s = timestamp_s;
  pose.cam_from_submap = cam_from_submap.value();
  pose.pnp_inliers = static_cast<std::uint32_t>(landmark_matches.size());
  return pose;
}

}  // namespace glam
