// Submap completion (paper, "Completion"): after the last keyframe's bundle adjustment, every
// frame of the submap is relocalised by PnP against the final landmarks — only the 3D-2D
// matches found while tracking are needed, no features are recomputed — and points that are
// inconsistent with the final poses are removed (the third outlier filter). Added to the
// paper: before the relocalisation, up to SubmapOptions::completion_ba_max_frames tracked
// frames join one last bundle adjustment with their tracking matches as observations, so
// landmarks are adjusted with the views in between keyframes too (docs/algorithm.md).
#include <algorithm>
#include <unordered_map>

#include "engine/core/logging.h"
#include "engine/geometry/absolute_pose.h"
#include "engine/submap/submap_builder.h"

namespace glam {
namespace {

// Iteration cap of each of the fixed-focal check's two adjustments (run once per job; the
// free focal took up to 34 iterations on the benchmark videos started 15 % off).
constexpr int kFixedFocalCheckIterations = 100;

// Up to `count` of `candidates` (sorted positions), spread evenly over them.
std::vector<std::size_t> PickEvenly(const std::vector<std::size_t>& candidates, std::size_t count) {
  if (candidates.size() <= count) return candidates;
  std::vector<std::size_t> picked;
  for (std::size_t i = 0; i < count; ++i) picked.push_back(candidates[i * candidates.size() / count]);
  return picked;
}

}  // namespace

std::vector<bool> SubmapBuilder::RefineWithTrackedFrames() {
  std::vector<bool> refined(open_.frames.size(), false);
  const auto max_frames = static_cast<std::size_t>(options_.completion_ba_max_frames);
  if (max_frames == 0) return refined;
  std::vector<bool> is_keyframe(open_.frames.size(), false);
  for (std::size_t p : open_.keyframe_frame_positions) is_keyframe[p] = true;
  std::vector<std::size_t> detected;
  std::vector<std::size_t> carried;
  for (std::size_t p = 0; p < open_.frames.size(); ++p) {
    const FrameRecord& frame = open_.frames[p];
    if (is_keyframe[p] || !frame.cam_from_submap ||
        static_cast<int>(frame.landmark_matches.size()) < options_.min_tracking_inliers) {
      continue;
    }
    (frame.detected ? detected : carried).push_back(p);
  }
  // Detection frames first (they see ground the carried-over keypoints do not).
  std::vector<std::size_t> chosen = PickEvenly(detected, max_frames);
  if (chosen.size() < max_frames) {
    const std::vector<std::size_t> more = PickEvenly(carried, max_frames - chosen.size());
    chosen.insert(chosen.end(), more.begin(), more.end());
  }
  if (chosen.empty()) return refined;

  // Keyframes first (the BA gauge holds keyframes 0 and 1), then the chosen frames, observing
  // copies of the landmarks; only poses and positions are taken back, so the submap's
  // observations keep indexing keyframes.
  std::vector<Keyframe> views = open_.keyframes;
  std::vector<Landmark> landmarks = open_.landmarks;
  std::unordered_map<std::uint32_t, std::size_t> row_of_id;
  for (std::size_t i = 0; i < landmarks.size(); ++i) row_of_id[landmarks[i].id] = i;
  for (std::size_t p : chosen) {
    const FrameRecord& frame = open_.frames[p];
    const auto view = static_cast<std::uint32_t>(views.size());
    views.push_back({frame.index, *frame.cam_from_submap, focal_});
    for (const auto& [feature, id] : frame.landmark_matches) {
      const auto it = row_of_id.find(id);
      if (it == row_of_id.end()) continue;
      landmarks[it->second].observations.push_back({view, frame.features.points[feature]});
    }
  }
  BundleAdjustmentOptions ba = options_.bundle_adjustment;
  ba.refine_focal = false;  // focal and k1 estimation are the incremental BAs' job
  ba.refine_k1 = false;
  const auto summary = BundleAdjust(CurrentCamera().intrinsics(), views, landmarks, ba, cancel_);
  stats_.bundle_adjust_seconds += summary.seconds;
  for (std::size_t k = 0; k < open_.keyframes.size(); ++k) {
    open_.keyframes[k].cam_from_submap = views[k].cam_from_submap;
  }
  for (std::size_t i = 0; i < landmarks.size(); ++i) {
    open_.landmarks[i].point_in_submap = landmarks[i].point_in_submap;
  }
  for (std::size_t c = 0; c < chosen.size(); ++c) {
    open_.frames[chosen[c]].cam_from_submap = views[open_.keyframes.size() + c].cam_from_submap;
    refined[chosen[c]] = true;
  }
  GLAM_LOG_DEBUG("completion BA: {} keyframes + {} tracked frames, rms {:.3f} -> {:.3f} px ({:.3f} s)",
                 open_.keyframes.size(), chosen.size(), summary.initial_rms_pixels,
                 summary.final_rms_pixels, summary.seconds);
  return refined;
}

void SubmapBuilder::RelocaliseFrames(const std::vector<bool>& keep) {
  const Camera camera = CurrentCamera();
  RansacOptions pnp;
  pnp.inlier_threshold = options_.pnp_threshold_pixels;
  pnp.min_inliers = options_.min_tracking_inliers;
  for (std::size_t p = 0; p < open_.frames.size(); ++p) {
    if (p < keep.size() && keep[p]) continue;
    FrameRecord& frame = open_.frames[p];
    if (frame.rotation_only()) continue;  // RederiveRotationOnlyPoses
    std::vector<Eigen::Vector2d> pixels;
    std::vector<Eigen::Vector3d> points;
    for (const auto& [feature, id] : frame.landmark_matches) {
      if (const Landmark* lm = FindLandmark(id)) {
        pixels.push_back(frame.features.points[feature].cast<double>());
        points.push_back(lm->point_in_submap);
      }
    }
    if (static_cast<int>(points.size()) < options_.min_tracking_inliers) {
      // Too few surviving matches: match the final landmarks again, guided by the tracked pose.
      LocaliseGuidedFirst(frame, frame.cam_from_submap);
      continue;
    }
    const RansacResult<SE3> result = EstimateAbsolutePose(pixels, points, camera, pnp);
    if (result.success) {
      frame.cam_from_submap = result.model;
    } else {
      frame.cam_from_submap.reset();
    }
  }
  // Keyframes keep their bundle-adjusted poses.
  for (std::size_t k = 0; k < open_.keyframes.size(); ++k) {
    open_.frames[open_.keyframe_frame_positions[k]].cam_from_submap = open_.keyframes[k].cam_from_submap;
  }
}

void SubmapBuilder::SmoothFrameCentres() {
  const CentreSmoothingOptions& options = options_.centre_smoothing;
  if (options.half_window_s <= 0) return;
  const Camera camera = CurrentCamera();
  std::size_t smoothed = 0;
  double moved = 0;
  auto smooth_run = [&](std::size_t begin, std::size_t end) {  // posed frames [begin, end)
    if (end - begin < static_cast<std::size_t>(options.min_frames)) return;
    std::vector<double> times;
    std::vector<Eigen::Vector3d> centres;
    for (std::size_t p = begin; p < end; ++p) {
      times.push_back(open_.frames[p].timestamp_s);
      centres.push_back(open_.frames[p].cam_from_submap->Inverse().translation());
    }
    const std::vector<Eigen::Vector3d> fitted = SmoothCentres(times, centres, options);
    for (std::size_t p = begin; p < end; ++p) {
      // Frames SmoothCentres left where they were (windows too sparse) keep their PnP pose.
      if (fitted[p - begin] == centres[p - begin]) continue;
      FrameRecord& frame = open_.frames[p];
      std::vector<Eigen::Vector2d> normalized;
      std::vector<Eigen::Vector3d> points;
      for (const auto& [feature, id] : frame.landmark_matches) {
        const Landmark* lm = FindLandmark(id);
        if (lm == nullptr) continue;
        // Only the matches the relocalised pose explains (the tracking matches were found
        // against landmarks that have moved since).
        const Eigen::Vector2d pixel = frame.features.points[feature].cast<double>();
        Eigen::Vector2d projected;
        if (!camera.Project(*frame.cam_from_submap * lm->point_in_submap, &projected) ||
            (projected - pixel).norm() > options_.pnp_threshold_pixels) {
          continue;
        }
        normalized.push_back(camera.Unproject(pixel).head<2>());
        points.push_back(lm->point_in_submap);
      }
      if (static_cast<int>(points.size()) < options_.min_tracking_inliers) continue;
      SE3 pose = *frame.cam_from_submap;
      if (!SolveRotationWithCentre(normalized, points, fitted[p - begin], &pose)) continue;
      moved += (fitted[p - begin] - centres[p - begin]).norm();
      frame.cam_from_submap = pose;
      ++smoothed;
    }
  };
  // Runs end at unposed and at rotation-only frames (their centre follows the frame before
  // them afterwards, RederiveRotationOnlyPoses).
  std::size_t run_begin = 0;
  for (std::size_t p = 0; p <= open_.frames.size(); ++p) {
    if (p < open_.frames.size() && open_.frames[p].cam_from_submap && !open_.frames[p].rotation_only()) continue;
    smooth_run(run_begin, p);
    run_begin = p + 1;
  }
  GLAM_LOG_DEBUG("centre smoothing: {} of {} frames, mean move {:.4f} (submap units)", smoothed,
                 open_.frames.size(), smoothed > 0 ? moved / static_cast<double>(smoothed) : 0.0);
}

void SubmapBuilder::CheckFixedFocal() {
  // A focal held because the images do not determine it (focal profile) has nothing to check.
  if (!options_.check_fixed_focal || options_.bundle_adjustment.refine_focal || stats_.free_focal_px ||
      stats_.focal_held) {
    return;
  }
  std::vector<Keyframe> keyframes = open_.keyframes;
  std::vector<Landmark> landmarks = open_.landmarks;
  BundleAdjustmentOptions ba = options_.bundle_adjustment;
  ba.max_iterations = kFixedFocalCheckIterations;
  ba.refine_k1 = false;  // the focal's question alone
  // First to convergence with the focal still fixed: the completed submap is not at the
  // keyframes-only optimum (its last adjustment included tracked frames, and filters removed
  // points since), and a free focal started off that optimum wanders along the flat
  // focal/depth valley of low-relief ground while the structure settles (measured on the loop
  // benchmark video, true focal: -17.6 % without this pass, 0.0 % with it). The free pass then
  // follows the cost downhill from the given focal with Ceres' default tolerances: where the
  // images do not determine the focal (flat valley) it stops near the given one, so the check
  // errs towards no warning. It is a local estimate, not a calibration: with tolerances
  // tightened by six orders it wanders to -56 % on that video for a 0.2 % lower rms.
  const auto fixed = BundleAdjust(CurrentCamera().intrinsics(), keyframes, landmarks, ba, cancel_);
  ba.refine_focal = true;
  ba.share_focal = true;
  ba.focal_prior_weight = 0.0;
  const auto free = BundleAdjust(CurrentCamera().intrinsics(), keyframes, landmarks, ba, cancel_);
  stats_.bundle_adjust_seconds += fixed.seconds + free.seconds;
  stats_.free_focal_px = keyframes.front().focal;
  stats_.free_focal_rms_gain =
      fixed.final_rms_pixels > 0 ? 1.0 - free.final_rms_pixels / fixed.final_rms_pixels : 0.0;
  GLAM_LOG_INFO("fixed focal check: {:.1f} px given, {:.1f} px preferred with the focal free ({:+.1f} %; "
                "rms {:.4f} px fixed, {:.4f} px free; {:.2f} s)",
                focal_, *stats_.free_focal_px, 100.0 * (*stats_.free_focal_px / focal_ - 1.0),
                fixed.final_rms_pixels, free.final_rms_pixels, fixed.seconds + free.seconds);
}

std::optional<Submap> SubmapBuilder::Complete() {
  const Camera camera = CurrentCamera();
  const std::size_t before = open_.landmarks.size();
  // Landmarks found moving after the last keyframe's adjustment would otherwise stay in the
  // submap and in the completion adjustment below.
  RemoveMovingLandmarks();
  const std::size_t reprojection =
      RemoveReprojectionOutliers(camera.intrinsics(), open_.keyframes, open_.landmarks, options_.outlier_filter);
  const std::size_t isolated =
      RemoveIsolatedLandmarks(open_.landmarks, options_.outlier_filter);  // all of them, as in the paper
  const std::size_t weak = RemoveWeaklyTriangulatedLandmarks(open_.keyframes, open_.landmarks, options_.outlier_filter);
  GLAM_LOG_DEBUG("completion filters: {} landmarks, {} reprojection outliers, {} isolated, {} weakly triangulated",
                 before, reprojection, isolated, weak);
  if (static_cast<int>(open_.landmarks.size()) < options_.min_tracking_inliers) {
    ++stats_.submaps_discarded;
    GLAM_LOG_INFO("submap of frames {}-{} discarded: {} of its {} landmarks are left after the completion filters, "
                  "fewer than posing a frame needs ({}); its frames stay unposed",
                  open_.frames.front().index, open_.frames.back().index, open_.landmarks.size(), before,
                  options_.min_tracking_inliers);
    return std::nullopt;
  }
  const std::vector<bool> refined = RefineWithTrackedFrames();
  if (std::find(refined.begin(), refined.end(), true) != refined.end()) {
    // The completion BA moved the landmarks: filter 1 once more on their final positions.
    RemoveReprojectionOutliers(camera.intrinsics(), open_.keyframes, open_.landmarks, options_.outlier_filter);
  }
  RelocaliseFrames(refined);
  SmoothFrameCentres();
  RederiveRotationOnlyPoses();
  CheckFixedFocal();
  // A first submap closed without the camera decisions (by a tracking loss, or out of rebuilds)
  // still decides on k1, for the submaps after it; it keeps the k1 it was built with. A
  // fragment leaves the decisions to the next submap (CameraDecidingSubmap).
  const bool deciding = camera_decisions_open_ && CameraDecidingSubmap();
  if (deciding) DecideK1();

  Submap submap;
  submap.id = next_submap_id_++;
  if (deciding) camera_decisions_open_ = false;
  submap.intrinsics = camera.intrinsics();
  submap.keyframes = open_.keyframes;
  submap.landmarks = open_.landmarks;
  submap.first_frame = open_.frames.front().index;
  submap.last_frame = open_.frames.back().index;
  for (const FrameRecord& frame : open_.frames) {
    if (!frame.cam_from_submap) {
      ++submap.stats.frames_unposed;
      continue;
    }
    submap.frame_poses.push_back(frame.ToFramePose());
  }
  submap.stats.landmarks_removed = static_cast<std::uint32_t>(before - open_.landmarks.size());
  std::string focals;
  for (const Keyframe& kf : open_.keyframes) {
    completed_keyframe_focals_.push_back(kf.focal);
    focals += fmt::format(" {:.1f}", kf.focal);
  }
  GLAM_LOG_DEBUG("submap {} keyframe focals:{}", submap.id, focals);
  // Track length: the BA's stiffness (a landmark seen by two keyframes only pins little).
  std::size_t observations = 0, seen_twice = 0;
  for (const Landmark& lm : open_.landmarks) {
    observations += lm.observations.size();
    seen_twice += lm.observations.size() <= 2 ? 1 : 0;
  }
  GLAM_LOG_DEBUG("submap {}: {:.2f} keyframe observations per landmark, {} of {} landmarks seen by two",
                 submap.id, static_cast<double>(observations) / std::max<std::size_t>(1, open_.landmarks.size()),
                 seen_twice, open_.landmarks.size());
  UpdateFocalEstimate();
  ++stats_.submaps_completed;
  GLAM_LOG_INFO("submap {} complete: frames {}-{}, {} keyframes, {} landmarks, {} frames posed, focal {:.1f}",
                submap.id, submap.first_frame, submap.last_frame, submap.keyframes.size(),
                submap.landmarks.size(), submap.frame_poses.size(), focal_);
  return submap;
}

}  // namespace glam
