#include "engine/pipeline/live_georeference.h"

#include <utility>

#include "engine/alignment/world_leveling.h"
#include "engine/core/logging.h"
#include "engine/geo/geodetic.h"
#include "engine/map/submap_io.h"
#include "engine/pipeline/georeference_map.h"

namespace glam {

LiveGeoreferencer::Cached LiveGeoreferencer::ForFits(const Submap& submap) {
  LiveGeoreferencer::Cached entry;
  entry.poses.id = submap.id;
  entry.poses.first_frame = submap.first_frame;
  entry.poses.last_frame = submap.last_frame;
  entry.poses.frame_poses = submap.frame_poses;
  entry.levelled_from_submap = LevelSubmap(submap).world_from_submap;
  return entry;
}

LiveGeoreferencer::LiveGeoreferencer(std::vector<GpsSample> gps, double fps, GeoreferenceOptions options,
                                     std::filesystem::path submaps_root)
    : gps_(std::move(gps)), fps_(fps), options_(options), submaps_root_(std::move(submaps_root)) {
  options_.Check();
}

void LiveGeoreferencer::AddSubmap(const Submap& submap) { cache_[submap.id] = ForFits(submap); }

const LiveGeoreferencer::Cached& LiveGeoreferencer::Entry(std::uint32_t id) {
  auto it = cache_.find(id);
  if (it == cache_.end()) it = cache_.emplace(id, ForFits(ReadSubmap(submaps_root_, id))).first;
  return it->second;
}

std::map<std::int64_t, Eigen::Vector3d> LiveGeoreferencer::Centres(const std::vector<PlacedSubmap>& placed) {
  ChosenPoses poses;
  for (const PlacedSubmap& entry : placed) AddFramePoses(Entry(entry.id).poses, entry.frame_from_submap, &poses);
  return CameraCentres(poses);
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
        return Entry(first).levelled_from_submap * part_from_first.Inverse();
      });
  PlacePartsByGps(
      parts, [this](const PartModel& part) { return Centres(part.submaps); }, fps_, gps_, options_,
      georeferenced.get(), false);
  return georeferenced;
}

}  // namespace glam
