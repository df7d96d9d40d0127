// SubmapBuilder: the twin check of a focal-dependent first bootstrap
// (SubmapOptions::bootstrap_twin_*).
//
// Two views of nearly planar ground admit two relative motions that explain the flow almost
// equally well; the bootstrap's RANSAC picks the cheaper, and with a focal a few per cent off
// that can be the wrong one. The two views cannot settle it, but a few more keyframes can: a
// submap built on the wrong motion needs a bent ground and a wrong focal to explain them, and
// its bundle adjustment keeps a clearly higher reprojection error. So when the bootstrap's
// views give another motion at another focal (SubmapBuilder::FocalTwin, bootstrap.cc), the
// open submap is tracked a second time from its first frame (its frames are still in memory),
// starting at that focal with the bootstrap steered to that motion, and the build with the
// lower rms is kept. Split from bootstrap.cc: this decides between two whole builds; that file
// makes one.
#include <utility>

#include "engine/core/logging.h"
#include "engine/geometry/essential.h"
#include "engine/submap/submap_builder.h"

namespace glam {

bool SubmapBuilder::BootstrapTwinCheckDue() const {
  return open_.bootstrap_twin && !open_.bootstrap_twin_checked &&
         static_cast<int>(open_.keyframes.size()) >= options_.bootstrap_twin_check_keyframes;
}

SubmapBuilder::BuilderState SubmapBuilder::SaveState() const {
  return BuilderState{open_,    focal_,          k1_,    completed_keyframe_focals_, previous_tail_,
                      options_, next_submap_id_, camera_decisions_open_, stats_};
}

void SubmapBuilder::RestoreState(BuilderState state) {
  open_ = std::move(state.open);
  focal_ = state.focal;
  k1_ = state.k1;
  completed_keyframe_focals_ = std::move(state.completed_keyframe_focals);
  previous_tail_ = std::move(state.previous_tail);
  options_ = std::move(state.options);
  next_submap_id_ = state.next_submap_id;
  camera_decisions_open_ = state.camera_decisions_open;
  stats_ = std::move(state.stats);
}

void SubmapBuilder::CheckBootstrapTwin(std::vector<Submap>* completed) {
  const Eigen::Vector3d chosen = *open_.bootstrap_direction;
  const OpenSubmap::Twin twin = *open_.bootstrap_twin;
  const double chosen_rms = open_.last_ba_rms;
  const std::size_t chosen_keyframes = open_.keyframes.size();
  const std::int64_t first_frame = open_.frames.front().index;
  const std::int64_t last_frame = open_.frames.back().index;
  // A copy (the frames' features included, ~0.3 MB per frame at 2000 features): the first
  // build comes back unchanged when the second is not better. The replay takes the live frames.
  BuilderState saved = SaveState();
  const std::size_t completed_before = completed->size();

  // The second build starts at the focal that gave the other motion (its bundle adjustments
  // then move it as usual).
  focal_ = twin.focal;
  const RestartCarry carry{open_.rebuilds, twin.direction, /*bootstrap_twin_checked=*/true};
  RestartWith(std::move(open_.frames), carry, completed);

  // The second build counts only if it is still one open submap over the same frames (no
  // tracking loss or completion on the way) that bootstrapped on the other motion.
  const bool comparable = completed->size() == completed_before && open_.bootstrapped &&
                          !open_.frames.empty() && open_.frames.front().index == first_frame &&
                          open_.keyframes.size() >= 3 && open_.bootstrap_direction &&
                          DistinctMotions(*open_.bootstrap_direction, chosen);
  const double twin_rms = open_.last_ba_rms;
  const bool keep_twin = comparable && twin_rms > 0 &&
                         twin_rms < (1.0 - options_.bootstrap_twin_min_rms_gain) * chosen_rms;
  if (comparable) {
    GLAM_LOG_INFO("bootstrap of the submap from frame {} depends on the focal (another motion at {:.1f} px): "
                  "tracked again to frame {} from there: rms {:.3f} px with {} keyframes (focal {:.1f} px) "
                  "against {:.3f} px with {} (focal {:.1f} px): {}",
                  first_frame, twin.focal, last_frame, twin_rms, open_.keyframes.size(), focal_, chosen_rms,
                  chosen_keyframes, saved.focal, keep_twin ? "keeping the new build" : "keeping the first build");
  } else {
    GLAM_LOG_DEBUG("bootstrap twin check of the submap from frame {}: the second build did not start from "
                   "the other motion or did not stay one submap: keeping the first build",
                   first_frame);
  }
  if (keep_twin) {
    ++stats_.bootstrap_twin_checks;
    ++stats_.bootstrap_twins_kept;
    open_.bootstrap_preference = twin.direction;
    return;
  }
  const double ba_seconds = stats_.bundle_adjust_seconds;
  completed->erase(completed->begin() + static_cast<std::ptrdiff_t>(completed_before), completed->end());
  RestoreState(std::move(saved));
  stats_.bundle_adjust_seconds = ba_seconds;  // the second build's adjustments did run
  ++stats_.bootstrap_twin_checks;
  open_.bootstrap_preference = chosen;
  open_.bootstrap_twin_checked = true;
}

}  // namespace glam
