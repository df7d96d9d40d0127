// SubmapBuilder: self-calibration decisions (focal length and radial distortion) taken on the
// first submap, and the rebuild of an open submap whose camera estimate moved while it was
// built. Split from submap_builder.cc: these decide *which* camera the map is built with;
// that file feeds frames through it.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <unordered_map>

#include <fmt/format.h>

#include "engine/core/logging.h"
#include "engine/submap/submap_builder.h"

namespace glam {
namespace {

// Iteration cap of each adjustment of the focal profile and the k1 test (run once per job;
// from the free optimum they converge in 8-25 iterations on the clips measured).
constexpr int kCameraTestIterations = 100;
// Each adjustment of the readout profile: it starts at the optimum of the readout tried before
// (one grid step away), and the profile only ranks readouts, so a few iterations are enough
// (the lawnmower benchmark video: 8 adjustments at 100 iterations cost ~1.5 s).
constexpr int kReadoutProfileIterations = 15;
// The profile adjusts a subset of the submap's landmarks: the readout is one number shared by
// every observation, and a few thousand residuals rank it as well as all of them do (the loop
// benchmark video, ~5000 landmarks per submap: the profile cost a sixth of the builder thread).
constexpr std::size_t kReadoutProfileMaxLandmarks = 1500;

}  // namespace

// The open submap's keyframes and (a subset of) its landmarks, each observation with the image
// motion per second of readout of its keypoint, for adjustments at other readouts.
struct ReadoutProblem {
  std::vector<Keyframe> keyframes;
  std::vector<Landmark> landmarks;                    // observations at the current readout
  std::vector<std::vector<Eigen::Vector2f>> rates;    // per landmark, per observation
};

namespace {

// `keyframe_features[k]`: the features of keyframe k's frame.
ReadoutProblem MakeReadoutProblem(const std::vector<Keyframe>& keyframes, const std::vector<Landmark>& all_landmarks,
                                  const std::vector<const CompactFeatures*>& keyframe_features,
                                  std::size_t max_landmarks) {
  // Observations are copies of their keyframe's keypoints, found by position (exact: both
  // are the same floats).
  const auto key = [](const Eigen::Vector2f& p) {
    std::uint32_t x, y;
    std::memcpy(&x, &p.x(), sizeof x);
    std::memcpy(&y, &p.y(), sizeof y);
    return (static_cast<std::uint64_t>(x) << 32) | y;
  };
  std::vector<std::unordered_map<std::uint64_t, Eigen::Vector2f>> rates(keyframes.size());
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    const CompactFeatures& features = *keyframe_features[k];
    if (features.rolling_shutter_rates.size() != features.size()) continue;
    for (std::size_t i = 0; i < features.size(); ++i) rates[k][key(features.points[i])] = features.rolling_shutter_rates[i];
  }
  ReadoutProblem problem;
  problem.keyframes = keyframes;
  // An even stride through the landmarks (triangulated in flight order, so spread over the
  // whole submap).
  const std::size_t stride = std::max<std::size_t>(1, (all_landmarks.size() + max_landmarks - 1) / max_landmarks);
  for (std::size_t l = 0; l < all_landmarks.size(); l += stride) {
    const Landmark& landmark = all_landmarks[l];
    std::vector<Eigen::Vector2f> of_landmark;
    for (const Observation& observation : landmark.observations) {
      const auto& of_keyframe = rates[observation.keyframe];
      const auto it = of_keyframe.find(key(observation.pixel));
      of_landmark.push_back(it != of_keyframe.end() ? it->second : Eigen::Vector2f::Zero());
    }
    problem.landmarks.push_back(landmark);
    problem.rates.push_back(std::move(of_landmark));
  }
  return problem;
}

}  // namespace

double SubmapBuilder::CameraChangeSinceSubmapStart() const {
  const double half_diagonal = 0.5 * std::hypot(intrinsics_.width, intrinsics_.height);
  const double corner_r2 = half_diagonal * half_diagonal / (focal_ * focal_);
  return std::max(std::abs(focal_ - open_.start_focal) / open_.start_focal,
                  std::abs(k1_ - open_.start_k1) * corner_r2);
}

