#include "engine/submap/bundle_adjuster.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include <ceres/ceres.h>

#include "engine/core/logging.h"
#include "engine/core/options.h"
#include "engine/submap/reprojection_cost.h"

namespace glam {
namespace {

struct FocalPriorCost {
  FocalPriorCost(double prior, double weight) : prior(prior), weight(weight) {}
  template <typename T>
  bool operator()(const T* focal, T* residual) const {
    residual[0] = T(weight) * (focal[0] - T(prior)) / T(prior);
    return true;
  }
  double prior, weight;
};

struct K1PriorCost {
  K1PriorCost(double prior, double weight) : prior(prior), weight(weight) {}
  template <typename T>
  bool operator()(const T* k1, T* residual) const {
    residual[0] = T(weight) * (k1[0] - T(prior));
    return true;
  }
  double prior, weight;
};

class CancelCallback : public ceres::IterationCallback {
 public:
  explicit CancelCallback(const CancellationToken& cancel) : cancel_(cancel) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return cancel_.IsCancelled() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  CancellationToken cancel_;
};

// Ceres works on raw arrays; poses are unpacked here and written back after solving.
struct PoseBlock {
  double cam_from_submap[7];  // Eigen quaternion x, y, z, w; translation (ReprojectionCostFunction)
  double focal;
};

double RmsReprojection(const Intrinsics& intrinsics, const std::vector<Keyframe>& keyframes,
                       const std::vector<Landmark>& landmarks) {
  double sum = 0;
  std::size_t count = 0;
  for (const Landmark& lm : landmarks) {
    for (const Observation& obs : lm.observations) {
      const double e = ReprojectionError(intrinsics, keyframes[obs.keyframe], lm.point_in_submap, obs.pixel);
      sum += e * e;
      ++count;
    }
  }
  return count > 0 ? std::sqrt(sum / static_cast<double>(count)) : 0.0;
}

// Whether a keyframe at index >= first_keyframe observes the landmark.
bool SeenFrom(const Landmark& landmark, int first_keyframe) {
  return std::any_of(landmark.observations.begin(), landmark.observations.end(),
                     [first_keyframe](const Observation& obs) { return static_cast<int>(obs.keyframe) >= first_keyframe; });
}

// The number of leading keyframes held by a local adjustment (options.local_keyframes), or
// options.fixed_keyframes when the adjustment is the whole one (no window, or too few held
// keyframes would anchor the window's landmarks).
int HeldKeyframes(const std::vector<Keyframe>& keyframes, const std::vector<Landmark>& landmarks,
                  const BundleAdjustmentOptions& options) {
  const int count = static_cast<int>(keyframes.size());
  const int held = count - options.local_keyframes;
  if (options.local_keyframes <= 0 || held <= options.fixed_keyframes) return options.fixed_keyframes;
  std::vector<int> anchor_observations(static_cast<std::size_t>(held), 0);
  for (const Landmark& lm : landmarks) {
    if (!SeenFrom(lm, held)) continue;
    for (const Observation& obs : lm.observations) {
      if (static_cast<int>(obs.keyframe) < held) ++anchor_observations[obs.keyframe];
    }
  }
  const auto anchors = std::count_if(anchor_observations.begin(), anchor_observations.end(),
                                     [&](int n) { return n >= options.local_min_anchor_observations; });
  return anchors >= 2 ? held : options.fixed_keyframes;
}

}  // namespace

void BundleAdjustmentOptions::Check() const {
  CheckGreater("BundleAdjustmentOptions.max_iterations", max_iterations, 0);
  CheckGreater("BundleAdjustmentOptions.huber_pixels", huber_pixels, 0.0);
  CheckGreaterEqual("BundleAdjustmentOptions.focal_prior_weight", focal_prior_weight, 0.0);
  CheckGreaterEqual("BundleAdjustmentOptions.focal_prior_px", focal_prior_px, 0.0);
  CheckGreaterEqual("BundleAdjustmentOptions.k1_prior_weight", k1_prior_weight, 0.0);
  CheckGreaterEqual("BundleAdjustmentOptions.fixed_keyframes", fixed_keyframes, 1);
  CheckGreaterEqual("BundleAdjustmentOptions.local_keyframes", local_keyframes, 0);
  CheckGreaterEqual("BundleAdjustmentOptions.local_min_anchor_observations", local_min_anchor_observations, 1);
  CheckGreater("BundleAdjustmentOptions.num_threads", num_threads, 0);
  CheckGreaterEqual("BundleAdjustmentOptions.dense_schur_max_keyframes", dense_schur_max_keyframes, 0);
}

double ReprojectionError(const Intrinsics& intrinsics, const Keyframe& keyframe,
                         const Eigen::Vector3d& point_in_submap, const Eigen::Vector2f& pixel) {
  Eigen::Vector2d projected;
  if (!Camera(intrinsics.WithFocal(keyframe.focal)).Project(keyframe.cam_from_submap * point_in_submap, &projected)) {
    return std::numeric_limits<double>::infinity();
  }
  return (projected - pixel.cast<double>()).norm();
}

BundleAdjustmentSummary BundleAdjust(const Intrinsics& intrinsics, std::vector<Keyframe>& keyframes,
                                     std::vector<Landmark>& landmarks,
                                     const BundleAdjustmentOptions& options,
                                     const CancellationToken& cancel) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  BundleAdjustmentSummary summary;
  summary.k1 = intrinsics.k1;
  summary.initial_rms_pixels = RmsReprojection(intrinsics, keyframes, landmarks);
  if (landmarks.empty()) return summary;
  double k1 = intrinsics.k1;

