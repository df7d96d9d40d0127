#include "engine/pipeline/map_refinement.h"

#include <utility>

#include "engine/core/logging.h"
#include "engine/map/submap_io.h"

namespace glam {

MapRefinementResult RefineFinishedMap(std::shared_ptr<const MapSnapshot> snapshot,
                                      const std::vector<std::vector<LandmarkKey>>& groups,
                                      const std::filesystem::path& submaps_root, TileWriter& tiles,
                                      const GlobalRefinementOptions& options,
                                      const CancellationToken& cancel) {
  MapRefinementResult result;
  result.snapshot = snapshot;
  if (options.max_keyframes == 0) {
    result.summary.reason = "off";
    return result;
  }
  std::vector<Submap> submaps;
  std::vector<Sim3> world_from_submap;
  std::size_t keyframes = 0;
  for (const SubmapPlacement& placement : snapshot->submaps) {
    if (placement.disconnected || placement.part != 0) continue;
    submaps.push_back(ReadSubmap(submaps_root, placement.id));
    world_from_submap.push_back(placement.world_from_submap);
    keyframes += submaps.back().keyframes.size();
    if (keyframes > static_cast<std::size_t>(options.max_keyframes)) {
      result.summary.reason = fmt::format("more than {} keyframes in the map", options.max_keyframes);
      GLAM_LOG_INFO("global refinement skipped: {}", result.summary.reason);
      return result;
    }
  }
  result.summary = RefineMapJointly(submaps, world_from_submap, groups, options, cancel);
  if (!result.summary.applied) {
    if (!result.summary.reason.empty()) {
      GLAM_LOG_INFO("global refinement not applied: {}", result.summary.reason);
    }
    return result;
  }
  const GlobalRefinementSummary& s = result.summary;
  GLAM_LOG_INFO(
      "global refinement: {} submaps, {} keyframes ({} shared), {} points ({} joined across "
      "submaps, {} joins undone), rms {:.3f} -> {:.3f} px, largest camera move {:.3g}, "
      "{} iterations, {:.2f} s",
      s.submaps, s.keyframes, s.shared_keyframes, s.landmarks, s.joined_landmarks, s.split_landmarks,
      s.initial_rms_pixels, s.final_rms_pixels, s.max_camera_shift, s.iterations, s.seconds);
  for (const Submap& submap : submaps) WriteSubmap(submap, submaps_root);
  tiles.OnSubmapsRefined(submaps);
  auto refined = std::make_shared<MapSnapshot>(*snapshot);
  refined->revision = snapshot->revision + 1;
  result.snapshot = std::move(refined);
  return result;
}

}  // namespace glam
