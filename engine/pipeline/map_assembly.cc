#include "engine/pipeline/map_assembly.h"

#include <chrono>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/export/tum_trajectory.h"

namespace glam {

SE3 WorldFromCam(const Sim3& world_from_submap, const SE3& cam_from_submap) {
  const SE3 submap_from_cam = cam_from_submap.Inverse();
  return SE3(world_from_submap.rotation() * submap_from_cam.rotation(),
             world_from_submap * submap_from_cam.translation());
}

MapAssembler::MapAssembler(const VerificationOptions& chaining, const LevelingOptions& leveling)
    : chaining_(chaining), leveling_(leveling) {}

void MapAssembler::Add(const Submap& submap) {
  const auto start = std::chrono::steady_clock::now();
  SubmapNode node;
  node.id = submap.id;
  node.first_frame = submap.first_frame;
  node.last_frame = submap.last_frame;
  node.frames = static_cast<std::int64_t>(submap.frame_poses.size());
  if (!previous_) {
    const LevelingResult level = LevelSubmap(submap, leveling_);
    node.world_from_submap = level.world_from_submap;
    GLAM_LOG_INFO("world frame = submap {} levelled ({} ground-plane inliers of {} landmarks)",
                  submap.id, level.plane_inliers, submap.landmarks.size());
  } else {
    const PairVerification link = VerifySubmapPair(*previous_, submap, chaining_);
    const Sim3& world_from_prev = nodes_.back().world_from_submap;
    if (link.verified) {
      node.world_from_submap = world_from_prev * link.reference_from_query;
      edges_.push_back({previous_->id, submap.id, link.matches, link.inliers});
    } else {
      node.world_from_submap = world_from_prev;
      node.disconnected = true;
      GLAM_LOG_WARN("submap {} could not be linked to submap {} ({} matches, {} inliers): kept as "
                    "disconnected",
                    submap.id, previous_->id, link.matches, link.inliers);
    }
  }
  for (const FramePose& fp : submap.frame_poses) {
    poses_.try_emplace(fp.frame_index, WorldFromCam(node.world_from_submap, fp.cam_from_submap));
  }
  points_.reserve(points_.size() + submap.landmarks.size());
  for (const Landmark& lm : submap.landmarks) {
    ColoredPoint p;
    p.position = (node.world_from_submap * lm.point_in_submap).cast<float>();
    p.color = lm.color;
    points_.push_back(p);
  }
  nodes_.push_back(node);
  previous_ = submap;
  chaining_seconds_ +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::int64_t MapAssembler::disconnected() const {
  std::int64_t n = 0;
  for (const SubmapNode& node : nodes_) n += node.disconnected ? 1 : 0;
  return n;
}

void MapAssembler::WriteTrajectory(const std::filesystem::path& path, double fps) const {
  std::vector<TimedPose> poses;
  poses.reserve(poses_.size());
  for (const auto& [index, pose] : poses_) {
    poses.push_back({static_cast<double>(index) / fps, pose});
  }
  WriteTumTrajectory(path, poses);
}

void MapAssembler::WritePoints(const std::filesystem::path& path) const {
  WritePlyPoints(path, points_);
}

void MapAssembler::WriteGraph(const std::filesystem::path& path) const {
  nlohmann::json nodes = nlohmann::json::array();
  for (const SubmapNode& node : nodes_) {
    const Eigen::Matrix4d m = node.world_from_submap.matrix();
    nlohmann::json rows = nlohmann::json::array();
    for (int r = 0; r < 4; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
    nodes.push_back({{"id", node.id},
                     {"world_from_submap", rows},
                     {"first_frame", node.first_frame},
                     {"last_frame", node.last_frame},
                     {"frames", node.frames},
                     {"disconnected", node.disconnected}});
  }
  nlohmann::json edges = nlohmann::json::array();
  for (const SubmapEdge& e : edges_) {
    edges.push_back({{"from", e.from}, {"to", e.to}, {"matches", e.matches}, {"inliers", e.inliers}});
  }
  const nlohmann::json graph = {{"nodes", nodes}, {"edges", edges}};
  std::ofstream out(path);
  out << graph.dump(2) << "\n";
  out.close();
  if (!out) throw EnvironmentError(fmt::format("cannot write {}", path.string()));
}

}  // namespace glam
