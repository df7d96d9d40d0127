// The live preview of the submap being built. A submap completes after keyframes_per_submap
// (20) keyframes, tens of seconds of flight; until then a viewer following the job would see
// nothing new (on a short video, nothing at all before the end). Every few seconds this puts
// the open submap, as tracking and its incremental bundle adjustments left it, into the
// tilesets as a provisional tile (TileWriter::OnOpenSubmapPreview), replaced by the submap's
// own tile once alignment places it.
//
// Placement without waiting for alignment: the open submap starts inside the previous one's
// last 10 % of frames and poses them again (the hand-off), so those shared frames give
// previous_from_open (EstimateFromSharedFrames), and the preview rides on the previous
// submap's placement in each revision. The first submap of a run has no previous one: it is
// levelled on its own, as the aligner will level it into the world frame; with a GPS track
// (GeoreferenceWith) it is shown only once the track fits its posed frames, and in metres,
// east-north-up with the fit, as the revisions after it will be: shown in the mapping frame
// first, the map would jump to another scale and heading at the first georeferenced revision.
// A submap started after a tracking loss shares no frames with the one before. With a GPS
// track and a georeferenced map it is previewed where its own GPS fit puts it (levelled, then
// fitted as the revisions place a disconnected part: the same east-north-up frame, whose
// origin is the track's first fix), once its posed frames allow a fit; without, it gets no
// preview until it completes and alignment has linked it (a preview in the wrong place is
// worse than none).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>

#include "engine/alignment/world_leveling.h"
#include "engine/map/submap.h"
#include "engine/pipeline/live_georeference.h"
#include "engine/pipeline/tile_writer.h"
#include "engine/submap/submap_builder.h"

namespace glam {

struct OpenSubmapPreviewOptions {
  // At most one preview per this many seconds, and only after the open submap gained a
  // keyframe (landmarks are triangulated at keyframes); 0 turns previews off. Each costs a few
  // milliseconds (a copy of the landmarks, two tile encodings, two small tilesets).
  double interval_s = 1.0;
  // The open submap needs this many keyframes before it is shown (>= 2: bootstrapped; keyframes
  // often come in pairs, the middle one and the current frame, so 3 would skip 2 -> 4).
  int min_keyframes = 2;

  void Check() const;  // throws InputError
};

class OpenSubmapPreviewer {
 public:
  OpenSubmapPreviewer(const OpenSubmapPreviewOptions& options, const LevelingOptions& leveling, TileWriter& tiles);

  // The run's GPS fits (owned by the caller, used on the same thread as Update): the first
  // submap's preview waits for a fit of its own while no revision has been georeferenced, and
  // so does a submap started after a tracking loss once one has.
  void GeoreferenceWith(const LiveGeoreferencer* georeferencer) { georeferencer_ = georeferencer; }

  // The submap the next open one hands off from (also the last one of a resumed run).
  void OnSubmapCompleted(std::shared_ptr<const Submap> submap);

  // After each frame the builder consumed: writes a preview when one is due. Returns whether it did.
  bool Update(const SubmapBuilder& builder);

  // Previews written, and the submap / keyframes of the last one.
  std::int64_t previews() const { return previews_; }
  std::int64_t last_submap() const { return last_submap_; }
  std::int64_t last_keyframes() const { return last_keyframes_; }

 private:
  using Clock = std::chrono::steady_clock;

  OpenSubmapPreviewOptions options_;
  LevelingOptions leveling_;
  TileWriter& tiles_;
  const LiveGeoreferencer* georeferencer_ = nullptr;
  std::shared_ptr<const Submap> previous_;
  Clock::time_point last_time_{};
  std::int64_t keyframes_seen_ = -1;  // builder's keyframe count at the last attempt
  std::int64_t previews_ = 0;
  std::int64_t last_submap_ = -1;
  std::int64_t last_keyframes_ = 0;
};

}  // namespace glam
