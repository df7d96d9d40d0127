#include "engine/pipeline/open_submap_preview.h"

#include "engine/alignment/shared_frames.h"
#include "engine/core/logging.h"
#include "engine/core/options.h"
#include "engine/geo/geodetic.h"

namespace glam {

void OpenSubmapPreviewOptions::Check() const {
  CheckGreaterEqual("OpenSubmapPreviewOptions.interval_s", interval_s, 0.0);
  CheckInRange("OpenSubmapPreviewOptions.min_keyframes", min_keyframes, 2, 1000);
}

OpenSubmapPreviewer::OpenSubmapPreviewer(const OpenSubmapPreviewOptions& options, const LevelingOptions& leveling,
                                         TileWriter& tiles)
    : options_(options), leveling_(leveling), tiles_(tiles) {
  options_.Check();
  leveling_.Check();
}

void OpenSubmapPreviewer::OnSubmapCompleted(std::shared_ptr<const Submap> submap) { previous_ = std::move(submap); }

bool OpenSubmapPreviewer::Update(const SubmapBuilder& builder) {
  if (options_.interval_s <= 0) return false;
  // A preview whose submap was discarded (closed with too few keyframes: the next one, started
  // elsewhere, got its id) must not stay on screen.
  if (const auto shown = tiles_.open_preview();
      shown && shown->first == builder.next_submap_id() && builder.open_submap_first_frame() != shown->second) {
    tiles_.ClearOpenPreview();
  }
  const std::int64_t keyframes = builder.stats().keyframes;
  const Clock::time_point now = Clock::now();
  if (keyframes == keyframes_seen_ || now - last_time_ < std::chrono::duration<double>(options_.interval_s)) {
    return false;
  }
  // Where the open submap will be placed from: the submap before it, once a revision placed
  // that (a fraction of a second after it completed), or its own levelling for the run's first.
  // After a tracking loss (no frames shared with the submap before) only a GPS fit of its own
  // can place it, in the east-north-up frame the georeferenced revisions already use.
  const std::uint32_t id = builder.next_submap_id();
  const bool gps_placeable = id != 0 && georeferencer_ != nullptr && georeferencer_->fit().has_value();
  std::optional<std::uint32_t> anchor;
  if (previous_ && previous_->id + 1 == id) {
    if (!tiles_.placed(previous_->id)) return false;  // tried again on the next frame
    anchor = previous_->id;
  } else if (id != 0 && !gps_placeable) {
    return false;  // placed by alignment (or the revisions' GPS fits) once complete
  }
  std::optional<Submap> preview = builder.OpenSubmapPreview(static_cast<std::size_t>(options_.min_keyframes));
  if (!preview) return false;
  keyframes_seen_ = keyframes;
  last_time_ = now;
  Sim3 anchor_from_open;
  std::optional<Eigen::Matrix4d> ecef_from_world;
  if (anchor) {
    const std::optional<Sim3> previous_from_open = EstimateFromSharedFrames(*previous_, *preview);
    if (previous_from_open) {
      anchor_from_open = *previous_from_open;
    } else if (gps_placeable) {
      anchor.reset();  // the submap before it was lost, not handed off from: placed by GPS below
    } else {
      GLAM_LOG_DEBUG("open submap {}: no placement from the frames it shares with submap {}", id, *anchor);
      return false;
    }
  }
  if (!anchor) {
    anchor_from_open = LevelSubmap(*preview, leveling_).world_from_submap;
    if (georeferencer_ != nullptr && (gps_placeable || !georeferencer_->fit())) {
      const std::optional<GeoreferenceResult> fit = georeferencer_->FitOpenSubmap(*preview, anchor_from_open);
      if (!fit) {
        GLAM_LOG_DEBUG("open submap {}: not previewed until the GPS track fits its {} posed frames", id,
                       preview->frame_poses.size());
        return false;
      }
      GLAM_LOG_DEBUG("open submap {}: previewed in ENU, GPS fit of {} frames, rms {:.2f} m over {:.1f} m ({}), "
                     "scale {:.3f}",
                     id, fit->samples_used, fit->rms_m, fit->extent_m, fit->full ? "similarity" : "yaw, scale, offset",
                     fit->enu_from_world.scale());
      anchor_from_open = fit->enu_from_world * anchor_from_open;
      ecef_from_world = EnuFrame(fit->origin).EcefFromEnu();
    }
  }
  if (!tiles_.OnOpenSubmapPreview(*preview, anchor, anchor_from_open, ecef_from_world)) return false;
  ++previews_;
  last_submap_ = preview->id;
  last_keyframes_ = static_cast<std::int64_t>(preview->keyframes.size());
  GLAM_LOG_DEBUG("open submap {} previewed: {} keyframes, {} landmarks, {} frames posed, {:.1f} ms", preview->id,
                 preview->keyframes.size(), preview->landmarks.size(), preview->frame_poses.size(),
                 1e3 * std::chrono::duration<double>(Clock::now() - now).count());
  return true;
}

}  // namespace glam
