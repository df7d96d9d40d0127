// SubmapBuilder::OpenSubmapPreview: the open submap as it stands, for live map views.
#include <algorithm>

#include "engine/submap/submap_builder.h"

namespace glam {

std::optional<Submap> SubmapBuilder::OpenSubmapPreview(std::size_t min_keyframes) const {
  if (!open_.bootstrapped || open_.keyframes.size() < std::max<std::size_t>(2, min_keyframes)) {
    return std::nullopt;
  }
  Submap preview;
  preview.id = next_submap_id_;
  preview.intrinsics = CurrentCamera().intrinsics();
  preview.keyframes = open_.keyframes;
  preview.first_frame = open_.frames.front().index;
  preview.last_frame = open_.frames.back().index;
  preview.landmarks.reserve(open_.landmarks.size());
  for (const Landmark& lm : open_.landmarks) {
    Landmark copy;
    copy.id = lm.id;
    copy.point_in_submap = lm.point_in_submap;
    copy.color = lm.color;
    preview.landmarks.push_back(std::move(copy));
  }
  for (const FrameRecord& frame : open_.frames) {
    if (frame.cam_from_submap) preview.frame_poses.push_back(frame.ToFramePose());
  }
  return preview;
}

}  // namespace glam
