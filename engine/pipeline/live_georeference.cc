#include "engine/pipeline/live_georeference.h"

#include <utility>

#include "engine/core/logging.h"
#include "engine/geo/geodetic.h"
#include "engine/map/submap_io.h"
#include "engine/pipeline/map_export.h"

namespace glam {
namespace {

// The part of a submap a fit needs: its id and frame poses.
Submap PosesOnly(const Submap& submap) {
  Submap poses;
  poses.id = submap.id;
  poses.first_frame = submap.first_frame;
  poses.last_frame = submap.last_frame;
  poses.frame_poses = submap.frame_poses;
  return poses;
}

}  // namespace

LiveGeoreferencer::LiveGeoreferencer(std::vector<GpsSample> gps, double fps, GeoreferenceOptions options,
                                     std::filesystem::path submaps_root)
    : gps_(std::move(gps)), fps_(fps), options_(options), submaps_root_(std::move(submaps_root)) {
  options_.Check();
}

void LiveGeoreferencer::AddSubmap(const Submap& submap) { poses_[submap.id] = PosesOnly(submap); }

const Submap& LiveGeoreferencer::Poses(std::uint32_t id) {
  auto it = poses_.find(id);
  if (it == poses_.end()) it = poses_.emplace(id, PosesOnly(ReadSubmap(submaps_root_, id))).first;
  return it->second;
}

std::shared_ptr<const MapSnapshot> LiveGeoreferencer::Apply(const std::shared_ptr<const MapSnapshot>& snapshot) {
  if (gps_.empty() || snapshot == nullptr) return snapshot;
  ChosenPoses poses;
  for (const PlacedSubmap& placed : MapSubmaps(*snapshot)) {
    AddFramePoses(Poses(placed.id), placed.frame_from_submap, &poses);
  }
  GeoreferenceResult refit = FitGeoreference(CameraCentres(poses), fps_, gps_, options_);
  if (refit.ok) {
    if (!fit_) {
      GLAM_LOG_INFO("map revision {} georeferenced while mapping: {} GPS positions, rms {:.2f} m over {:.0f} m",
                    snapshot->revision, refit.samples_used, refit.rms_m, refit.extent_m);
    }
    fit_ = std::move(refit);
  } else if (fit_) {
    GLAM_LOG_DEBUG("map revision {}: GPS refit failed ({}); keeping the previous fit", snapshot->revision,
                   refit.reason);
  }
  if (!fit_) return snapshot;
  auto georeferenced = std::make_shared<MapSnapshot>(*snapshot);
  for (SubmapPlacement& placement : georeferenced->submaps) {
    placement.world_from_submap = fit_->enu_from_world * placement.world_from_submap;
  }
  georeferenced->ecef_from_world = EnuFrame(fit_->origin).EcefFromEnu();
  return georeferenced;
}

}  // namespace glam
