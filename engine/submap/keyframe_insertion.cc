// New keyframes (paper, "Keyframes"): when PnP inliers fall below tau_resection, the frame
// halfway between the previous keyframe and the current frame becomes the *middle* keyframe
// (its PnP pose and inliers become BA observations), essential-matrix RANSAC between the
// middle keyframe and the current frame selects geometrically consistent matches, these are
// triangulated with the two PnP poses, each new landmark takes the middle keyframe's
// descriptor, new landmarks whose descriptor matches an existing landmark are removed as
// duplicates, and the current frame becomes a keyframe. Then bundle adjustment and the
// outlier filters run, and the focal estimate is updated.
#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "engine/core/logging.h"
#include "engine/core/median.h"
#include "engine/features/epipolar_matcher.h"
#include "engine/features/feature_grid.h"
#include "engine/features/feature_matcher.h"
#include "engine/features/guided_matcher.h"
#include "engine/geometry/essential.h"
#include "engine/geometry/triangulation.h"
#include "engine/submap/submap_builder.h"

namespace glam {

void SubmapBuilder::AddKeyframe(std::size_t position) {
  FrameRecord& frame = open_.frames[position];
  GLAM_CHECK(frame.cam_from_submap.has_value(), "keyframe without pose");
  const auto keyframe_index = static_cast<std::uint32_t>(open_.keyframes.size());
  Keyframe kf;
  kf.frame_index = frame.index;
  kf.cam_from_submap = *frame.cam_from_submap;
  kf.focal = focal_;
  open_.keyframes.push_back(kf);
  open_.keyframe_frame_positions.push_back(position);
  for (const auto& [feature, landmark_id] : frame.landmark_matches) {
    Landmark* landmark = FindLandmark(landmark_id);
    if (landmark == nullptr) continue;  // filtered meanwhile
    landmark->observations.push_back({keyframe_index, frame.features.points[feature]});
  }
  ++stats_.keyframes;
}

void SubmapBuilder::InsertKeyframes(std::size_t current_position) {
  const std::size_t previous = open_.keyframe_frame_positions.back();
  if (current_position <= previous) return;
  // Middle keyframe: the posed frame closest to halfway; a detected frame (full SIFT
  // features) within a quarter of the gap from halfway is preferred to a propagated one.
  const std::size_t half = (previous + current_position) / 2;
  const std::size_t gap = current_position - previous;
  auto closest_to_half = [&](std::size_t max_distance, bool detected_only) -> std::optional<std::size_t> {
    for (std::size_t d = 0; d <= max_distance; ++d) {
      for (std::size_t p : {half - std::min(d, half), half + d}) {
        if (p <= previous || p >= current_position) continue;
        const FrameRecord& f = open_.frames[p];
        if (f.cam_from_submap && !f.rotation_only() && (f.detected || !detected_only)) return p;
      }
    }
    return std::nullopt;
  };
  std::optional<std::size_t> middle = closest_to_half(gap / 4, true);
  if (!middle) middle = closest_to_half(gap, false);
  const std::size_t first_new = open_.landmarks.size();
  if (middle) {
    AddKeyframe(*middle);
    TriangulateBetween(*middle, current_position);
  } else {
    TriangulateBetween(previous, current_position);
  }
  AddKeyframe(current_position);
  if (options_.extend_new_tracks) ObserveNewLandmarksInEarlierKeyframes(first_new);
  OptimiseAndFilter();
}

void SubmapBuilder::ObserveNewLandmarksInEarlierKeyframes(std::size_t first_new) {
  // New landmarks are triangulated from two close views; finding them in earlier keyframes
  // (projection + descriptor match nearby) lengthens their tracks and the BA baseline, which
  // is what makes their depth precise. Keyframes that already observe them are skipped.
  if (first_new >= open_.landmarks.size() || open_.keyframes.size() < 3) return;
  const Camera camera = CurrentCamera();
  const double radius = options_.max_new_point_reprojection_pixels * 2.0;
  std::vector<int> rows;
  for (std::size_t i = first_new; i < open_.landmarks.size(); ++i) rows.push_back(static_cast<int>(i));
  const cv::Mat descriptors = LandmarkDescriptorMatrix(open_.landmarks, rows);
  const std::size_t newest_two = open_.keyframes.size() - 2;  // middle and current observe them
  std::size_t added = 0;
  for (std::size_t k = 0; k < newest_two; ++k) {
    const FrameRecord& frame = open_.frames[open_.keyframe_frame_positions[k]];
    std::vector<Eigen::Vector2d> predicted(rows.size(), Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN()));
    bool any = false;
    for (std::size_t r = 0; r < rows.size(); ++r) {
      Eigen::Vector2d px;
      if (camera.Project(open_.keyframes[k].cam_from_submap * open_.landmarks[rows[r]].point_in_submap, &px) &&
          camera.InImage(px)) {
        predicted[r] = px;
        any = true;
      }
    }
    if (!any) continue;
    const FeatureGrid grid(frame.features.PixelPoints(), camera.intrinsics().width, camera.intrinsics().height, radius);
    GuidedMatchOptions guided;
    guided.radius_px = radius;
    guided.ratio = static_cast<float>(options_.match_ratio);
    for (const Match& m : MatchGuided(descriptors, predicted, frame.features.FloatDescriptors(), grid, guided)) {
      open_.landmarks[rows[m.query]].observations.push_back(
          {static_cast<std::uint32_t>(k), frame.features.points[m.train]});
      ++added;
    }
  }
  GLAM_LOG_TRACE("{} observations of new landmarks found in earlier keyframes", added);
}

