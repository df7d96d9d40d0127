#include "engine/alignment/global_refinement.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <unordered_map>
#include <utility>

#include "engine/core/camera.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/core/median.h"
#include "engine/core/options.h"
#include "engine/core/placed_pose.h"
#include "engine/geometry/triangulation.h"

namespace glam {
namespace {

// Where a landmark of the joint problem came from: submap (index into `submaps`) and the
// landmark's index in that submap's vector.
struct Member {
  std::size_t submap = 0;
  std::size_t landmark = 0;
};

bool SameLensModel(const Intrinsics& a, const Intrinsics& b) {
  return a.cx == b.cx && a.cy == b.cy && a.k1 == b.k1 && a.k2 == b.k2 &&
         a.fy / a.fx == b.fy / b.fx;
}

// A pixel observed through `from` re-expressed through `to` (same focal `focal`): the same
// ray, so the joint adjustment can use one lens model for submaps whose k1 differ slightly.
Eigen::Vector2f RemapPixel(const Intrinsics& from, const Intrinsics& to, double focal,
                           const Eigen::Vector2f& pixel) {
  const Eigen::Vector3d ray = Camera(from.WithFocal(focal)).Unproject(pixel.cast<double>());
  Eigen::Vector2d out;
  Camera(to.WithFocal(focal)).Project(ray, &out);
  return out.cast<float>();
}

// The rigid correction of a frame between two keyframes of one submap: the keyframes'
// corrections interpolated on SE(3) by frame index.
SE3 Interpolate(const SE3& a, const SE3& b, double weight) {
  return a * SE3::Exp(weight * (a.Inverse() * b).Log());
}

void ApplyToSubmap(Submap& submap, const Sim3& world_from_submap,
                   const std::vector<SE3>& keyframe_cam_from_world) {
  // submap_from_cam_new * cam_from_submap_old per keyframe, ordered by frame index.
  std::vector<std::pair<std::int64_t, SE3>> corrections;
  for (std::size_t k = 0; k < submap.keyframes.size(); ++k) {
    Keyframe& keyframe = submap.keyframes[k];
    const SE3 refined = CamFromSubmap(world_from_submap, keyframe_cam_from_world[k]);
    corrections.emplace_back(keyframe.frame_index, refined.Inverse() * keyframe.cam_from_submap);
    keyframe.cam_from_submap = refined;
  }
  std::sort(corrections.begin(), corrections.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  if (corrections.empty()) return;
  for (FramePose& pose : submap.frame_poses) {
    const auto after = std::lower_bound(
        corrections.begin(), corrections.end(), pose.frame_index,
        [](const auto& correction, std::int64_t frame) { return correction.first < frame; });
    SE3 correction;
    if (after == corrections.begin()) {
      correction = after->second;
    } else if (after == corrections.end()) {
      correction = corrections.back().second;
    } else {
      const auto before = after - 1;
      const double weight = static_cast<double>(pose.frame_index - before->first) /
                            static_cast<double>(after->first - before->first);
      correction = Interpolate(before->second, after->second, weight);
    }
    // submap_from_cam_new = correction * submap_from_cam_old.
    pose.cam_from_submap = pose.cam_from_submap * correction.Inverse();
  }
}

// The whole map as one bundle adjustment problem in the world frame: cameras (one per video
// frame that is a keyframe of any submap) and points (one per landmark group matched across
// submaps, one per other landmark), and what to write back where.
class JointProblem {
 public:
  JointProblem(const std::vector<Submap>& submaps, const std::vector<Sim3>& world_from_submap,
               const std::vector<std::vector<LandmarkKey>>& groups)
      : submaps_(submaps), world_from_submap_(world_from_submap), lens_(submaps.front().intrinsics) {
    AddCameras();
    GroupMembers(groups);
    BuildPoints();
  }

  // Bundle adjustment with the adjuster's gauge (first camera fixed, scale through the largest
  // coordinate of the second camera's translation), which assumes the first camera at the
  // origin: with it elsewhere, that coordinate can stay fixed while the map scales about the
  // first camera. So the adjustment runs in the first camera's frame and is moved back.
  BundleAdjustmentSummary Adjust(const BundleAdjustmentOptions& options, const CancellationToken& cancel) {
    const SE3 first_from_world = cameras_.front().cam_from_submap;
    const SE3 world_from_first = first_from_world.Inverse();
    for (Keyframe& camera : cameras_) camera.cam_from_submap = camera.cam_from_submap * world_from_first;
    for (Landmark& point : points_) point.point_in_submap = first_from_world * point.point_in_submap;
    const BundleAdjustmentSummary result = BundleAdjust(lens_, cameras_, points_, options, cancel);
    for (Keyframe& camera : cameras_) camera.cam_from_submap = camera.cam_from_submap * first_from_world;
    for (Landmark& point : points_) point.point_in_submap = world_from_first * point.point_in_submap;
    return result;
  }

  // A join the adjusted map cannot explain (a member's observations reproject worse than
  // `max_error_px`, rms) was a wrong match: its members become points of their own again, at
  // their placed positions. Returns how many joins were undone.
  int SplitInconsistentJoins(double max_error_px) {
    int undone = 0;
    std::vector<std::vector<Member>> split;
    for (std::size_t p = 0; p < points_.size(); ++p) {
      std::vector<Member>& members = members_of_point_[p];
      if (members.size() < 2) continue;
      const bool consistent = std::all_of(members.begin(), members.end(), [&](const Member& m) {
        return MemberRmsError(m, points_[p].point_in_submap) <= max_error_px;
      });
      if (consistent) continue;
      ++undone;
      for (std::size_t k = 1; k < members.size(); ++k) split.push_back({members[k]});
      members.resize(1);
    }
    if (undone > 0) {
      members_of_point_.insert(members_of_point_.end(), split.begin(), split.end());
      BuildPoints();
    }
    return undone;
  }

  // The median depth of the points in the cameras that observe them (every 7th point).
  double MedianDepth() const {
    std::vector<double> depths;
    for (std::size_t p = 0; p < points_.size(); p += 7) {
      for (const Observation& o : points_[p].observations) {
        depths.push_back((cameras_[o.keyframe].cam_from_submap * points_[p].point_in_submap).z());
      }
    }
    return depths.empty() ? 0.0 : UpperMedian(std::move(depths));
  }

  std::vector<Eigen::Vector3d> CameraCentres() const {
    std::vector<Eigen::Vector3d> centres;
    for (const Keyframe& camera : cameras_) centres.push_back(CameraCenter(camera.cam_from_submap));
    return centres;
  }

  // Into each submap's own frame, under its unchanged placement.
  void WriteBack(std::vector<Submap>& submaps) const {
    for (std::size_t i = 0; i < submaps.size(); ++i) {
      std::vector<SE3> cam_from_world;
      for (std::size_t camera : camera_of_keyframe_[i]) cam_from_world.push_back(cameras_[camera].cam_from_submap);
      ApplyToSubmap(submaps[i], world_from_submap_[i], cam_from_world);
    }
    for (std::size_t p = 0; p < points_.size(); ++p) {
      for (const Member& m : members_of_point_[p]) {
        submaps[m.submap].landmarks[m.landmark].point_in_submap =
            world_from_submap_[m.submap].Inverse() * points_[p].point_in_submap;
      }
    }
  }

  void Summarise(GlobalRefinementSummary* summary) const {
    summary->keyframes = static_cast<int>(cameras_.size());
    summary->shared_keyframes = shared_keyframes_;
    summary->landmarks = static_cast<int>(points_.size());
    summary->joined_landmarks = 0;
    for (const auto& members : members_of_point_) summary->joined_landmarks += members.size() > 1 ? 1 : 0;
    summary->observations = 0;
    for (const Landmark& point : points_) summary->observations += static_cast<int>(point.observations.size());
  }

 private:
  // The overlap hand-off gives some frames a keyframe in two submaps: one camera, starting at
  // the first submap's pose of it.
  void AddCameras() {
    std::map<std::int64_t, std::size_t> camera_of_frame;
    camera_of_keyframe_.resize(submaps_.size());
    for (std::size_t i = 0; i < submaps_.size(); ++i) {
      for (const Keyframe& keyframe : submaps_[i].keyframes) {
        const auto [it, inserted] = camera_of_frame.emplace(keyframe.frame_index, cameras_.size());
        if (inserted) {
          Keyframe camera = keyframe;
          camera.cam_from_submap = CamFromWorld(world_from_submap_[i], keyframe.cam_from_submap);
          cameras_.push_back(camera);
        } else {
          ++shared_keyframes_;
        }
        camera_of_keyframe_[i].push_back(it->second);
      }
    }
  }

  // members_of_point_: one entry per group (its members in these submaps), then one per
  // landmark in no group.
  void GroupMembers(const std::vector<std::vector<LandmarkKey>>& groups) {
    std::map<std::uint32_t, std::size_t> submap_index;
    std::vector<std::unordered_map<std::uint32_t, std::size_t>> index_of_id(submaps_.size());
    std::vector<std::vector<bool>> grouped(submaps_.size());
    for (std::size_t i = 0; i < submaps_.size(); ++i) {
      submap_index[submaps_[i].id] = i;
      grouped[i].assign(submaps_[i].landmarks.size(), false);
      for (std::size_t l = 0; l < submaps_[i].landmarks.size(); ++l) index_of_id[i][submaps_[i].landmarks[l].id] = l;
    }
    for (const std::vector<LandmarkKey>& group : groups) {
      std::vector<Member> members;
      for (const LandmarkKey& key : group) {
        const auto s = submap_index.find(key.submap);
        if (s == submap_index.end()) continue;
        const auto l = index_of_id[s->second].find(key.landmark);
        if (l == index_of_id[s->second].end() || grouped[s->second][l->second]) continue;
        grouped[s->second][l->second] = true;
        members.push_back({s->second, l->second});
      }
      if (!members.empty()) members_of_point_.push_back(std::move(members));
    }
    for (std::size_t i = 0; i < submaps_.size(); ++i) {
      for (std::size_t l = 0; l < submaps_[i].landmarks.size(); ++l) {
        if (!grouped[i][l]) members_of_point_.push_back({{i, l}});
      }
    }
  }

  // A member's observations as joint-problem observations: camera indices, and pixels seen
  // through the joint lens (a submap whose k1 differs slightly is re-expressed).
  std::vector<Observation> ObservationsOf(const Member& m) const {
    const Submap& submap = submaps_[m.submap];
    const bool same_lens = SameLensModel(submap.intrinsics, lens_);
    std::vector<Observation> out;
    for (const Observation& o : submap.landmarks[m.landmark].observations) {
      const Eigen::Vector2f pixel =
          same_lens ? o.pixel : RemapPixel(submap.intrinsics, lens_, submap.keyframes[o.keyframe].focal, o.pixel);
      out.push_back({static_cast<std::uint32_t>(camera_of_keyframe_[m.submap][o.keyframe]), pixel});
    }
    return out;
  }

  double MemberRmsError(const Member& m, const Eigen::Vector3d& point_in_world) const {
    const std::vector<Observation> seen = ObservationsOf(m);
    double squared = 0;
    for (const Observation& o : seen) {
      const double e = ReprojectionError(lens_, cameras_[o.keyframe], point_in_world, o.pixel);
      squared += e * e;
    }
    return seen.empty() ? 0.0 : std::sqrt(squared / static_cast<double>(seen.size()));
  }

  // Each point: its members' observations (one per camera: a joined keyframe saw it in both
  // submaps) at the mean of their positions as the map placed them.
  void BuildPoints() {
    points_.clear();
    points_.reserve(members_of_point_.size());
    for (const std::vector<Member>& members : members_of_point_) {
      Landmark point;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (const Member& m : members) {
        sum += world_from_submap_[m.submap] * submaps_[m.submap].landmarks[m.landmark].point_in_submap;
        for (const Observation& o : ObservationsOf(m)) {
          const bool seen = std::any_of(point.observations.begin(), point.observations.end(),
                                        [&o](const Observation& p) { return p.keyframe == o.keyframe; });
          if (!seen) point.observations.push_back(o);
        }
      }
      point.point_in_submap = sum / static_cast<double>(members.size());
      points_.push_back(std::move(point));
    }
  }

  const std::vector<Submap>& submaps_;
  const std::vector<Sim3>& world_from_submap_;
  const Intrinsics lens_;  // the first submap's: cx, cy, k1, k2, aspect (focal per keyframe)
  std::vector<Keyframe> cameras_;                       // cam_from_submap holds cam_from_world
  std::vector<std::vector<std::size_t>> camera_of_keyframe_;  // [submap][keyframe] -> camera
  int shared_keyframes_ = 0;
  std::vector<std::vector<Member>> members_of_point_;
  std::vector<Landmark> points_;  // point_in_submap holds point_in_world
};

}  // namespace

BundleAdjustmentOptions GlobalRefinementOptions::DefaultBundleAdjustment() {
  BundleAdjustmentOptions options;
  options.max_iterations = 10;
  options.refine_focal = false;
  options.refine_k1 = false;
  options.fixed_keyframes = 1;
  options.fix_scale = true;
  // It runs after the input has ended, when the decoding and feature threads are done: both
  // cores of the reference machine are free (loop benchmark video: 2.75 s -> 2.1-2.2 s, the
  // same map; the sparse Cholesky of the reduced system stays single-threaded).
  options.num_threads = 2;
  return options;
}

void GlobalRefinementOptions::Check() const {
  CheckGreaterEqual("GlobalRefinementOptions.max_keyframes", max_keyframes, 0);
  CheckGreater("GlobalRefinementOptions.max_camera_shift_fraction", max_camera_shift_fraction, 0.0);
  CheckGreater("GlobalRefinementOptions.max_joined_error_px", max_joined_error_px, 0.0);
  bundle_adjustment.Check();
  if (bundle_adjustment.refine_focal || bundle_adjustment.refine_k1 ||
      bundle_adjustment.fixed_keyframes < 1 || !bundle_adjustment.fix_scale) {
    throw InputError(
        "GlobalRefinementOptions.bundle_adjustment must keep focal, k1, the first keyframe and "
        "the scale fixed (the world frame and the camera are settled by then)");
  }
}

GlobalRefinementSummary RefineMapJointly(std::vector<Submap>& submaps,
                                         const std::vector<Sim3>& world_from_submap,
                                         const std::vector<std::vector<LandmarkKey>>& groups,
                                         const GlobalRefinementOptions& options,
                                         const CancellationToken& cancel) {
  options.Check();
  GLAM_CHECK(submaps.size() == world_from_submap.size(), "{} submaps but {} placements",
             submaps.size(), world_from_submap.size());
  const auto start = std::chrono::steady_clock::now();
  const auto elapsed = [&start] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  GlobalRefinementSummary summary;
  summary.submaps = static_cast<int>(submaps.size());
  std::size_t total_keyframes = 0;
  for (const Submap& submap : submaps) total_keyframes += submap.keyframes.size();
  if (options.max_keyframes == 0) {
    summary.reason = "off";
    return summary;
  }
  if (submaps.size() < 2) {
    summary.reason = "the map is one submap (its own bundle adjustment covered it)";
    return summary;
  }
  if (total_keyframes > static_cast<std::size_t>(options.max_keyframes)) {
    summary.reason = fmt::format("{} keyframes, above the limit of {}", total_keyframes,
                                 options.max_keyframes);
    return summary;
  }

  JointProblem problem(submaps, world_from_submap, groups);
  const double depth = problem.MedianDepth();
  const std::vector<Eigen::Vector3d> centres_before = problem.CameraCentres();
  summary.ran = true;
  BundleAdjustmentSummary ba = problem.Adjust(options.bundle_adjustment, cancel);
  // Undone joins: adjusted once more, from where the first pass left the cameras.
  summary.split_landmarks = problem.SplitInconsistentJoins(options.max_joined_error_px);
  if (summary.split_landmarks > 0) {
    const double initial_rms = ba.initial_rms_pixels;
    ba = problem.Adjust(options.bundle_adjustment, cancel);
    ba.initial_rms_pixels = initial_rms;
  }
  problem.Summarise(&summary);
  summary.initial_rms_pixels = ba.initial_rms_pixels;
  summary.final_rms_pixels = ba.final_rms_pixels;
  summary.iterations = ba.iterations;
  const std::vector<Eigen::Vector3d> centres_after = problem.CameraCentres();
  for (std::size_t c = 0; c < centres_after.size(); ++c) {
    summary.max_camera_shift = std::max(summary.max_camera_shift, (centres_after[c] - centres_before[c]).norm());
  }
  summary.seconds = elapsed();

  if (!std::isfinite(ba.final_rms_pixels) || ba.final_rms_pixels > ba.initial_rms_pixels * 1.001 + 1e-6) {
    summary.reason = fmt::format("the adjustment did not lower the reprojection error ({:.3f} -> {:.3f} px)",
                                 ba.initial_rms_pixels, ba.final_rms_pixels);
    return summary;
  }
  if (depth > 0 && summary.max_camera_shift > options.max_camera_shift_fraction * depth) {
    summary.reason = fmt::format("a camera moved {:.3g} (median depth {:.3g}): not applied",
                                 summary.max_camera_shift, depth);
    return summary;
  }
  problem.WriteBack(submaps);
  summary.applied = true;
  summary.seconds = elapsed();
  return summary;
}

}  // namespace glam