bool SubmapBuilder::RebuildIfCameraMoved(std::vector<Submap>* completed) {
  // The readout comes first (the other decisions are then taken on corrected keypoints),
  // calibrated or not, whatever the rebuild count; one profile per submap (a camera rebuild of
  // the same submap is not profiled again) until decided.
  if (readout_decision_open_ && readout_profiled_submap_ != static_cast<std::int64_t>(next_submap_id_) &&
      CameraDecidingSubmap() && open_.start_focal > 0 && DecideReadout()) {
    ++stats_.submap_rebuilds;
    const RestartCarry carry{open_.rebuilds + 1, open_.bootstrap_preference, open_.bootstrap_twin_checked};
    RestartWith(std::move(open_.frames), carry, completed);
    return true;
  }
  if (open_.rebuilds >= options_.max_submap_rebuilds || open_.start_focal <= 0) return false;
  // The decisions on the camera model are taken once, on the job's first submap: one taken
  // after a submap was emitted would make the map's submaps disagree on the camera (except
  // after a fragment, CameraDecidingSubmap; a resumed run continues with the decisions of the
  // interrupted one).
  const bool first_submap = camera_decisions_open_;
  const BundleAdjustmentOptions& ba = options_.bundle_adjustment;
  if (!(ba.refine_focal || ba.refine_k1) || options_.rebuild_focal_change <= 0) return false;
  // The replay goes through the normal per-frame path, so it may complete this submap (and
  // even rebuild it again, up to the limit) before the current frame is reached.
  const auto track_again = [this, completed] {
    ++stats_.submap_rebuilds;
    // Same first frame: the bootstrap keeps the motion a twin check decided on.
    const RestartCarry carry{open_.rebuilds + 1, open_.bootstrap_preference, open_.bootstrap_twin_checked};
    RestartWith(std::move(open_.frames), carry, completed);
    return true;
  };
  // Both decisions are taken on the same keyframes, and the submap is tracked again once for
  // both: k1 held or kept, the submap is tracked again at the decided k1 and the focal that
  // goes with it (DecideK1), as its landmarks were triangulated while both were moving; the
  // focal profile is taken at the decided k1 (the initial one when held, else free), so a held
  // focal needs no further pass (the first submap was built three times before, ~2 s of the
  // builder thread on the loop benchmark video uncalibrated).
  const bool k1_decided = DecideK1().has_value();
  bool focal_held = false;
  if (first_submap && ba.refine_focal && !stats_.focal_profile_rms_increase &&
      options_.focal_profile_step > 0) {
    const double increase = FocalProfileRmsIncrease();
    stats_.focal_profile_rms_increase = increase;
    if (increase < options_.focal_profile_min_rms_increase) {
      // The open submap was adjusted with the focal free: tracked again at the held focal.
      GLAM_LOG_WARN("the images do not determine the focal length (fixing it {:.0f} % off the estimate "
                    "{:.1f} px changes the reprojection rms by {:+.3f} %; nadir view of flat ground?): "
                    "holding the initial {:.1f} px; tracking the open submap's {} frames again",
                    100.0 * options_.focal_profile_step, focal_, 100.0 * increase, intrinsics_.fx,
                    open_.frames.size());
      HoldInitialFocal();
      focal_held = true;
    }
  }
  if (k1_decided || focal_held) return track_again();
  const double change = CameraChangeSinceSubmapStart();
  if (change <= options_.rebuild_focal_change) return false;
  GLAM_LOG_INFO("camera estimate moved {:.1f} % at the image corner (focal {:.1f} -> {:.1f} px, k1 "
                "{:.4f} -> {:.4f}) since frame {}: tracking the open submap's {} frames again "
                "(rebuild {})",
                100.0 * change, open_.start_focal, focal_, open_.start_k1, k1_,
                open_.frames.front().index, open_.frames.size(), open_.rebuilds + 1);
  return track_again();
}