std::vector<Match> SubmapBuilder::MatchForTriangulation(const FrameRecord& first, const std::vector<int>& rows_first,
                                                       const std::vector<Eigen::Vector2d>& first_rays,
                                                       const FrameRecord& second, const std::vector<int>& rows_second,
                                                       const std::vector<Eigen::Vector2d>& second_rays) const {
  // Query = the second frame's unmatched features, train = the first frame's.
  const Camera camera = CurrentCamera();
  const cv::Mat first_descriptors = first.features.FloatDescriptors(rows_first);
  const cv::Mat second_descriptors = second.features.FloatDescriptors(rows_second);
  // Only with the camera fixed: lines drawn with a focal still being refined (a calibration
  // given as a guess, `--refine-focal`) miss the true matches. On the Brighton Beach photos
  // (EXIF focal 16 % short) that cost 6 of 18 photos and sent the focal to 1480 px.
  const BundleAdjustmentOptions& ba = options_.bundle_adjustment;
  if (options_.epipolar_triangulation_matching && !ba.refine_focal && !ba.refine_k1) {
    EpipolarMatchOptions epipolar;
    epipolar.max_line_distance_px = options_.max_new_point_reprojection_pixels;
    epipolar.ratio = static_cast<float>(options_.epipolar_match_ratio);
    epipolar.mutual = true;
    const SE3 cam_first_from_cam_second = *first.cam_from_submap * second.cam_from_submap->Inverse();
    return MatchAlongEpipolarLines(second_descriptors, second_rays, first_descriptors, first_rays,
                                   cam_first_from_cam_second, camera.intrinsics().fx, epipolar);
  }
  // The paper: global matching, then the essential matrix's RANSAC selects consistent matches.
  MatchOptions match_options;
  match_options.ratio = static_cast<float>(options_.match_ratio);
  match_options.mutual = true;
  const std::vector<Match> matches = MatchDescriptors(second_descriptors, first_descriptors, match_options);
  if (matches.size() < 8) return {};
  std::vector<TwoViewCorrespondence> rays;
  for (const Match& m : matches) rays.push_back({first_rays[m.train], second_rays[m.query]});
  RansacOptions ransac;
  ransac.inlier_threshold = options_.pnp_threshold_pixels;
  // The essential matrix only selects consistent matches; triangulation checks depth and angle.
  const RelativePoseResult rel = EstimateRelativePose(rays, camera.intrinsics().fx, ransac, 1e4);
  GLAM_LOG_TRACE("keyframe pair {}-{}: {} matches, {} essential inliers", first.index, second.index,
                 matches.size(), rel.num_inliers);
  if (!rel.success) return {};
  std::vector<Match> inliers;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    if (rel.inlier_mask[i]) inliers.push_back(matches[i]);
  }
  return inliers;
}

