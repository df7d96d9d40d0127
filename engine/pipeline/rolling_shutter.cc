#include "engine/pipeline/rolling_shutter.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include <fmt/format.h>

#include "engine/core/error.h"
#include "engine/core/options.h"

namespace glam {

void RollingShutterOptions::Check() const {
  CheckInRange("RollingShutterOptions.readout_ms", readout_ms, 0.0, 100.0);
  CheckGreater("RollingShutterOptions.max_frame_gap_s", max_frame_gap_s, 0.0);
  CheckInRange("RollingShutterOptions.min_model_points", min_model_points, 6, 100000);
  if (estimate && readout_ms > 0) {
    throw InputError("RollingShutterOptions: give a readout time or ask for its estimate, not both");
  }
}

RollingShutterOptions EstimatedRollingShutter() {
  RollingShutterOptions options;
  options.estimate = true;
  return options;
}

RollingShutterOptions RollingShutterFromText(const std::string& text) {
  RollingShutterOptions options;
  if (text == "auto") {
    options.estimate = true;
    return options;
  }
  std::size_t used = 0;
  try {
    options.readout_ms = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size()) {
    throw InputError(fmt::format("rolling-shutter readout must be a number of milliseconds or \"auto\", got \"{}\"", text));
  }
  options.Check();
  return options;
}

std::array<double, 6> FlowModel::Basis(cv::Point2f p) const {
  const double u = (p.x - centre_.x) / scale_;
  const double w = (p.y - centre_.y) / scale_;
  return {1.0, u, w, u * u, u * w, w * w};
}

bool FlowModel::Fit(const std::vector<cv::Point2f>& points, const std::vector<cv::Point2f>& velocities,
                    cv::Size image_size, int min_points) {
  valid_ = false;
  if (static_cast<int>(points.size()) < min_points) return false;
  centre_ = cv::Point2f(0.5f * static_cast<float>(image_size.width - 1), 0.5f * static_cast<float>(image_size.height - 1));
  scale_ = 0.5 * std::max(image_size.width, image_size.height);
  std::vector<char> use(points.size(), 1);
  for (int round = 0; round < 2; ++round) {
    Eigen::Matrix<double, 6, 6> ata = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 2> atb = Eigen::Matrix<double, 6, 2>::Zero();
    int used = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (!use[i]) continue;
      const std::array<double, 6> b = Basis(points[i]);
      const Eigen::Map<const Eigen::Matrix<double, 6, 1>> row(b.data());
      ata += row * row.transpose();
      atb.col(0) += row * velocities[i].x;
      atb.col(1) += row * velocities[i].y;
      ++used;
    }
    if (used < min_points) return valid_;  // keeps the first round's fit if there was one
    const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> solver(ata);
    if (solver.info() != Eigen::Success) return valid_;
    const Eigen::Matrix<double, 6, 2> coefficients = solver.solve(atb);
    if (!coefficients.allFinite()) return valid_;
    for (int k = 0; k < 6; ++k) {
      vx_[k] = coefficients(k, 0);
      vy_[k] = coefficients(k, 1);
    }
    valid_ = true;
    std::vector<double> residuals;
    residuals.reserve(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      const cv::Point2f d = velocities[i] - At(points[i]);
      residuals.push_back(std::hypot(d.x, d.y));
    }
    std::vector<double> sorted = residuals;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
    // Relief and KLT noise leave a spread; 1 px/s keeps a perfect fit from rejecting noise.
    outlier_threshold_ = 3.0 * sorted[sorted.size() / 2] + 1.0;
    for (std::size_t i = 0; i < points.size(); ++i) use[i] = residuals[i] <= outlier_threshold_;
  }
  return valid_;
}

cv::Point2f FlowModel::At(cv::Point2f p) const {
  const std::array<double, 6> b = Basis(p);
  double x = 0, y = 0;
  for (int k = 0; k < 6; ++k) {
    x += vx_[k] * b[k];
    y += vy_[k] * b[k];
  }
  return {static_cast<float>(x), static_cast<float>(y)};
}

RollingShutterCorrector::RollingShutterCorrector(const RollingShutterOptions& options, cv::Size image_size)
    : options_(options), image_size_(image_size) {
  options_.Check();
}

RollingShutterCorrector::Track RollingShutterCorrector::TrackOf(const FrameFeatures& frame) {
  Track track;
  track.timestamp_s = frame.timestamp_s;
  track.detected = frame.features.detected;
  int max_id = -1;
  for (const cv::KeyPoint& kp : frame.features.keypoints) max_id = std::max(max_id, kp.class_id);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  track.by_id.assign(static_cast<std::size_t>(max_id + 1), cv::Point2f(nan, nan));
  for (const cv::KeyPoint& kp : frame.features.keypoints) {
    if (kp.class_id >= 0) track.by_id[static_cast<std::size_t>(kp.class_id)] = kp.pt;
  }
  return track;
}