bool SubmapBuilder::CameraDecidingSubmap() const {
  return finishing_ || 2 * static_cast<int>(open_.keyframes.size()) >= options_.keyframes_per_submap;
}

double SubmapBuilder::AdjustedCopyRms(const Intrinsics& camera, const BundleAdjustmentOptions& ba,
                                      std::optional<double> focal, double* adjusted_focal) {
  std::vector<Keyframe> keyframes = open_.keyframes;
  std::vector<Landmark> landmarks = open_.landmarks;
  if (focal) {
    for (Keyframe& kf : keyframes) kf.focal = *focal;
  }
  const BundleAdjustmentSummary summary = BundleAdjust(camera, keyframes, landmarks, ba, cancel_);
  stats_.bundle_adjust_seconds += summary.seconds;
  if (adjusted_focal != nullptr) *adjusted_focal = MedianFocal(keyframes);
  return summary.final_rms_pixels;
}

void SubmapBuilder::HoldInitialFocal() {
  stats_.focal_held = true;
  options_.bundle_adjustment.refine_focal = false;  // also ends the profile (and focal rebuilds)
  focal_ = intrinsics_.fx;
}

double SubmapBuilder::FocalProfileRmsIncrease() {
  const double step = options_.focal_profile_step;
  BundleAdjustmentOptions ba = options_.bundle_adjustment;
  ba.refine_focal = false;
  ba.max_iterations = kCameraTestIterations;
  std::array<double, 3> rms{};
  const std::array<double, 3> scales{1.0, 1.0 - step, 1.0 + step};
  for (std::size_t i = 0; i < scales.size(); ++i) {
    rms[i] = AdjustedCopyRms(CurrentCamera().intrinsics(), ba, scales[i] * focal_);
  }
  const double increase = rms[0] > 0 ? std::min(rms[1], rms[2]) / rms[0] - 1.0
                                     : std::numeric_limits<double>::infinity();
  GLAM_LOG_INFO("focal profile of submap {} ({} keyframes): rms {:.4f} px at {:.1f} px, "
                "{:+.3f} % at {:.1f} px, {:+.3f} % at {:.1f} px",
                next_submap_id_, open_.keyframes.size(), rms[0], focal_, 100.0 * (rms[1] / rms[0] - 1.0), scales[1] * focal_,
                100.0 * (rms[2] / rms[0] - 1.0), scales[2] * focal_);
  return increase;
}

std::optional<bool> SubmapBuilder::DecideK1() {
  if (!camera_decisions_open_ || !options_.bundle_adjustment.refine_k1 || stats_.k1_profile_rms_increase ||
      options_.k1_profile_min_rms_increase <= 0) {
    return std::nullopt;
  }
  double focal_at_initial_k1 = 0;
  const double increase = K1ProfileRmsIncrease(&focal_at_initial_k1);
  stats_.k1_profile_rms_increase = increase;
  if (increase >= options_.k1_profile_min_rms_increase) {
    GLAM_LOG_INFO("radial distortion: k1 = {:.4f} fits the first submap {:.3f} % better than the initial "
                  "{:.4f}: estimating it", k1_, 100.0 * increase, intrinsics_.k1);
    return false;
  }
  GLAM_LOG_INFO("radial distortion: k1 = {:.4f} fits the first submap hardly better than the initial "
                "{:.4f} ({:+.3f} % rms): taking the lens as the initial one",
                k1_, intrinsics_.k1, 100.0 * increase);
  HoldInitialK1();
  // The focal estimated with k1 free is not the one that goes with the held k1: a k1 of a few
  // hundredths is absorbed by a focal a few per cent off (the fast robustness clip: 574.5 px
  // with k1 +0.019, 558.7 px in the copy adjusted at k1 0, truth 554.3 px). The focal profile
  // is taken around the latter (around the former it is lopsided), and the submap tracked
  // again starts there: on that clip it then no longer moves past
  // SubmapOptions::rebuild_focal_change, so it is not tracked a third time.
  if (options_.bundle_adjustment.refine_focal && focal_at_initial_k1 > 0) {
    GLAM_LOG_INFO("focal estimate at the initial k1: {:.1f} px (was {:.1f} px with k1 free)", focal_at_initial_k1,
                  focal_);
    focal_ = focal_at_initial_k1;
  }
  return true;
}