std::size_t SubmapBuilder::TriangulateBetween(std::size_t first_position, std::size_t second_position) {
  FrameRecord& first = open_.frames[first_position];
  FrameRecord& second = open_.frames[second_position];
  const Camera camera = CurrentCamera();

  // Features already explaining an existing landmark are not triangulated again.
  std::unordered_set<int> used_first, used_second;
  for (const auto& m : first.landmark_matches) used_first.insert(m.first);
  for (const auto& m : second.landmark_matches) used_second.insert(m.first);
  std::vector<int> rows_first, rows_second;
  for (int i = 0; i < static_cast<int>(first.features.size()); ++i)
    if (!used_first.count(i)) rows_first.push_back(i);
  for (int i = 0; i < static_cast<int>(second.features.size()); ++i)
    if (!used_second.count(i)) rows_second.push_back(i);
  if (rows_first.size() < 8 || rows_second.size() < 8) return 0;

  // Normalised image coordinates of the unmatched features, for matching and triangulation.
  const auto normalised = [&](const FrameRecord& frame, const std::vector<int>& rows) {
    std::vector<Eigen::Vector2d> out;
    out.reserve(rows.size());
    for (int r : rows) out.push_back(camera.Unproject(frame.features.points[r].cast<double>()).head<2>());
    return out;
  };
  const std::vector<Eigen::Vector2d> first_rays = normalised(first, rows_first);
  const std::vector<Eigen::Vector2d> second_rays = normalised(second, rows_second);
  const std::vector<Match> matches = MatchForTriangulation(first, rows_first, first_rays, second, rows_second, second_rays);
  GLAM_LOG_TRACE("keyframe pair {}-{}: {} unmatched x {} unmatched features, {} matches", first.index,
                 second.index, rows_first.size(), rows_second.size(), matches.size());
  if (matches.size() < 8) return 0;
  std::vector<TwoViewCorrespondence> rays;
  for (const Match& m : matches) rays.push_back({first_rays[m.train], second_rays[m.query]});

  // Triangulated with the two PnP poses (not the essential matrix's relative pose).
  const SE3 poses[2] = {*first.cam_from_submap, *second.cam_from_submap};
  const Eigen::Vector3d centre_first = CameraCenter(poses[0]);
  TriangulationOptions tri_options;
  tri_options.min_angle_deg = options_.min_triangulation_angle_deg;
  tri_options.max_error_px = options_.max_new_point_reprojection_pixels;
  tri_options.focal_px = camera.intrinsics().fx;

  struct NewPoint {
    int feature_first, feature_second;
    Eigen::Vector3d point;
  };
  std::vector<NewPoint> candidates;
  int status_counts[6] = {0, 0, 0, 0, 0, 0};
  for (std::size_t i = 0; i < matches.size(); ++i) {
    const Eigen::Vector2d obs[2] = {rays[i].x1, rays[i].x2};
    const Triangulation t = Triangulate(poses, obs, tri_options);
    ++status_counts[static_cast<int>(t.status)];
    if (!t.ok()) continue;
    candidates.push_back({rows_first[matches[i].train], rows_second[matches[i].query], t.point});
  }
  GLAM_LOG_TRACE("triangulation: ok {}, degenerate {}, small angle {}, behind {}, large error {}",
                 status_counts[0], status_counts[2], status_counts[3], status_counts[4], status_counts[5]);
  if (candidates.empty()) return 0;

  // Duplicate removal: a new landmark whose descriptor matches an existing one is dropped
  // (SubmapOptions::duplicate_check_in_view: only the existing landmarks in the first frame's
  // view are compared).
  std::vector<bool> duplicate(candidates.size(), false);
  std::vector<int> existing_rows;
  for (std::size_t l = 0; l < open_.landmarks.size(); ++l) {
    Eigen::Vector2d px;
    if (!options_.duplicate_check_in_view ||
        (camera.Project(poses[0] * open_.landmarks[l].point_in_submap, &px) && camera.InImage(px))) {
      existing_rows.push_back(static_cast<int>(l));
    }
  }
  if (!existing_rows.empty()) {
    std::vector<int> candidate_rows;
    for (const NewPoint& c : candidates) candidate_rows.push_back(c.feature_first);
    const cv::Mat existing = LandmarkDescriptorMatrix(open_.landmarks, existing_rows);
    MatchOptions dup_options;
    dup_options.ratio = static_cast<float>(options_.match_ratio);
    for (const Match& m : MatchDescriptors(first.features.FloatDescriptors(candidate_rows), existing, dup_options)) {
      duplicate[m.query] = true;
    }
  }

  const auto kf_first = static_cast<std::uint32_t>(open_.keyframes.size() - 1);  // middle (or previous) keyframe
  const auto kf_second = static_cast<std::uint32_t>(open_.keyframes.size());     // current, added next
  (void)kf_second;
  std::size_t added = 0;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    if (duplicate[i]) continue;
    const NewPoint& c = candidates[i];
    Landmark lm;
    lm.id = open_.next_landmark_id++;
    lm.point_in_submap = c.point;
    lm.descriptor = first.features.descriptors[c.feature_first];
    lm.color = first.features.colors[c.feature_first];
    // The first frame's keyframe already exists: observe directly. The second frame's
    // observation is added by AddKeyframe through its landmark_matches.
    const bool first_is_keyframe = open_.keyframe_frame_positions.back() == first_position;
    if (first_is_keyframe) {
      lm.observations.push_back({kf_first, first.features.points[c.feature_first]});
    }
    first.landmark_matches.emplace_back(c.feature_first, lm.id);
    second.landmark_matches.emplace_back(c.feature_second, lm.id);
    open_.extras[lm.id] = {(c.point - centre_first).normalized()};
    open_.landmarks.push_back(std::move(lm));
    ++added;
  }
  GLAM_LOG_DEBUG("triangulated {} new landmarks between frames {} and {} ({} duplicates)", added,
                 first.index, second.index, std::count(duplicate.begin(), duplicate.end(), true));
  return added;
}

