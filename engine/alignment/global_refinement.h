// Joint bundle adjustment of the whole map once the input has ended ("global refinement"), a
// step the paper does not have. Why: thread 2 places each submap as one rigid Sim3, so a
// submap that bent while it was built (its camera orientations drift a few tenths of a degree
// over 20 keyframes on a turning oblique flight) stays bent; the loop edge sees both ends of
// the loop agree and has nothing to correct. COLMAP's global bundle adjustment, and GLAM's own
// single-submap runs, take that bend out because keyframes at the end of a loop observe the
// points its start mapped. Here those observations come from the factor graph: every landmark
// node there is one ground point matched across submaps (verified Sim3 inliers), so its
// members' observations become one track, and keyframes of the same video frame in two
// submaps (the hand-off overlap) become one camera.
//
// The adjustment is the submap bundle adjuster (submap/bundle_adjuster.h) run in the world
// frame over every keyframe and landmark of the main map, focal and distortion fixed, with
// the first keyframe and the scale held (the world frame, levelled and possibly georeferenced
// later, stays where it is). A join the adjusted map cannot explain is undone and the map
// adjusted once more (max_joined_error_px). Results go back into each submap's own frame under its unchanged
// world_from_submap, so a snapshot's placements stay valid: keyframes and landmarks take their
// refined values, every other frame the keyframes' correction interpolated by frame index.
//
// Bounded: the problem grows with the whole map, so it runs only while the map has at most
// `max_keyframes` keyframes (a few thousand frames); longer flights keep the rigid placement,
// which is what bounds their memory and time per submap.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "engine/alignment/landmark_match.h"
#include "engine/core/cancellation.h"
#include "engine/core/sim3.h"
#include "engine/map/submap.h"
#include "engine/submap/bundle_adjuster.h"

namespace glam {

struct GlobalRefinementOptions {
  // Above this many keyframes in the map the refinement is skipped (time and memory grow with
  // the whole map; a 20-keyframe submap is ~300-600 frames of video at 30 fps). 0 = off.
  int max_keyframes = 400;
  // Focal and k1 stay fixed (each keyframe keeps its submap's focal); sparse Schur solver.
  BundleAdjustmentOptions bundle_adjustment = DefaultBundleAdjustment();
  // The refinement is kept only if the reprojection rms does not grow (it cannot, except when
  // the solver fails) and no camera moved by more than this fraction of the map's median
  // viewing depth: a larger move means a wrong cross-submap match pulled the map apart.
  double max_camera_shift_fraction = 0.5;
  // A point joined across submaps whose members' observations still reproject worse than this
  // (rms, pixels) after the adjustment was a wrong match: its members are split into points of
  // their own and the map adjusted once more. The submap filters' reprojection threshold.
  double max_joined_error_px = 4.0;

  void Check() const;  // throws InputError

  static BundleAdjustmentOptions DefaultBundleAdjustment();
};

struct GlobalRefinementSummary {
  bool ran = false;
  bool applied = false;
  std::string reason;  // why it did not run or was not applied (empty otherwise)
  int submaps = 0;
  int keyframes = 0;         // cameras in the adjustment (shared keyframes counted once)
  int shared_keyframes = 0;  // keyframes of the same frame in two submaps, joined
  int landmarks = 0;         // points in the adjustment
  int joined_landmarks = 0;  // points made of landmarks from several submaps
  int split_landmarks = 0;   // joins undone after the first pass (max_joined_error_px)
  int observations = 0;
  double initial_rms_pixels = 0;
  double final_rms_pixels = 0;
  double max_camera_shift = 0;  // world units
  int iterations = 0;
  double seconds = 0;
};

// `submaps` (all of the main map, ascending id, the gauge submap first) with their placements
// `world_from_submap` (same order) and the landmark groups matched across them (groups of two
// or more members; members of submaps not in `submaps` are ignored). Rewrites keyframes,
// landmarks and frame poses of `submaps` in place when the summary says applied. Throws
// Cancelled.
GlobalRefinementSummary RefineMapJointly(std::vector<Submap>& submaps,
                                         const std::vector<Sim3>& world_from_submap,
                                         const std::vector<std::vector<LandmarkKey>>& groups,
                                         const GlobalRefinementOptions& options,
                                         const CancellationToken& cancel = {});

}  // namespace glam
