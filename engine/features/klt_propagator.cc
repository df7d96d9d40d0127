#include "engine/features/klt_propagator.h"

#include <cmath>
#include <cstring>
#include <utility>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "engine/core/error.h"
#include "engine/core/median.h"
#include "engine/core/options.h"

namespace glam {

void KltOptions::Check() const {
  CheckInRange("KltOptions.window_px", window_px, 5, 61);
  if (window_px % 2 == 0) throw InputError("KltOptions.window_px must be odd");
  CheckInRange("KltOptions.pyramid_levels", pyramid_levels, 0, 6);
  CheckInRange("KltOptions.max_iterations", max_iterations, 1, 200);
  CheckGreater("KltOptions.epsilon_px", epsilon_px, 0.0);
  CheckGreater("KltOptions.max_patch_error", max_patch_error, 0.0);
  CheckGreaterEqual("KltOptions.min_eigen_value", min_eigen_value, 0.0);
  CheckGreaterEqual("KltOptions.border_px", border_px, 0.0);
  CheckGreaterEqual("KltOptions.max_forward_backward_px", max_forward_backward_px, 0.0);
  CheckInRange("KltOptions.min_patch_correlation", min_patch_correlation, -1.0, 1.0);
  CheckInRange("KltOptions.min_survival_fraction", min_survival_fraction, 0.0, 1.0);
}

namespace {

// Normalised cross-correlation of the `window` patches around a (in image_a) and b (in
// image_b), sampled bilinearly; -1 when either patch is flat.
double PatchCorrelation(const cv::Mat& image_a, cv::Point2f a, const cv::Mat& image_b, cv::Point2f b,
                        cv::Size window) {
  cv::Mat pa, pb;
  cv::getRectSubPix(image_a, window, a, pa, CV_32F);
  cv::getRectSubPix(image_b, window, b, pb, CV_32F);
  const double n = static_cast<double>(window.area());
  const double mean_a = cv::sum(pa)[0] / n, mean_b = cv::sum(pb)[0] / n;
  double ab = 0, aa = 0, bb = 0;
  for (int r = 0; r < window.height; ++r) {
    const float* ra = pa.ptr<float>(r);
    const float* rb = pb.ptr<float>(r);
    for (int c = 0; c < window.width; ++c) {
      const double da = ra[c] - mean_a, db = rb[c] - mean_b;
      ab += da * db;
      aa += da * da;
      bb += db * db;
    }
  }
  if (aa <= 1e-6 * n || bb <= 1e-6 * n) return -1;
  return ab / std::sqrt(aa * bb);
}

}  // namespace

KltPropagator::KltPropagator(const KltOptions& options)
    : options_(options), window_(options.window_px, options.window_px) {
  options_.Check();
}

void KltPropagator::SetReference(const cv::Mat& gray, const Features& features) {
  GLAM_CHECK(!gray.empty() && gray.type() == CV_8UC1, "KLT reference must be 8-bit grey");
  GLAM_CHECK(features.descriptors.rows == static_cast<int>(features.size()) &&
             features.colors.size() == features.size());
  GLAM_CHECK(features.empty() || features.descriptors.type() == CV_32F, "KLT reference descriptors must be CV_32F");
  reference_pyramid_.clear();
  cv::buildOpticalFlowPyramid(gray, reference_pyramid_, window_, options_.pyramid_levels, true);
  reference_ = features;
  reference_.descriptors = features.descriptors.clone();
  alive_.resize(features.size());
  last_position_.resize(features.size());
  for (std::size_t i = 0; i < features.size(); ++i) {
    alive_[i] = static_cast<int>(i);
    last_position_[i] = features.keypoints[i].pt;
  }
  frames_since_reference_ = 0;
}

double KltPropagator::median_displacement_px() const {
  std::vector<double> moved(alive_.size());
  for (std::size_t i = 0; i < alive_.size(); ++i) {
    const cv::Point2f d = last_position_[i] - reference_.keypoints[alive_[i]].pt;
    moved[i] = std::hypot(d.x, d.y);
  }
  return UpperMedian(std::move(moved));
}

Features KltPropagator::Propagate(const cv::Mat& gray) {
  GLAM_CHECK(has_reference(), "Propagate before SetReference");
  GLAM_CHECK(!gray.empty() && gray.type() == CV_8UC1 && gray.size() == reference_pyramid_[0].size(),
             "KLT frame must be 8-bit grey of the reference's size");
  Features out;
  out.detected = false;
  out.descriptors.create(0, 128, CV_32F);
  ++frames_since_reference_;
  if (alive_.empty()) return out;

  std::vector<cv::Mat> pyramid;
  cv::buildOpticalFlowPyramid(gray, pyramid, window_, options_.pyramid_levels, true);
  std::vector<cv::Point2f> from(alive_.size());
  for (std::size_t i = 0; i < alive_.size(); ++i) from[i] = reference_.keypoints[alive_[i]].pt;
  std::vector<cv::Point2f> to = last_position_;
  std::vector<unsigned char> status;
  std::vector<float> error;
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                  options_.max_iterations, options_.epsilon_px);
  cv::calcOpticalFlowPyrLK(reference_pyramid_, pyramid, from, to, status, error, window_,
                           options_.pyramid_levels, criteria, cv::OPTFLOW_USE_INITIAL_FLOW,
                           options_.min_eigen_value);