void SubmapBuilder::RemoveMovingLandmarks() {
  if (open_.moving_landmarks.empty()) return;
  const std::size_t before = open_.landmarks.size();
  std::erase_if(open_.landmarks, [&](const Landmark& lm) { return open_.moving_landmarks.contains(lm.id); });
  for (std::uint32_t id : open_.moving_landmarks) {
    open_.rejections.erase(id);
    open_.extras.erase(id);
  }
  open_.moving_landmarks.clear();
  stats_.moving_landmarks_removed += static_cast<std::int64_t>(before - open_.landmarks.size());
  GLAM_LOG_DEBUG("removed {} landmarks on moving content", before - open_.landmarks.size());
}

void SubmapBuilder::OptimiseAndFilter() {
  RemoveMovingLandmarks();
  BundleAdjustmentOptions ba = options_.bundle_adjustment;
  ba.focal_prior_px = focal_;  // the running median (see BundleAdjustmentOptions)
  // Local only with the camera fixed: a focal or k1 still being estimated couples every
  // keyframe, and held poses from before its last change would pull it back.
  if (!ba.refine_focal && !ba.refine_k1) ba.local_keyframes = options_.local_ba_keyframes;
  // What completed submaps agreed on weighs more with every keyframe they had (k1 likewise;
  // its prior is centred on the running estimate k1_).
  const double prior_growth =
      1.0 + options_.focal_prior_growth * static_cast<double>(completed_keyframe_focals_.size());
  ba.focal_prior_weight *= prior_growth;
  ba.k1_prior_weight *= prior_growth;
  const auto summary = BundleAdjust(CurrentCamera().intrinsics(), open_.keyframes, open_.landmarks, ba, cancel_);
  stats_.bundle_adjust_seconds += summary.seconds;
  open_.last_ba_rms = summary.final_rms_pixels;
  k1_ = summary.k1;
  RemoveReprojectionOutliers(CurrentCamera().intrinsics(), open_.keyframes, open_.landmarks,
                             options_.outlier_filter);
  // Each landmark meets filter 2 once, at the first adjustment after it was triangulated
  // (SubmapOptions::isolated_filter_once); the statistic still covers all landmarks.
  RemoveIsolatedLandmarks(open_.landmarks, options_.outlier_filter,
                          options_.isolated_filter_once ? open_.first_unfiltered_landmark_id : 0);
  open_.first_unfiltered_landmark_id = open_.next_landmark_id;
  // Keyframe frames take their refined poses (tracking continues from them).
  for (std::size_t k = 0; k < open_.keyframes.size(); ++k) {
    open_.frames[open_.keyframe_frame_positions[k]].cam_from_submap = open_.keyframes[k].cam_from_submap;
  }
  UpdateFocalEstimate();
}

void SubmapBuilder::UpdateFocalEstimate() {
  // Median over the keyframes of completed submaps and the open one's current estimates.
  std::vector<double> focals = completed_keyframe_focals_;
  for (const Keyframe& kf : open_.keyframes) focals.push_back(kf.focal);
  if (focals.empty()) return;
  focal_ = UpperMedian(std::move(focals));
}

}  // namespace glam
