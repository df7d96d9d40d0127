// Bootstrapping a submap (paper, "Bootstrapping"): the first frame is the first keyframe with
// its pose fixed at the origin; later frames are matched against it and related by
// essential-matrix RANSAC. The current frame becomes the second keyframe when the inliers drop
// below tau_stereo or the mean triangulation angle exceeds alpha_stereo — but never before the
// median angle reaches min_bootstrap_parallax_deg (triangulation below that is mostly noise).
// If neither happens within max_bootstrap_frames, the best candidate with enough parallax is
// taken, or the bootstrap restarts at the current frame. While the first submap estimates the
// focal, the accepted pair is also solved at other focals (FocalTwin): nearly planar ground
// has two motions, and which one the views give can depend on it (bootstrap_twin.cc).
#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>

#include "engine/core/logging.h"
#include "engine/core/median.h"
#include "engine/features/feature_matcher.h"
#include "engine/geometry/essential.h"
#include "engine/geometry/rotation_only.h"
#include "engine/geometry/triangulation.h"
#include "engine/submap/motion_prediction.h"
#include "engine/submap/submap_builder.h"

namespace glam {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;
// Small baselines are normal while the bootstrap waits for parallax; the angle rules decide.
constexpr double kMaxDepthBaselines = 1e4;
// A steered bootstrap (OpenSubmap::bootstrap_preference) takes the preferred basin's motion
// when it costs at most this much more than the cheapest.
constexpr double kPreferenceMaxCostRatio = 1.1;

struct TwoViewCandidate {
  std::size_t position = 0;  // of the second frame in the open submap's frames
  SE3 cam1_from_cam0;
  std::vector<Match> inlier_matches;
  std::vector<TwoViewCorrespondence> inlier_rays;  // one per inlier match
  std::vector<Eigen::Vector3d> points;  // in cam0 (= submap) frame, one per inlier match
  std::vector<double> angles_deg;
  double median_angle_deg = 0;
  double mean_angle_deg = 0;
};

// Normalised rays of the matched features (query: `second`, train: `first`) through `camera`.
std::vector<TwoViewCorrespondence> Rays(const Camera& camera, const FrameRecord& first, const FrameRecord& second,
                                        const std::vector<Match>& matches) {
  std::vector<TwoViewCorrespondence> rays;
  rays.reserve(matches.size());
  for (const Match& m : matches) {
    rays.push_back({camera.Unproject(first.features.points[m.train].cast<double>()).head<2>(),
                    camera.Unproject(second.features.points[m.query].cast<double>()).head<2>()});
  }
  return rays;
}

// How far (0-1) `frame` lies in time between `first` and `second` (frames dropped from a
// stream leave gaps that frame positions would not show); by frame number if the times do
// not increase.
double FractionOfTheWay(const FrameRecord& first, const FrameRecord& frame, const FrameRecord& second) {
  double span = second.timestamp_s - first.timestamp_s;
  double part = frame.timestamp_s - first.timestamp_s;
  if (!(span > 0) || !std::isfinite(span) || !std::isfinite(part)) {
    span = static_cast<double>(second.index - first.index);
    part = static_cast<double>(frame.index - first.index);
  }
  return span > 0 ? std::clamp(part / span, 0.0, 1.0) : 0.0;
}

}  // namespace

RansacOptions SubmapBuilder::BootstrapRansacOptions() const {
  RansacOptions ransac;
  ransac.inlier_threshold = options_.pnp_threshold_pixels;
  ransac.min_inliers = options_.min_tracking_inliers;
  return ransac;
}

std::optional<SubmapBuilder::OpenSubmap::Twin> SubmapBuilder::FocalTwin(const FrameRecord& first,
                                                                         const FrameRecord& second,
                                                                         const std::vector<Match>& matches) const {
  const double step = options_.bootstrap_twin_focal_step;
  if (step <= 0 || !options_.bundle_adjustment.refine_focal || !camera_decisions_open_ ||
      !open_.bootstrap_direction) {
    return std::nullopt;
  }
  for (const double scale : {1.0 - step, 1.0 + step}) {
    Intrinsics intrinsics = CurrentCamera().intrinsics();
    intrinsics.fx *= scale;
    intrinsics.fy *= scale;
    const RelativePoseResult rel = EstimateRelativePose(Rays(Camera(intrinsics), first, second, matches),
                                                        intrinsics.fx, BootstrapRansacOptions(), kMaxDepthBaselines);
    if (!rel.success) continue;
    const Eigen::Vector3d direction = CameraCenter(rel.cam2_from_cam1).normalized();
    if (!DistinctMotions(direction, *open_.bootstrap_direction)) continue;
    GLAM_LOG_DEBUG("bootstrap frames {} and {}: at focal {:.1f} px the views give another motion (centre "
                   "direction {:.1f} deg from the one at {:.1f} px)",
                   first.index, second.index, intrinsics.fx,
                   std::acos(std::clamp(direction.dot(*open_.bootstrap_direction), -1.0, 1.0)) * kRadToDeg, focal_);
    return OpenSubmap::Twin{direction, intrinsics.fx};
  }
  return std::nullopt;
}

