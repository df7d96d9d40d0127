// Progress of one mapping run, reported by RunMapping to its caller (the CLI draws a progress
// bar from it, the job runner turns it into `progress` events). Plain data so that the caller
// can copy it to another thread; the fields mirror the job JSON's `progress` object
// (docs/architecture.md, Contracts).
#pragma once

#include <cstdint>
#include <functional>
#include <string>

namespace glam {

struct MappingProgress {
  std::string stage;             // "mapping", "writing", "done"
  std::int64_t frames_done = 0;  // frames consumed by the submap builder
  std::int64_t frames_total = -1;  // expected frames after stride; -1 when unknown
  double fps = 0;                // frames_done / elapsed wall time
  double eta_s = -1;             // -1 when unknown
  std::int64_t submaps_completed = 0;
  std::int64_t submaps_aligned = 0;  // submaps placed in the world frame by alignment
  std::int64_t keyframes = 0;
  std::int64_t points = 0;
  // Grows with every published map revision (docs/architecture.md, "Map revision"); 0 before
  // the first submap is placed.
  std::int64_t revision = 0;
  // Live previews of the open submap written to the tilesets (open_submap_preview.h): how
  // many so far, and the submap and keyframe count of the last. Not part of the job JSON; the
  // server turns a new one into a `preview` event.
  std::int64_t previews = 0;
  std::int64_t preview_submap = -1;
  std::int64_t preview_keyframes = 0;
};

// Called on the thread that runs RunMapping, at most a few times per second plus once at the
// end; must be cheap and must not throw.
using ProgressCallback = std::function<void(const MappingProgress&)>;

}  // namespace glam
