// Tracking through a hovering yaw (SubmapOptions::hover_max_speed). A drone that stops and
// turns in place with an oblique camera swings its view to ground no landmark covers: PnP has
// nothing to match, and without a baseline nothing new can be triangulated either. What the
// images still give is the rotation: consecutive frames of a hover differ by x2 ~ K R K^-1 x1,
// which a pure-rotation fit (engine/geometry/rotation_only.h) recovers from their descriptor
// matches. Such a frame keeps the centre of the frame before it. The hover is checked where
// the chain starts (the last PnP pose): a moving drone that loses tracking still starts a new
// submap, since holding its centre would be wrong by its speed times the chain's length.
#include <algorithm>
#include <cmath>

#include "engine/core/logging.h"
#include "engine/core/median.h"
#include "engine/features/feature_matcher.h"
#include "engine/geometry/rotation_only.h"
#include "engine/submap/submap_builder.h"

namespace glam {
namespace {

// The hover is judged between the posed frames 0.2 and 0.7 s before the chain's first frame:
// PnP degrades in the last frames before tracking is lost (landmarks leave the view on one
// side: on the stop-and-yaw test flight the last 0.1 s of a hover moved its centre by 25 times
// what the 0.5 s before did), and over half a second PnP jitter (a few cm per frame) does not
// look like motion.
constexpr double kHoverCheckFromSeconds = 0.7;
constexpr double kHoverCheckToSeconds = 0.2;

}  // namespace

std::vector<std::size_t> SubmapBuilder::HoverWindow(std::size_t position) const {
  const double t = open_.frames[position].timestamp_s;
  std::vector<std::size_t> window;  // newest first
  for (std::size_t p = position; p-- > 0;) {
    const FrameRecord& f = open_.frames[p];
    const double dt = t - f.timestamp_s;
    if (dt > kHoverCheckFromSeconds) break;
    if (f.cam_from_submap && !f.rotation_only() && dt >= kHoverCheckToSeconds) window.push_back(p);
  }
  return window;
}

Eigen::Vector3d SubmapBuilder::HoverCentre(std::size_t position) const {
  const std::vector<std::size_t> window = HoverWindow(position);
  if (window.empty()) return open_.frames[position].cam_from_submap->Inverse().translation();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t p : window) sum += open_.frames[p].cam_from_submap->Inverse().translation();
  return sum / static_cast<double>(window.size());
}

bool SubmapBuilder::HoveringAt(std::size_t position) const {
  const FrameRecord& anchor = open_.frames[position];
  if (!anchor.cam_from_submap || anchor.landmark_matches.empty()) return false;
  const std::vector<std::size_t> window = HoverWindow(position);
  if (window.size() < 2) return false;
  const FrameRecord& first = open_.frames[window.back()];
  const FrameRecord& last = open_.frames[window.front()];
  // Speed relative to the depth of what the camera sees: submap units are arbitrary.
  std::vector<double> depths;
  for (const auto& [feature, id] : anchor.landmark_matches) {
    if (const Landmark* lm = FindLandmark(id)) {
      const double z = (*anchor.cam_from_submap * lm->point_in_submap).z();
      if (z > 0) depths.push_back(z);
    }
  }
  if (depths.empty()) return false;
  const double depth = UpperMedian(std::move(depths));
  // The velocity of a least-squares line through the window's centres, not the difference of
  // its two ends: PnP of the frames before a loss jitters (the yaw is taking the landmarks out
  // of view), and two poses alone made a hovering drone look like one flying at 1 m/s (the
  // stop-and-yaw clip: 0.0116 x the depth per second over the hover before its second yaw).
  std::vector<Eigen::Vector3d> centres;
  centres.reserve(window.size());
  double mean_t = 0;
  Eigen::Vector3d mean_centre = Eigen::Vector3d::Zero();
  for (std::size_t p : window) {
    centres.push_back(open_.frames[p].cam_from_submap->Inverse().translation());
    mean_t += open_.frames[p].timestamp_s;
    mean_centre += centres.back();
  }
  mean_t /= static_cast<double>(window.size());
  mean_centre /= static_cast<double>(window.size());
  double tt = 0;
  Eigen::Vector3d tc = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < window.size(); ++i) {
    const double dt = open_.frames[window[i]].timestamp_s - mean_t;
    tt += dt * dt;
    tc += dt * (centres[i] - mean_centre);
  }
  if (!(tt > 0)) return false;
  const double speed = (tc / tt).norm();
  const bool hovering = speed <= options_.hover_max_speed * depth;
  GLAM_LOG_DEBUG("frame {}: camera speed {:.4f} x the median depth per second over frames {}-{} ({})",
                 anchor.index, speed / depth, first.index, last.index, hovering ? "hovering" : "moving");
  return hovering;
}

