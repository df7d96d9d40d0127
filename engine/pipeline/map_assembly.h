// Puts completed submaps into one world frame as they arrive (until global alignment exists,
// a chain: submap k is placed by its link to submap k-1) and accumulates what the run's
// whole-map outputs need: the world trajectory, the coloured landmarks and the submap graph.
// Kept separate from the threading in mapping_job.cc so composition and chaining are testable
// without video.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <vector>

#include "engine/core/se3.h"
#include "engine/core/sim3.h"
#include "engine/export/ply_points.h"
#include "engine/map/submap.h"
#include "engine/alignment/submap_verifier.h"
#include "engine/alignment/world_leveling.h"

namespace glam {

// world_from_cam of a frame posed in a submap. TUM carries no scale, so the rotation is
// R_world_from_submap * R_submap_from_cam and the translation is the Sim3 applied to the
// camera centre (the camera's world position).
SE3 WorldFromCam(const Sim3& world_from_submap, const SE3& cam_from_submap);

struct SubmapNode {
  std::uint32_t id = 0;
  Sim3 world_from_submap;
  std::int64_t first_frame = 0;
  std::int64_t last_frame = 0;
  std::int64_t frames = 0;
  bool disconnected = false;
};

struct SubmapEdge {
  std::uint32_t from = 0;  // previous submap
  std::uint32_t to = 0;    // next submap
  int matches = 0;
  int inliers = 0;
};

class MapAssembler {
 public:
  MapAssembler(const VerificationOptions& chaining, const LevelingOptions& leveling);

  // Places `submap` (after the previous one) and records its frames and points.
  void Add(const Submap& submap);

  const std::vector<SubmapNode>& nodes() const { return nodes_; }
  const std::vector<SubmapEdge>& edges() const { return edges_; }
  std::int64_t disconnected() const;
  std::int64_t frames_posed() const { return static_cast<std::int64_t>(poses_.size()); }
  std::int64_t points() const { return static_cast<std::int64_t>(points_.size()); }
  double chaining_seconds() const { return chaining_seconds_; }

  // trajectory.tum with t = frame index / fps; a frame posed by two submaps (overlap) is
  // written once, from the earlier submap.
  void WriteTrajectory(const std::filesystem::path& path, double fps) const;
  void WritePoints(const std::filesystem::path& path) const;
  void WriteGraph(const std::filesystem::path& path) const;

 private:
  VerificationOptions chaining_;
  LevelingOptions leveling_;
  std::optional<Submap> previous_;  // landmarks of the last submap, for the next link
  std::vector<SubmapNode> nodes_;
  std::vector<SubmapEdge> edges_;
  std::map<std::int64_t, SE3> poses_;  // frame index -> world_from_cam
  std::vector<ColoredPoint> points_;
  double chaining_seconds_ = 0;
};

}  // namespace glam
