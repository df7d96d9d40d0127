#include "engine/pipeline/live_georeference.h"

#include <utility>

#include "engine/alignment/world_leveling.h"
#include "engine/core/logging.h"
#include "engine/geo/geodetic.h"
#include "engine/map/submap_io.h"
#include "engine/pipeline/georeference_map.h"

namespace glam {
namespace {

// The part of a submap a fit needs: its id, frame range and frame poses.
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

const Sim3& LiveGeoreferencer::LevelledFromSubmap(std::uint32_t id) {
  auto it = levelled_from_submap_.find(id);
  if (it == levelled_from_submap_.end()) {
    it = levelled_from_submap_.emplace(id, LevelSubmap(ReadSubmap(submaps_root_, id)).world_from_submap).first;
  }
  return it->second;
}

std::map<std::int64_t, Eigen::Vector3d> LiveGeoreferencer::Centres(const std::vector<PlacedSubmap>& placed) {
  ChosenPoses poses;
  for (const PlacedSubmap& entry : placed) AddFramePoses(Poses(entry.id), entry.frame_from_submap, &poses);
  return CameraCentres(poses);
}

std::optional<GeoreferenceResult> LiveGeoreferencer::FitOpenSubmap(const Submap& open,
                                                                  const Sim3& world_from_submap) const {
  if (gps_.empty()) return std::nullopt;
  ChosenPoses poses;
  AddFramePoses(open, world_from_submap, &poses);
  GeoreferenceResult result = FitGeoreference(CameraCentres(poses), fps_, gps_, options_);
  if (!result.ok) return std::nullopt;
  return result;
}

std::shared_ptr<const MapSnapshot> LiveGeoreferencer::Apply(const std::shared_ptr<const MapSnapshot>& snapshot) {
  if (gps_.empty() || snapshot == nullptr) return snapshot;
  GeoreferenceResult refit = FitGeoreference(Centres(MapSubmaps(*snapshot)), fps_, gps_, options_);
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
  const std::vector<PartModel> parts =
      DisconnectedParts(*snapshot, [this](std::uint32_t first, const Sim3& part_from_first) {
        return LevelledFromSubmap(first) * part_from_first.Inverse();
      });
  PlacePartsByGps(
      parts, [this](const PartModel& part) { return Centres(part.submaps); }, fps_, gps_, options_,
      georeferenced.get(), false);
  return georeferenced;
}

}  // namespace glam
