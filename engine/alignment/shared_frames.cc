#include "engine/alignment/shared_frames.h"

#include <algorithm>
#include <array>
#include <unordered_map>
#include <utility>

#include "engine/alignment/submap_verifier.h"
#include "engine/core/camera.h"
#include "engine/core/error.h"
#include "engine/core/median.h"
#include "engine/core/options.h"
#include "engine/core/similarity_alignment.h"
#include "engine/features/feature_grid.h"

namespace glam {

void SharedFrameOptions::Check() const {
  CheckGreater("SharedFrameOptions.max_disagreement_fraction", max_disagreement_fraction, 0.0);
}

namespace {

// A frame posed in both submaps (a = reference, b = query), in query order.
struct SharedFrame {
  std::int64_t frame_index = 0;
  SE3 a_from_cam;  // reference submap_from_cam
  SE3 b_from_cam;  // query submap_from_cam
};

std::vector<SharedFrame> SharedFrames(const Submap& reference, const Submap& query) {
  std::unordered_map<std::int64_t, const FramePose*> in_reference;
  for (const FramePose& pose : reference.frame_poses) in_reference[pose.frame_index] = &pose;
  std::vector<SharedFrame> out;
  for (const FramePose& pose : query.frame_poses) {
    const auto it = in_reference.find(pose.frame_index);
    if (it != in_reference.end()) {
      out.push_back({pose.frame_index, it->second->cam_from_submap.Inverse(), pose.cam_from_submap.Inverse()});
    }
  }
  return out;
}

}  // namespace

std::vector<LandmarkMatch> SharedFrameMatches(const Submap& reference, const Submap& query,
                                              const Sim3& reference_from_query,
                                              const SharedFrameOptions& options) {
  options.Check();
  std::vector<LandmarkMatch> out;
  if (query.first_frame > reference.last_frame || reference_from_query.scale() <= 0) return out;
  const double depth_a = SubmapDepthScale(reference);
  const double depth_b = depth_a / reference_from_query.scale();
  const double max_error = options.max_disagreement_fraction * depth_a;
  for (const SharedFrame& frame : SharedFrames(reference, query)) {
    if (frame.frame_index < 0 || frame.frame_index >= kMaxSharedFrameIndex) continue;
    const auto id = kSharedFrameIdBase + 2 * static_cast<std::uint32_t>(frame.frame_index);
    const SE3& submap_a_from_cam = frame.a_from_cam;
    const SE3& submap_b_from_cam = frame.b_from_cam;
    const Eigen::Vector3d centre_a = submap_a_from_cam.translation();
    const Eigen::Vector3d centre_b = submap_b_from_cam.translation();
    const Eigen::Vector3d ahead_a = submap_a_from_cam * Eigen::Vector3d(0, 0, depth_a);
    const Eigen::Vector3d ahead_b = submap_b_from_cam * Eigen::Vector3d(0, 0, depth_b);
    if ((reference_from_query * centre_b - centre_a).norm() > max_error ||
        (reference_from_query * ahead_b - ahead_a).norm() > max_error) {
      continue;
    }
    out.push_back({id, id, centre_a, centre_b});
    out.push_back({id + 1, id + 1, ahead_a, ahead_b});
  }
  return out;
}

namespace {

// The points a shared frame pins in a submap (submap_from_cam, the depth ahead in that
// submap's units): its centre, the point one depth ahead on the optical axis and the point
// beside that along the image x axis. Three points fix the frame's whole orientation: the
// camera's rotation is known far better than its position, so each frame on its own gives
// the rotation between the submaps, including the yaw that centres along a short path leave
// loose.
std::array<Eigen::Vector3d, 3> FramePoints(const SE3& submap_from_cam, double depth) {
  return {submap_from_cam.translation(), submap_from_cam * Eigen::Vector3d(0, 0, depth),
          submap_from_cam * Eigen::Vector3d(depth, 0, depth)};
}

// Umeyama fit of the FramePoints of the frames with used[i] (depth_a in the reference,
// depth_a / scale in the query); with fixed_scale the similarity keeps `scale` and fits rotation
// and translation only. Unset when degenerate.
std::optional<SimilarityAlignmentResult> FitSharedFrames(const std::vector<SharedFrame>& shared,
                                                         const std::vector<char>& used, double depth_a,
                                                         double scale, bool fixed_scale) {
  std::vector<Eigen::Vector3d> source, target;
  const double pre_scale = fixed_scale ? scale : 1.0;
  for (std::size_t i = 0; i < shared.size(); ++i) {
    if (!used[i]) continue;
    for (const Eigen::Vector3d& p : FramePoints(shared[i].a_from_cam, depth_a)) target.push_back(p);
    for (const Eigen::Vector3d& p : FramePoints(shared[i].b_from_cam, depth_a / scale)) source.push_back(pre_scale * p);
  }
  if (source.size() < 3) return std::nullopt;
  try {
    SimilarityAlignmentResult fit = AlignSimilarity(source, target, !fixed_scale);
    if (fixed_scale) {
      const Sim3& rigid = fit.target_from_source;
      fit.target_from_source = Sim3(scale, rigid.rotation(), rigid.translation());
    }
    return fit;
  } catch (const InputError&) {
    return std::nullopt;
  }
}

// How far `a_from_b` misses frame i's points (the largest of the three).
double FrameError(const SharedFrame& frame, const Sim3& a_from_b, double depth_a) {
  const auto a = FramePoints(frame.a_from_cam, depth_a);
  const auto b = FramePoints(frame.b_from_cam, depth_a / a_from_b.scale());
  double worst = 0;
  for (std::size_t k = 0; k < a.size(); ++k) worst = std::max(worst, (a_from_b * b[k] - a[k]).norm());
  return worst;
}

// Landmarks of `submap` seen from a camera (cam_from_submap) inside its image: pixel and depth.
struct ProjectedLandmark {
  Eigen::Vector2d pixel;
  double depth = 0;
};
std::vector<ProjectedLandmark> ProjectLandmarks(const Submap& submap, const SE3& cam_from_submap) {
  const Camera camera(submap.intrinsics);
  std::vector<ProjectedLandmark> out;
  for (const Landmark& lm : submap.landmarks) {
    const Eigen::Vector3d p = cam_from_submap * lm.point_in_submap;
    ProjectedLandmark projected;
    if (!camera.Project(p, &projected.pixel) || projected.pixel.x() < 0 || projected.pixel.y() < 0 ||
        projected.pixel.x() >= submap.intrinsics.width || projected.pixel.y() >= submap.intrinsics.height) {
      continue;
    }
    projected.depth = p.z();
    out.push_back(projected);
  }
  return out;
}

// Reference units per query unit, from depths of the same image points: in a shared frame, a
// query landmark that projects within kRadiusPx of a reference landmark lies on (nearly) the
// same ray, so the ratio of their depths is the scale between the two submaps. The median over
// such pairs of up to kMaxFrames shared frames; unset with fewer than kMinPairs. Unlike the
// camera centres, whose spread over the few shared frames is short and noisy (1-2 % scale
// error measured on the loop fixture), every pair measures the full viewing depth.
std::optional<double> DepthRatioScale(const Submap& reference, const Submap& query,
                                      const std::vector<SharedFrame>& shared) {
  constexpr double kRadiusPx = 2.0;
  constexpr std::size_t kMaxFrames = 8;
  constexpr std::size_t kMinPairs = 20;
  if (reference.intrinsics.width <= 0 || query.intrinsics.width <= 0) return std::nullopt;
  std::vector<double> ratios;
  const std::size_t step = std::max<std::size_t>(1, shared.size() / kMaxFrames);
  for (std::size_t i = 0; i < shared.size(); i += step) {
    const std::vector<ProjectedLandmark> a = ProjectLandmarks(reference, shared[i].a_from_cam.Inverse());
    const std::vector<ProjectedLandmark> b = ProjectLandmarks(query, shared[i].b_from_cam.Inverse());
    std::vector<Eigen::Vector2d> a_pixels;
    a_pixels.reserve(a.size());
    for (const ProjectedLandmark& p : a) a_pixels.push_back(p.pixel);
    const FeatureGrid grid(a_pixels, reference.intrinsics.width, reference.intrinsics.height, kRadiusPx);
    std::vector<int> near;
    for (const ProjectedLandmark& q : b) {
      near.clear();
      grid.Query(q.pixel, kRadiusPx, &near);
      const ProjectedLandmark* best = nullptr;
      double best_distance = kRadiusPx;
      for (const int k : near) {
        const double d = (grid.point(k) - q.pixel).norm();
        if (d < best_distance) best_distance = d, best = &a[static_cast<std::size_t>(k)];
      }
      if (best != nullptr) ratios.push_back(best->depth / q.depth);
    }
  }
  if (ratios.size() < kMinPairs) return std::nullopt;
  return UpperMedian(std::move(ratios));
}

}  // namespace

std::optional<Sim3> EstimateFromSharedFrames(const Submap& reference, const Submap& query,
                                             const SharedFrameOptions& options) {
  options.Check();
  const std::vector<SharedFrame> shared = SharedFrames(reference, query);
  if (shared.size() < 2) return std::nullopt;
  const double depth_a = SubmapDepthScale(reference);
  const double max_error = options.max_disagreement_fraction * depth_a;
  // The scale from the depths of shared image points when they give it; otherwise fitted, from
  // the ratio of the submaps' depth scales on.
  const std::optional<double> depth_ratio = DepthRatioScale(reference, query, shared);
  const bool fixed_scale = depth_ratio.has_value();
  double scale = depth_ratio.value_or(depth_a / SubmapDepthScale(query));
  // Frames agree or not with the fit of every pair of frames (a badly posed frame drags a fit of
  // all of them off); the largest agreeing set is fitted again.
  std::vector<char> best;
  std::size_t best_count = 0;
  const std::size_t step = std::max<std::size_t>(1, shared.size() / 12);  // <= ~66 pairs
  for (std::size_t i = 0; i < shared.size(); i += step) {
    for (std::size_t j = i + step; j < shared.size(); j += step) {
      std::vector<char> pair(shared.size(), 0);
      pair[i] = pair[j] = 1;
      const std::optional<SimilarityAlignmentResult> fit = FitSharedFrames(shared, pair, depth_a, scale, fixed_scale);
      if (!fit) continue;
      std::vector<char> agree(shared.size(), 0);
      std::size_t count = 0;
      for (std::size_t k = 0; k < shared.size(); ++k) {
        agree[k] = FrameError(shared[k], fit->target_from_source, depth_a) <= max_error;
        count += agree[k];
      }
      if (count > best_count) best_count = count, best = std::move(agree);
    }
  }
  if (best_count < 2) return std::nullopt;
  std::optional<SimilarityAlignmentResult> fit;
  for (int pass = 0; pass < (fixed_scale ? 1 : 3); ++pass) {  // the query's depth follows the scale
    fit = FitSharedFrames(shared, best, depth_a, scale, fixed_scale);
    if (!fit) return std::nullopt;
    scale = fit->target_from_source.scale();
  }
  if (fit->rmse > max_error) return std::nullopt;
  return fit->target_from_source;
}

}  // namespace glam