bool SubmapBuilder::PoseByRotationOnly(std::size_t position) {
  if (options_.hover_max_speed <= 0 || position == 0) return false;
  FrameRecord& current = open_.frames[position];
  const FrameRecord& previous = open_.frames[position - 1];
  if (!previous.cam_from_submap || current.features.size() == 0) return false;
  // The chain's first frame: the last one PnP posed.
  std::size_t anchor = position - 1;
  while (anchor > 0 && open_.frames[anchor].rotation_only()) --anchor;
  if (open_.frames[anchor].rotation_only()) return false;
  if (current.timestamp_s - open_.frames[anchor].timestamp_s > options_.hover_max_seconds) return false;
  if (anchor == position - 1 && !HoveringAt(anchor)) return false;

  MatchOptions match;
  match.ratio = static_cast<float>(options_.match_ratio);
  match.mutual = true;
  const std::vector<Match> matches =
      MatchDescriptors(current.features.FloatDescriptors(), previous.features.FloatDescriptors(), match);
  if (static_cast<int>(matches.size()) < options_.min_tracking_inliers) return false;
  const Camera camera = CurrentCamera();
  std::vector<TwoViewCorrespondence> rays;
  rays.reserve(matches.size());
  for (const Match& m : matches) {
    rays.push_back({camera.Unproject(previous.features.points[m.train].cast<double>()).head<2>(),
                    camera.Unproject(current.features.points[m.query].cast<double>()).head<2>()});
  }
  const RotationOnlyFit fit = FitRotationOnly(rays, camera.intrinsics().fx);
  if (!fit.success || fit.inliers < options_.min_tracking_inliers ||
      fit.inlier_fraction < options_.hover_min_rotation_fraction) {
    GLAM_LOG_DEBUG("frame {}: no rotation-only pose ({} of {} matches explained)", current.index, fit.inliers,
                   matches.size());
    return false;
  }
  const double turn_deg = fit.cam2_from_cam1.Log().norm() * 180.0 / M_PI;
  const double dt = current.timestamp_s - previous.timestamp_s;
  if (dt <= 0 || turn_deg < options_.hover_min_turn_rate_deg_s * dt) {
    GLAM_LOG_DEBUG("frame {}: turning {:.2f} deg since frame {}, too slow for a rotation-only pose",
                   current.index, turn_deg, previous.index);
    return false;
  }
  const SO3 cam_from_submap_rotation = fit.cam2_from_cam1 * previous.cam_from_submap->rotation();
  // The first frame of a chain holds the hover's centre (PnP of the frames right before it has
  // degraded), the others the centre of the frame before them.
  const Eigen::Vector3d centre = previous.rotation_only() ? previous.cam_from_submap->Inverse().translation()
                                                         : HoverCentre(position - 1);
  current.cam_from_submap = SE3(cam_from_submap_rotation, -(cam_from_submap_rotation * centre));
  current.cam_from_previous_rotation = fit.cam2_from_cam1;
  GLAM_LOG_DEBUG("frame {}: posed by rotation only ({:.2f} deg from frame {}, {} of {} matches within 1 px)",
                 current.index, turn_deg, previous.index, fit.inliers,
                 matches.size());
  return true;
}

void SubmapBuilder::RederiveRotationOnlyPoses() {
  for (std::size_t p = 1; p < open_.frames.size(); ++p) {
    FrameRecord& frame = open_.frames[p];
    if (!frame.rotation_only()) continue;
    const FrameRecord& previous = open_.frames[p - 1];
    if (!previous.cam_from_submap) {
      frame.ResetPose();
      continue;
    }
    const SO3 rotation = *frame.cam_from_previous_rotation * previous.cam_from_submap->rotation();
    const Eigen::Vector3d centre =
        previous.rotation_only() ? previous.cam_from_submap->Inverse().translation() : HoverCentre(p - 1);
    frame.cam_from_submap = SE3(rotation, -(rotation * centre));
  }
}

}  // namespace glam
