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

namespace glam {
namespace {

// Where a landmark of the joint problem came from: submap (index into `submaps`) and the
// landmark's index in that submap's vector.
struct Member {
  std::size_t submap = 0;
  std::size_t landmark = 0;
};

// cam_from_world of a keyframe posed in a submap placed by world_from_submap (a Sim3): the
// metric pose, with the submap's scale folded into the translation.
SE3 CamFromWorld(const SE3& cam_from_submap, const Sim3& world_from_submap) {
  const SO3 rotation = cam_from_submap.rotation() * world_from_submap.rotation().Inverse();
  return SE3(rotation, world_from_submap.scale() * cam_from_submap.translation() -
                           (rotation * world_from_submap.translation()));
}

// The inverse: cam_from_submap in the submap's own units.
SE3 CamFromSubmap(const SE3& cam_from_world, const Sim3& world_from_submap) {
  return SE3(cam_from_world.rotation() * world_from_submap.rotation(),
             (cam_from_world.rotation() * world_from_submap.translation() +
              cam_from_world.translation()) /
                 world_from_submap.scale());
}

Eigen::Vector3d CentreInWorld(const SE3& cam_from_world) {
  return -(cam_from_world.rotation().Inverse() * cam_from_world.translation());
}

bool SameLensModel(const Intrinsics& a, const Intrinsics& b) {
  return a.cx == b.cx && a.cy == b.cy && a.k1 == b.k1 && a.k2 == b.k2 &&
         a.fy / a.fx == b.fy / b.fx;
}

// A pixel observed through `from` re-expressed through `to` (same focal `focal`): the same
// ray, so the joint adjustment can use one lens model for submaps whose k1 differ slightly.
Eigen::Vector2f RemapPixel(const Intrinsics& from, const Intrinsics& to, double focal,
                           const Eigen::Vector2f& pixel) {
  const auto with_focal = [focal](Intrinsics intrinsics) {
    intrinsics.fy = focal * intrinsics.fy / intrinsics.fx;
    intrinsics.fx = focal;
    return intrinsics;
  };
  const Eigen::Vector3d ray = Camera(with_focal(from)).Unproject(pixel.cast<double>());
  Eigen::Vector2d out;
  Camera(with_focal(to)).Project(ray, &out);
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
    const SE3 refined = CamFromSubmap(keyframe_cam_from_world[k], world_from_submap);
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

}  // namespace

BundleAdjustmentOptions GlobalRefinementOptions::DefaultBundleAdjustment() {
  BundleAdjustmentOptions options;
  options.max_iterations = 10;
  options.refine_focal = false;
  options.refine_k1 = false;
  options.fixed_keyframes = 1;
  options.fix_scale = true;
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

  // Cameras: one per video frame that is a keyframe of any submap (the overlap hand-off gives
  // some frames a keyframe in two submaps; the first submap's pose starts the joint one).
  const Intrinsics& lens = submaps.front().intrinsics;
  std::vector<Keyframe> cameras;
  std::map<std::int64_t, std::size_t> camera_of_frame;
  std::vector<std::vector<std::size_t>> camera_of_keyframe(submaps.size());
  for (std::size_t i = 0; i < submaps.size(); ++i) {
    for (const Keyframe& keyframe : submaps[i].keyframes) {
      const auto [it, inserted] = camera_of_frame.emplace(keyframe.frame_index, cameras.size());
      if (inserted) {
        Keyframe camera = keyframe;
        camera.cam_from_submap = CamFromWorld(keyframe.cam_from_submap, world_from_submap[i]);
        cameras.push_back(camera);
      } else {
        ++summary.shared_keyframes;
      }
      camera_of_keyframe[i].push_back(it->second);
    }
  }

  // Points: one per cross-submap group, one per remaining landmark.
  std::vector<std::unordered_map<std::uint32_t, std::size_t>> index_of_id(submaps.size());
  std::map<std::uint32_t, std::size_t> submap_index;
  for (std::size_t i = 0; i < submaps.size(); ++i) {
    submap_index[submaps[i].id] = i;
    for (std::size_t l = 0; l < submaps[i].landmarks.size(); ++l) {
      index_of_id[i][submaps[i].landmarks[l].id] = l;
    }
  }
  std::vector<std::vector<Member>> members_of_point;
  std::vector<std::vector<bool>> grouped(submaps.size());
  for (std::size_t i = 0; i < submaps.size(); ++i) grouped[i].assign(submaps[i].landmarks.size(), false);
  for (const std::vector<LandmarkKey>& group : groups) {
    std::vector<Member> members;
    for (const LandmarkKey& key : group) {
      const auto s = submap_index.find(key.submap);
      if (s == submap_index.end()) continue;
      const auto l = index_of_id[s->second].find(key.landmark);
      if (l == index_of_id[s->second].end()) continue;
      if (grouped[s->second][l->second]) continue;
      grouped[s->second][l->second] = true;
      members.push_back({s->second, l->second});
    }
    if (!members.empty()) members_of_point.push_back(std::move(members));
  }
  for (std::size_t i = 0; i < submaps.size(); ++i) {
    for (std::size_t l = 0; l < submaps[i].landmarks.size(); ++l) {
      if (!grouped[i][l]) members_of_point.push_back({{i, l}});
    }
  }
  const auto observations_of = [&](const Member& m) {
    const Submap& submap = submaps[m.submap];
    std::vector<Observation> out;
    for (const Observation& o : submap.landmarks[m.landmark].observations) {
      Eigen::Vector2f pixel = o.pixel;
      if (!SameLensModel(submap.intrinsics, lens)) {
        pixel = RemapPixel(submap.intrinsics, lens, submap.keyframes[o.keyframe].focal, pixel);
      }
      out.push_back({static_cast<std::uint32_t>(camera_of_keyframe[m.submap][o.keyframe]), pixel});
    }
    return out;
  };
  // The joint point of `members`: their observations (one per camera: a joined keyframe saw
  // the point in both submaps) at the mean of their positions as the map placed them.
  const auto make_point = [&](const std::vector<Member>& members) {
    Landmark point;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const Member& m : members) {
      sum += world_from_submap[m.submap] * submaps[m.submap].landmarks[m.landmark].point_in_submap;
      for (const Observation& o : observations_of(m)) {
        const bool seen = std::any_of(point.observations.begin(), point.observations.end(),
                                      [&o](const Observation& p) { return p.keyframe == o.keyframe; });
        if (!seen) point.observations.push_back(o);
      }
    }
    point.point_in_submap = sum / static_cast<double>(members.size());
    return point;
  };
  const auto make_points = [&] {
    std::vector<Landmark> points;
    points.reserve(members_of_point.size());
    for (const auto& members : members_of_point) points.push_back(make_point(members));
    return points;
  };
  std::vector<Landmark> points = make_points();