  std::vector<PoseBlock> poses(keyframes.size());
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    const Eigen::Quaterniond& q = keyframes[k].cam_from_submap.rotation().quaternion();
    const Eigen::Vector3d& t = keyframes[k].cam_from_submap.translation();
    poses[k] = {{q.x(), q.y(), q.z(), q.w(), t.x(), t.y(), t.z()}, keyframes[k].focal};
  }

  // One focal for all keyframes (options.share_focal): starts at the prior's centre, or at the
  // keyframes' median when there is none. Only when focals are refined: fixed focals stay each
  // keyframe's own (the completion BA adds tracked frames at the running median).
  const bool share = options.share_focal && options.refine_focal;
  double shared_focal = options.focal_prior_px;
  if (share && shared_focal <= 0) shared_focal = MedianFocal(keyframes);

  const int held = HeldKeyframes(keyframes, landmarks, options);
  const bool local = held != options.fixed_keyframes;

  // The problem owns cost, loss and manifold objects; Ceres reference-counts the shared loss.
  ceres::Problem problem;
  auto* loss = new ceres::HuberLoss(options.huber_pixels);
  std::vector<bool> keyframe_used(keyframes.size(), false);
  for (Landmark& lm : landmarks) {
    if (local && !SeenFrom(lm, held)) continue;
    for (const Observation& obs : lm.observations) {
      auto* cost = new ReprojectionCostFunction(obs.pixel.cast<double>(), intrinsics);
      PoseBlock& pose = poses[obs.keyframe];
      problem.AddResidualBlock(cost, loss, pose.cam_from_submap, share ? &shared_focal : &pose.focal,
                               &k1, lm.point_in_submap.data());
      keyframe_used[obs.keyframe] = true;
    }
  }

  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    if (!keyframe_used[k]) continue;
    PoseBlock& pose = poses[k];
    if (static_cast<int>(k) < held) {
      problem.SetParameterBlockConstant(pose.cam_from_submap);
    } else if (k == 1 && options.fix_scale && held == 1) {
      const double* t = pose.cam_from_submap + 4;
      int largest = 0;
      for (int i = 1; i < 3; ++i) {
        if (std::abs(t[i]) > std::abs(t[largest])) largest = i;
      }
      problem.SetManifold(pose.cam_from_submap, NewPoseManifold(largest));
    } else {
      problem.SetManifold(pose.cam_from_submap, NewPoseManifold());
    }
    if (share) continue;
    // A held keyframe of a local adjustment keeps its own focal too.
    if (options.refine_focal && !(local && static_cast<int>(k) < held)) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<FocalPriorCost, 1, 1>(
              new FocalPriorCost(options.focal_prior_px > 0 ? options.focal_prior_px : keyframes[k].focal,
                                 options.focal_prior_weight)),
          nullptr, &pose.focal);
    } else {
      problem.SetParameterBlockConstant(&pose.focal);
    }
  }

  if (share && problem.HasParameterBlock(&shared_focal)) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<FocalPriorCost, 1, 1>(
                                 new FocalPriorCost(shared_focal, options.focal_prior_weight)),
                             nullptr, &shared_focal);
  }

  if (problem.HasParameterBlock(&k1)) {
    if (options.refine_k1) {
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<K1PriorCost, 1, 1>(
                                   new K1PriorCost(intrinsics.k1, options.k1_prior_weight)),
                               nullptr, &k1);
    } else {
      problem.SetParameterBlockConstant(&k1);
    }
  }

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type =
      keyframes.size() <= static_cast<std::size_t>(options.dense_schur_max_keyframes) ? ceres::DENSE_SCHUR
                                                                                     : ceres::SPARSE_SCHUR;
  // The Schur elimination order is known: landmarks first, then the cameras. Given, Ceres
  // skips the independent-set search over the problem's graph it would otherwise run on
  // every call (loop benchmark video: preprocessing 0.74 -> 0.46 s of ~5 s of adjustments;
  // the same solutions up to rounding).
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (Landmark& lm : landmarks) {
    if (problem.HasParameterBlock(lm.point_in_submap.data())) ordering->AddElementToGroup(lm.point_in_submap.data(), 0);
  }
  for (PoseBlock& pose : poses) {
    if (problem.HasParameterBlock(pose.cam_from_submap)) ordering->AddElementToGroup(pose.cam_from_submap, 1);
    if (problem.HasParameterBlock(&pose.focal)) ordering->AddElementToGroup(&pose.focal, 1);
  }
  if (problem.HasParameterBlock(&shared_focal)) ordering->AddElementToGroup(&shared_focal, 1);
  if (problem.HasParameterBlock(&k1)) ordering->AddElementToGroup(&k1, 1);
  solver_options.linear_solver_ordering = ordering;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = options.num_threads;
  solver_options.logging_type = ceres::SILENT;
  CancelCallback cancel_callback(cancel);
  solver_options.callbacks.push_back(&cancel_callback);
  ceres::Solver::Summary ceres_summary;
  const auto solve_start = std::chrono::steady_clock::now();
  ceres::Solve(solver_options, &problem, &ceres_summary);
  cancel.ThrowIfCancelled();

  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    const PoseBlock& pose = poses[k];
    const double* x = pose.cam_from_submap;
    keyframes[k].cam_from_submap =
        SE3(SO3(Eigen::Quaterniond(x[3], x[0], x[1], x[2])), Eigen::Vector3d(x[4], x[5], x[6]));
    keyframes[k].focal = share ? shared_focal : pose.focal;
  }
  Intrinsics refined = intrinsics;
  refined.SetK1(k1);
  summary.k1 = k1;
  summary.final_rms_pixels = RmsReprojection(refined, keyframes, landmarks);
  summary.iterations = static_cast<int>(ceres_summary.iterations.size());
  summary.converged = ceres_summary.termination_type == ceres::CONVERGENCE;
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  GLAM_LOG_TRACE("BA timing: build {:.4f} pre {:.4f} min {:.4f} (jac {:.4f} res {:.4f} lin {:.4f}) post {:.4f} total {:.4f}",
                 std::chrono::duration<double>(solve_start - start).count(), ceres_summary.preprocessor_time_in_seconds,
                 ceres_summary.minimizer_time_in_seconds, ceres_summary.jacobian_evaluation_time_in_seconds,
                 ceres_summary.residual_evaluation_time_in_seconds, ceres_summary.linear_solver_time_in_seconds,
                 ceres_summary.postprocessor_time_in_seconds, ceres_summary.total_time_in_seconds);
  GLAM_LOG_DEBUG("BA: {} keyframes ({} held), {} landmarks, rms {:.3f} -> {:.3f} px in {} iterations ({:.3f} s), "
                 "k1 {:.4f}",
                 keyframes.size(), held, landmarks.size(), summary.initial_rms_pixels,
                 summary.final_rms_pixels, summary.iterations, summary.seconds, k1);
  return summary;
}

}  // namespace glam
