// The end-of-run step between thread 2's last alignment and the exports: the joint bundle
// adjustment of engine/alignment/global_refinement.h applied to the finished map. It reads the
// main map's submaps back from disk (thread 2 keeps only their metadata), refines them, and
// when the refinement is kept, persists them again (each atomically, same placements, so a
// crash in between leaves every submap either before or after, both valid maps) and rewrites
// their tiles under a new URI version (tiles are served as immutable). The returned snapshot
// (one revision later) is what the run exports.
#pragma once

#include <filesystem>
#include <memory>
#include <vector>

#include "engine/alignment/global_refinement.h"
#include "engine/core/cancellation.h"
#include "engine/map/map_snapshot.h"
#include "engine/pipeline/tile_writer.h"

namespace glam {

struct MapRefinementResult {
  GlobalRefinementSummary summary;
  std::shared_ptr<const MapSnapshot> snapshot;  // the input snapshot when not applied
};

MapRefinementResult RefineFinishedMap(std::shared_ptr<const MapSnapshot> snapshot,
                                      const std::vector<std::vector<LandmarkKey>>& groups,
                                      const std::filesystem::path& submaps_root, TileWriter& tiles,
                                      const GlobalRefinementOptions& options,
                                      const CancellationToken& cancel = {});

}  // namespace glam