void SubmapBuilder::HoldInitialK1() {
  stats_.k1_held = true;
  options_.bundle_adjustment.refine_k1 = false;
  k1_ = intrinsics_.k1;
}

double SubmapBuilder::K1ProfileRmsIncrease(double* focal_at_initial_k1) {
  BundleAdjustmentOptions ba = options_.bundle_adjustment;
  ba.refine_k1 = false;
  ba.max_iterations = kCameraTestIterations;
  std::array<double, 2> rms{};
  const std::array<double, 2> k1s{k1_, intrinsics_.k1};
  for (std::size_t i = 0; i < k1s.size(); ++i) {
    Intrinsics camera = CurrentCamera().intrinsics();
    camera.SetK1(k1s[i]);
    // The keyframes' own focals, free when refined.
    rms[i] = AdjustedCopyRms(camera, ba, std::nullopt, i == 1 ? focal_at_initial_k1 : nullptr);
  }
  const double increase = rms[0] > 0 ? rms[1] / rms[0] - 1.0 : std::numeric_limits<double>::infinity();
  GLAM_LOG_INFO("k1 profile of submap {} ({} keyframes): rms {:.4f} px at k1 {:+.4f}, {:+.3f} % at "
                "the initial {:+.4f}",
                next_submap_id_, open_.keyframes.size(), rms[0], k1s[0], 100.0 * increase, k1s[1]);
  return increase;
}