std::optional<FrameFeatures> RollingShutterCorrector::Push(FrameFeatures next) {
  Track next_track = TrackOf(next);  // raw positions, before next is corrected in turn
  std::optional<FrameFeatures> out;
  if (pending_) {
    Correct(*pending_, &next_track);
    out = std::move(pending_);
    previous_ = std::move(pending_track_);
  }
  pending_ = std::move(next);
  pending_track_ = std::move(next_track);
  return out;
}

std::optional<FrameFeatures> RollingShutterCorrector::Flush() {
  if (!pending_) return std::nullopt;
  Correct(*pending_, nullptr);
  std::optional<FrameFeatures> out = std::move(pending_);
  pending_.reset();
  pending_track_.reset();
  previous_.reset();
  return out;
}

void RollingShutterCorrector::Correct(FrameFeatures& frame, const Track* next) {
  std::vector<cv::KeyPoint>& keypoints = frame.features.keypoints;
  if (keypoints.empty()) return;
  // Neighbours on the same KLT track: the previous frame unless this one was detected (a new
  // reference), the next one unless it was detected.
  auto usable_gap = [&](double gap) { return gap > 0 && gap <= options_.max_frame_gap_s; };
  const Track* before =
      previous_ && !frame.features.detected && usable_gap(frame.timestamp_s - previous_->timestamp_s)
          ? &*previous_
          : nullptr;
  const Track* after = next && !next->detected && usable_gap(next->timestamp_s - frame.timestamp_s) ? next : nullptr;
  auto position_in = [](const Track* track, int id, cv::Point2f* p) {
    if (!track || id < 0 || static_cast<std::size_t>(id) >= track->by_id.size()) return false;
    *p = track->by_id[static_cast<std::size_t>(id)];
    return std::isfinite(p->x);
  };

  std::vector<cv::Point2f> velocity(keypoints.size());
  std::vector<char> measured(keypoints.size(), 0);
  std::vector<cv::Point2f> fit_points, fit_velocities;
  for (std::size_t i = 0; i < keypoints.size(); ++i) {
    const cv::Point2f p = keypoints[i].pt;
    cv::Point2f sum(0, 0), q;
    int n = 0;
    if (position_in(before, keypoints[i].class_id, &q)) {
      sum += (p - q) * static_cast<float>(1.0 / (frame.timestamp_s - before->timestamp_s));
      ++n;
    }
    if (position_in(after, keypoints[i].class_id, &q)) {
      sum += (q - p) * static_cast<float>(1.0 / (after->timestamp_s - frame.timestamp_s));
      ++n;
    }
    if (n == 0) continue;
    velocity[i] = sum * (1.0f / static_cast<float>(n));
    measured[i] = 1;
    fit_points.push_back(p);
    fit_velocities.push_back(velocity[i]);
  }
  FlowModel model;
  if (model.Fit(fit_points, fit_velocities, image_size_, options_.min_model_points)) {
    last_model_ = model;
  } else {
    model = last_model_;  // constant flow over a frame or two (or none: nothing to correct)
  }

  const double readout_s = 1e-3 * options_.readout_ms;
  const double rows = std::max(1, image_size_.height - 1);
  if (options_.estimate) frame.features.rolling_shutter_rates.assign(keypoints.size(), cv::Point2f(0, 0));
  for (std::size_t i = 0; i < keypoints.size(); ++i) {
    cv::Point2f v;
    if (measured[i]) {
      v = velocity[i];
      // A measured velocity far from the frame's flow is a wrong track or a mismatch: the
      // model is the better guess there.
      if (model.valid()) {
        const cv::Point2f m = model.At(keypoints[i].pt);
        if (std::hypot(v.x - m.x, v.y - m.y) > model.outlier_threshold()) v = m;
      }
    } else if (model.valid()) {
      v = model.At(keypoints[i].pt);
    } else {
      continue;
    }
    const double row_time = keypoints[i].pt.y / rows - 0.5;  // in readouts from the middle row
    if (options_.estimate) {
      frame.features.rolling_shutter_rates[i] = v * static_cast<float>(row_time);
      continue;
    }
    const cv::Point2f shift = v * static_cast<float>(-readout_s * row_time);
    keypoints[i].pt += shift;
    const double length = std::hypot(shift.x, shift.y);
    shift_sum_ += length;
    shift_max_ = std::max(shift_max_, length);
    ++corrected_;
  }
}

}  // namespace glam