  // The map's median viewing depth, the unit of the shift check.
  std::vector<double> depths;
  for (std::size_t p = 0; p < points.size(); p += 7) {
    for (const Observation& o : points[p].observations) {
      depths.push_back((cameras[o.keyframe].cam_from_submap * points[p].point_in_submap).z());
    }
  }
  const double depth = depths.empty() ? 0.0 : UpperMedian(depths);
  std::vector<Eigen::Vector3d> centres_before;
  for (const Keyframe& camera : cameras) centres_before.push_back(CentreInWorld(camera.cam_from_submap));

  // The bundle adjuster's gauge (first camera fixed, scale through the largest coordinate of
  // the second camera's translation) assumes the first camera at the origin: with it
  // elsewhere, that coordinate can stay fixed while the map scales about the first camera.
  // So the adjustment runs in the first camera's frame and the result is moved back.
  const SE3 first_from_world = cameras.front().cam_from_submap;
  const SE3 world_from_first = first_from_world.Inverse();
  const auto adjust = [&] {
    for (Keyframe& camera : cameras) camera.cam_from_submap = camera.cam_from_submap * world_from_first;
    for (Landmark& point : points) point.point_in_submap = first_from_world * point.point_in_submap;
    const BundleAdjustmentSummary result = BundleAdjust(lens, cameras, points, options.bundle_adjustment, cancel);
    for (Keyframe& camera : cameras) camera.cam_from_submap = camera.cam_from_submap * first_from_world;
    for (Landmark& point : points) point.point_in_submap = world_from_first * point.point_in_submap;
    return result;
  };
  summary.ran = true;
  BundleAdjustmentSummary ba = adjust();

  // A join the adjusted map cannot explain was a wrong match (the graph accepts matches within
  // 2 % of the viewing depth): its members become points of their own again, and the map is
  // adjusted once more from where the first pass left the cameras.
  std::vector<std::vector<Member>> split;
  for (std::size_t p = 0; p < points.size(); ++p) {
    if (members_of_point[p].size() < 2) continue;
    bool consistent = true;
    for (const Member& m : members_of_point[p]) {
      double squared = 0;
      const std::vector<Observation> seen = observations_of(m);
      for (const Observation& o : seen) {
        const double e = ReprojectionError(lens, cameras[o.keyframe], points[p].point_in_submap, o.pixel);
        squared += e * e;
      }
      if (std::sqrt(squared / static_cast<double>(seen.size())) > options.max_joined_error_px) consistent = false;
    }
    if (!consistent) {
      ++summary.split_landmarks;
      for (std::size_t k = 1; k < members_of_point[p].size(); ++k) split.push_back({members_of_point[p][k]});
      members_of_point[p].resize(1);
    }
  }
  if (!split.empty()) {
    members_of_point.insert(members_of_point.end(), split.begin(), split.end());
    const double initial_rms = ba.initial_rms_pixels;
    points = make_points();
    ba = adjust();
    ba.initial_rms_pixels = initial_rms;
  }
  for (const auto& members : members_of_point) summary.joined_landmarks += members.size() > 1 ? 1 : 0;
  summary.keyframes = static_cast<int>(cameras.size());
  summary.landmarks = static_cast<int>(points.size());
  for (const Landmark& point : points) summary.observations += static_cast<int>(point.observations.size());
  summary.initial_rms_pixels = ba.initial_rms_pixels;
  summary.final_rms_pixels = ba.final_rms_pixels;
  summary.iterations = ba.iterations;
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    summary.max_camera_shift = std::max(
        summary.max_camera_shift, (CentreInWorld(cameras[c].cam_from_submap) - centres_before[c]).norm());
  }
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

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

  for (std::size_t i = 0; i < submaps.size(); ++i) {
    std::vector<SE3> cam_from_world;
    for (std::size_t camera : camera_of_keyframe[i]) cam_from_world.push_back(cameras[camera].cam_from_submap);
    ApplyToSubmap(submaps[i], world_from_submap[i], cam_from_world);
  }
  for (std::size_t p = 0; p < points.size(); ++p) {
    for (const Member& m : members_of_point[p]) {
      submaps[m.submap].landmarks[m.landmark].point_in_submap =
          world_from_submap[m.submap].Inverse() * points[p].point_in_submap;
    }
  }
  summary.applied = true;
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace glam