bool SubmapBuilder::TryBootstrap() {
  // The first frame of the (re)started bootstrap is the first keyframe candidate.
  if (open_.frames.size() - open_.bootstrap_first < 2) return false;
  const FrameRecord& first = open_.frames[open_.bootstrap_first];
  const std::size_t position = open_.frames.size() - 1;
  const FrameRecord& current = open_.frames[position];
  const Camera camera = CurrentCamera();

  MatchOptions match_options;
  match_options.ratio = static_cast<float>(options_.match_ratio);
  match_options.mutual = true;
  const std::vector<Match> matches =
      MatchDescriptors(current.features.FloatDescriptors(), first.features.FloatDescriptors(), match_options);

  TwoViewCandidate candidate;
  candidate.position = position;
  bool usable = false;
  if (static_cast<int>(matches.size()) >= options_.min_tracking_inliers) {
    const std::vector<TwoViewCorrespondence> rays = Rays(camera, first, current, matches);
    const RansacOptions ransac = BootstrapRansacOptions();
    std::optional<MotionPreference> preference;
    if (open_.bootstrap_preference) {
      preference = MotionPreference{*open_.bootstrap_preference, kPreferenceMaxCostRatio};
    }
    const RelativePoseResult rel =
        EstimateRelativePose(rays, camera.intrinsics().fx, ransac, kMaxDepthBaselines, preference);
    if (rel.success) {
      candidate.cam1_from_cam0 = rel.cam2_from_cam1;
      const SE3 poses[2] = {SE3(), rel.cam2_from_cam1};
      for (std::size_t i = 0; i < matches.size(); ++i) {
        if (!rel.inlier_mask[i]) continue;
        const Eigen::Vector2d obs[2] = {rays[i].x1, rays[i].x2};
        const auto triangulated = TriangulateDlt(poses, obs);
        if (!triangulated) continue;
        const Eigen::Vector3d p = *triangulated;
        if (p.z() <= 0 || (rel.cam2_from_cam1 * p).z() <= 0) continue;
        candidate.inlier_matches.push_back(matches[i]);
        candidate.inlier_rays.push_back(rays[i]);
        candidate.points.push_back(p);
        candidate.angles_deg.push_back(
            TriangulationAngle(Eigen::Vector3d::Zero(), rel.cam2_from_cam1.Inverse().translation(), p) * kRadToDeg);
      }
      if (static_cast<int>(candidate.points.size()) >= options_.min_tracking_inliers) {
        candidate.median_angle_deg = UpperMedian(candidate.angles_deg);
        candidate.mean_angle_deg =
            std::accumulate(candidate.angles_deg.begin(), candidate.angles_deg.end(), 0.0) /
            static_cast<double>(candidate.angles_deg.size());
        usable = true;
      }
    }
  }

  if (open_.tau_stereo == 0) {
    const int features = static_cast<int>(first.features.size());
    open_.tau_stereo = options_.EffectiveTauStereo(features);
    open_.tau_resection = options_.EffectiveTauResection(features);
  }
  bool enough_parallax = usable && candidate.median_angle_deg >= options_.min_bootstrap_parallax_deg;
  if (enough_parallax && options_.bootstrap_rotation_veto_fraction > 0) {
    // Only where the angle would count: is it a rotation that E mistook for a baseline?
    RotationOnlyOptions rotation_options;
    rotation_options.inlier_threshold_px = options_.bootstrap_rotation_veto_pixels;
    const RotationOnlyFit rotation =
        FitRotationOnly(candidate.inlier_rays, camera.intrinsics().fx, rotation_options);
    if (rotation.success && rotation.inlier_fraction >= options_.bootstrap_rotation_veto_fraction) {
      GLAM_LOG_DEBUG("bootstrap frame {} vs {}: a rotation explains {:.1f} % of the {} inliers "
                     "(median angle {:.2f} deg from E ignored)",
                     current.index, first.index, 100 * rotation.inlier_fraction, candidate.inlier_rays.size(),
                     candidate.median_angle_deg);
      enough_parallax = false;
    }
  }
  const bool paper_rule = enough_parallax &&
                          (static_cast<int>(candidate.points.size()) < open_.tau_stereo ||
                           candidate.mean_angle_deg > options_.alpha_stereo_deg);
  const bool parallax_rule = enough_parallax && options_.bootstrap_accept_parallax_deg > 0 &&
                             candidate.median_angle_deg >= options_.bootstrap_accept_parallax_deg;
  const bool waited_too_long =
      finishing_ || static_cast<int>(position - open_.bootstrap_first) >= options_.max_bootstrap_frames;
  // Restart only when the first keyframe is no longer in view; low parallax means waiting.
  const bool losing_overlap = static_cast<int>(matches.size()) < 2 * options_.min_tracking_inliers;

  GLAM_LOG_TRACE("bootstrap frame {} vs {}: {} matches, usable {}, {} points, median {:.2f} deg, mean {:.2f} deg",
                 current.index, first.index, matches.size(), usable, candidate.points.size(),
                 candidate.median_angle_deg, candidate.mean_angle_deg);
  if (!paper_rule && !parallax_rule && !(enough_parallax && waited_too_long)) {
    if (losing_overlap || waited_too_long) {
      // Restart with the current frame as the first keyframe candidate; earlier frames of this
      // attempt stay unposed and are dropped.
      GLAM_LOG_DEBUG("bootstrap restarted at frame {} ({})", current.index,
                     losing_overlap ? "too few matches" : "no parallax");
      open_.frames.erase(open_.frames.begin(), open_.frames.begin() + static_cast<std::ptrdiff_t>(position));
      open_.bootstrap_first = 0;
      open_.tau_stereo = 0;
      open_.bootstrap_preference.reset();  // a direction seen from the old first frame
    }
    return false;
  }

  // Accept: drop frames before the first keyframe, create keyframes 0 and 1 and landmarks.
  open_.frames.erase(open_.frames.begin(), open_.frames.begin() + static_cast<std::ptrdiff_t>(open_.bootstrap_first));
  const std::size_t kf1_position = position - open_.bootstrap_first;
  open_.bootstrap_first = 0;
  // Fix the submap's scale: unit baseline between the first two keyframes.
  SE3 cam1_from_cam0 = candidate.cam1_from_cam0;
  const double baseline = cam1_from_cam0.translation().norm();
  cam1_from_cam0.translation() /= baseline;
  for (Eigen::Vector3d& p : candidate.points) p /= baseline;

  open_.frames[0].cam_from_submap = SE3();
  open_.frames[kf1_position].cam_from_submap = cam1_from_cam0;
  for (std::size_t i = 0; i < candidate.points.size(); ++i) {
    const Match& m = candidate.inlier_matches[i];
    Landmark lm;
    lm.id = open_.next_landmark_id++;
    lm.point_in_submap = candidate.points[i];
    lm.descriptor = open_.frames[0].features.descriptors[m.train];
    lm.color = open_.frames[0].features.colors[m.train];
    open_.frames[0].landmark_matches.emplace_back(m.train, lm.id);
    open_.frames[kf1_position].landmark_matches.emplace_back(m.query, lm.id);
    open_.extras[lm.id] = {lm.point_in_submap.normalized()};
    open_.landmarks.push_back(std::move(lm));
  }
  AddKeyframe(0);
  AddKeyframe(kf1_position);
  open_.bootstrapped = true;
  OptimiseAndFilter();
  GLAM_LOG_DEBUG("bootstrap: keyframes at frames {} and {}, {} landmarks, median angle {:.1f} deg",
                 open_.frames[0].index, open_.frames[kf1_position].index, open_.landmarks.size(),
                 candidate.median_angle_deg);
  open_.bootstrap_direction = CameraCenter(candidate.cam1_from_cam0).normalized();
  if (!open_.bootstrap_twin_checked) open_.bootstrap_twin = FocalTwin(open_.frames[0], open_.frames[kf1_position], matches);

  // Frames between the two keyframes are localised against the new landmarks in order, each
  // guided first by a constant-velocity prediction off the two frames before it (the first by
  // the pose interpolated between the keyframes), both in time (motion_prediction.h). Frames after the second keyframe (a past best
  // candidate) are tracked in order.
  const SE3 cam1_from_submap = *open_.frames[kf1_position].cam_from_submap;  // submap = cam0
  for (std::size_t p = 1; p < open_.frames.size(); ++p) {
    if (p == kf1_position) continue;
    FrameRecord& f = open_.frames[p];
    if (p < kf1_position) {
      SE3 predicted;
      const auto& previous = open_.frames[p - 1].cam_from_submap;
      if (p >= 2 && previous && open_.frames[p - 2].cam_from_submap) {
        const FrameRecord& before = open_.frames[p - 2];
        predicted = ExtrapolateConstantVelocity(*before.cam_from_submap, before.timestamp_s, *previous,
                                                open_.frames[p - 1].timestamp_s, f.timestamp_s);
      } else {
        const double t = FractionOfTheWay(open_.frames[0], f, open_.frames[kf1_position]);
        const SO3 rotation = SO3::Exp(t * cam1_from_submap.rotation().Log());
        predicted = SE3(rotation, -(rotation * (t * CameraCenter(cam1_from_submap))));
      }
      LocaliseGuidedFirst(f, predicted);
    } else if (Track(f)) {
      ++stats_.frames_tracked;
    }
  }
  return true;
}

}  // namespace glam