  std::vector<unsigned char> passes(alive_.size(), 1);  // the wrong-track tests
  if (options_.max_forward_backward_px > 0) {
    std::vector<cv::Point2f> back = from;
    std::vector<unsigned char> back_status;
    std::vector<float> back_error;
    cv::calcOpticalFlowPyrLK(pyramid, reference_pyramid_, to, back, back_status, back_error, window_,
                             options_.pyramid_levels, criteria, cv::OPTFLOW_USE_INITIAL_FLOW,
                             options_.min_eigen_value);
    for (std::size_t i = 0; i < alive_.size(); ++i) {
      const cv::Point2f d = back[i] - from[i];
      passes[i] = back_status[i] && std::hypot(d.x, d.y) <= options_.max_forward_backward_px;
    }
  }

  if (options_.min_patch_correlation > -1) {
    for (std::size_t i = 0; i < alive_.size(); ++i) {
      if (!status[i] || !passes[i] || !std::isfinite(to[i].x) || !std::isfinite(to[i].y)) continue;
      passes[i] = PatchCorrelation(reference_pyramid_[0], from[i], gray, to[i], window_) >= options_.min_patch_correlation;
    }
  }

  const float border = static_cast<float>(options_.border_px);
  const float max_x = static_cast<float>(gray.cols - 1) - border;
  const float max_y = static_cast<float>(gray.rows - 1) - border;
  std::vector<int> survivors;
  std::vector<cv::Point2f> survivor_positions;
  for (std::size_t i = 0; i < alive_.size(); ++i) {
    const cv::Point2f& p = to[i];
    if (!status[i] || !passes[i] || !(error[i] <= options_.max_patch_error) || !std::isfinite(p.x) ||
        !std::isfinite(p.y) || p.x < border || p.y < border || p.x > max_x || p.y > max_y) {
      continue;
    }
    survivors.push_back(alive_[i]);
    survivor_positions.push_back(p);
  }
  alive_ = survivors;
  last_position_ = survivor_positions;

  out.keypoints.reserve(alive_.size());
  out.colors.reserve(alive_.size());
  out.descriptors.create(static_cast<int>(alive_.size()), reference_.descriptors.cols, CV_32F);
  // Rows copied as bytes: a cv::Mat row header per copy cost more than the copy itself.
  const std::size_t row_bytes = reference_.descriptors.elemSize() * static_cast<std::size_t>(reference_.descriptors.cols);
  for (std::size_t i = 0; i < alive_.size(); ++i) {
    cv::KeyPoint kp = reference_.keypoints[alive_[i]];
    kp.pt = last_position_[i];
    out.keypoints.push_back(kp);
    out.colors.push_back(reference_.colors[alive_[i]]);
    std::memcpy(out.descriptors.ptr(static_cast<int>(i)), reference_.descriptors.ptr(alive_[i]), row_bytes);
  }
  return out;
}

}  // namespace glam