bool SubmapBuilder::DecideReadout() {
  ++readout_profiles_;
  readout_profiled_submap_ = next_submap_id_;
  const double current_s = readout_s_;
  std::vector<std::pair<double, double>>& profile = stats_.readout_profile;
  profile.clear();
  std::vector<const CompactFeatures*> keyframe_features;
  for (std::size_t position : open_.keyframe_frame_positions) keyframe_features.push_back(&open_.frames[position].features);
  const ReadoutProblem problem =
      MakeReadoutProblem(open_.keyframes, open_.landmarks, keyframe_features, kReadoutProfileMaxLandmarks);
  // Each grid point's adjustment starts at the previous one's optimum (continuation).
  std::vector<ReadoutSolution> solutions;
  for (int i = 0; i * options_.readout_step_ms <= options_.readout_max_ms + 1e-9; ++i) {
    const double ms = i * options_.readout_step_ms;
    solutions.push_back(AdjustAtReadout(problem, 1e-3 * ms, solutions.empty() ? nullptr : &solutions.back()));
    profile.emplace_back(ms, solutions.back().rms_px);
  }
  const std::size_t grid_size = profile.size();
  std::size_t best = 0;
  for (std::size_t i = 1; i < grid_size; ++i) {
    if (profile[i].second < profile[best].second) best = i;
  }
  double best_ms = profile[best].first;
  double best_rms = profile[best].second;
  if (best > 0 && best + 1 < grid_size) {
    // Vertex of the parabola through the best and its neighbours (equal spacing), tried too.
    const double a = profile[best - 1].second, b = profile[best].second, c = profile[best + 1].second;
    const double denominator = a - 2 * b + c;
    if (denominator > 0) {
      const double vertex_ms = best_ms + 0.5 * options_.readout_step_ms * (a - c) / denominator;
      const double vertex_rms = AdjustAtReadout(problem, 1e-3 * vertex_ms, &solutions[best]).rms_px;
      profile.emplace_back(vertex_ms, vertex_rms);
      if (vertex_rms < best_rms) {
        best_ms = vertex_ms;
        best_rms = vertex_rms;
      }
    }
  }
  const double none_rms = profile.front().second;
  const double gain = none_rms > 0 ? 1.0 - best_rms / none_rms : 0.0;
  // How sharply the grid rises a step or more away from the best: a global shutter's profile
  // rises from 0 ms at once (+12 % at 10 ms on a lawnmower clip), a straight leg's is flat.
  double rise = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < grid_size; ++i) {
    if (std::abs(profile[i].first - best_ms) >= options_.readout_step_ms - 1e-9 && best_rms > 0) {
      rise = std::min(rise, profile[i].second / best_rms - 1.0);
    }
  }
  std::string tried;
  for (const auto& [ms, rms] : profile) tried += fmt::format(" {:.1f} ms {:.4f} px;", ms, rms);
  GLAM_LOG_INFO("rolling-shutter readout profile of submap {} ({} keyframes):{}", next_submap_id_,
                open_.keyframes.size(), tried);
  const bool decided = (best_ms > 0 && gain >= options_.readout_min_rms_gain) || rise >= options_.readout_min_rms_gain;
  if (!decided && readout_profiles_ < options_.readout_max_submaps) {
    // Flying straight at constant speed, a rolling shutter squashes every frame alike, which
    // the submap absorbs as a world squashed along the track (a flat profile); turns and speed
    // changes tell the readout apart. The next submap is profiled again.
    GLAM_LOG_INFO("rolling shutter: the readout profile of submap {} is flat (best {:.1f} ms, {:+.2f} % against "
                  "none, {:+.2f} % a step away); profiling the next submap",
                  next_submap_id_, best_ms, 100.0 * gain, 100.0 * rise);
    return false;
  }
  readout_decision_open_ = false;
  const double chosen_s = decided && gain >= options_.readout_min_rms_gain ? 1e-3 * best_ms : 0.0;
  stats_.readout_ms = 1e3 * chosen_s;
  stats_.readout_decided_at_submap = next_submap_id_;
  if (chosen_s > 0) {
    GLAM_LOG_INFO("rolling shutter: a readout of {:.1f} ms fits submap {} {:.1f} % better than a global "
                  "shutter; tracking its {} frames again with the keypoints corrected",
                  1e3 * chosen_s, next_submap_id_, 100.0 * gain, open_.frames.size());
  } else {
    GLAM_LOG_INFO("rolling shutter: no readout fits submap {} {:.1f} % better than a global shutter "
                  "(best {:.1f} ms, {:+.2f} %): keypoints left uncorrected",
                  next_submap_id_, 100.0 * options_.readout_min_rms_gain, best_ms, 100.0 * gain);
    if (!decided) stats_.readout_ms.reset();  // undetermined, not a global shutter
  }
  if (std::abs(chosen_s - current_s) < 1e-6) return false;
  readout_s_ = chosen_s;
  return true;
}

SubmapBuilder::ReadoutSolution SubmapBuilder::AdjustAtReadout(const ReadoutProblem& problem, double readout_s,
                                                              const ReadoutSolution* start) {
  ReadoutSolution solution;
  solution.keyframes = start != nullptr ? start->keyframes : problem.keyframes;
  solution.points.reserve(problem.landmarks.size());
  std::vector<Landmark> landmarks = problem.landmarks;
  const auto step = static_cast<float>(readout_s - readout_s_);
  for (std::size_t l = 0; l < landmarks.size(); ++l) {
    if (start != nullptr) landmarks[l].point_in_submap = start->points[l];
    for (std::size_t o = 0; o < landmarks[l].observations.size(); ++o) {
      landmarks[l].observations[o].pixel -= step * problem.rates[l][o];
    }
  }
  BundleAdjustmentOptions ba = options_.bundle_adjustment;
  ba.max_iterations = kReadoutProfileIterations;
  const BundleAdjustmentSummary summary =
      BundleAdjust(CurrentCamera().intrinsics(), solution.keyframes, landmarks, ba, cancel_);
  stats_.bundle_adjust_seconds += summary.seconds;
  for (const Landmark& landmark : landmarks) solution.points.push_back(landmark.point_in_submap);
  solution.rms_px = summary.final_rms_pixels;
  return solution;
}

}  // namespace glam
