#include "engine/submap/submap_builder.h"

#include <algorithm>
#include <iterator>
#include <utility>
#include <cmath>

#include "engine/core/logging.h"
#include "engine/core/median.h"

namespace glam {
namespace {

// How far (frames) the overlap start may move back to reach a detected frame: more than any
// automatic detection interval (0.2 s at up to 120 fps).
constexpr std::size_t kMaxOverlapShift = 30;

}  // namespace

SubmapBuilder::SubmapBuilder(const Intrinsics& intrinsics, const SubmapOptions& options,
                             CancellationToken cancel)
    : intrinsics_(intrinsics), options_(options), cancel_(std::move(cancel)), focal_(intrinsics.fx),
      k1_(intrinsics.k1) {
  intrinsics_.Check();
  options_.Check();
  readout_decision_open_ = options_.estimate_readout;
}

Camera SubmapBuilder::CurrentCamera() const {
  Intrinsics in = intrinsics_.WithFocal(focal_);
  in.SetK1(k1_);
  return Camera(in);
}

void SubmapBuilder::ResumeAt(std::uint32_t next_submap_id, bool focal_held, bool k1_held,
                             std::optional<double> readout_ms) {
  GLAM_CHECK(stats_.frames_seen == 0, "ResumeAt after frames were added");
  next_submap_id_ = next_submap_id;
  if (next_submap_id > 0) {
    camera_decisions_open_ = false;  // taken by the interrupted run
    if (readout_decision_open_) {
      readout_decision_open_ = false;
      readout_s_ = 1e-3 * readout_ms.value_or(0.0);
      stats_.readout_ms = readout_ms.value_or(0.0);
    }
  }
  if (focal_held && options_.bundle_adjustment.refine_focal) HoldInitialFocal();
  if (k1_held && options_.bundle_adjustment.refine_k1) HoldInitialK1();
}

std::optional<std::int64_t> SubmapBuilder::open_submap_first_frame() const {
  if (open_.frames.empty()) return std::nullopt;
  return open_.frames.front().index;
}

const Landmark* SubmapBuilder::FindLandmark(std::uint32_t id) const {
  // Landmarks are appended with increasing ids and filters keep the order, so ids are sorted.
  auto it = std::lower_bound(open_.landmarks.begin(), open_.landmarks.end(), id,
                             [](const Landmark& lm, std::uint32_t v) { return lm.id < v; });
  return (it != open_.landmarks.end() && it->id == id) ? &*it : nullptr;
}

Landmark* SubmapBuilder::FindLandmark(std::uint32_t id) {
  return const_cast<Landmark*>(std::as_const(*this).FindLandmark(id));
}

std::vector<Submap> SubmapBuilder::AddFrame(std::int64_t index, double timestamp_s,
                                            const Features& features) {
  cancel_.ThrowIfCancelled();
  ++stats_.frames_seen;
  FrameRecord record;
  record.index = index;
  record.timestamp_s = timestamp_s;
  record.features = CompactFeatures::From(features);
  record.detected = features.detected;
  std::vector<Submap> completed;
  Process(std::move(record), &completed);
  return completed;
}

void SubmapBuilder::StartSubmapAt(std::deque<FrameRecord> frames) {
  open_ = OpenSubmap{};
  open_.frames = std::move(frames);
  open_.start_focal = focal_;
  open_.start_k1 = k1_;
  for (FrameRecord& f : open_.frames) {
    f.ResetPose();
  }
}

void SubmapBuilder::Process(FrameRecord record, std::vector<Submap>* completed) {
  // Replayed frames too: a rebuild after the readout decision corrects them anew.
  record.features.ApplyReadout(readout_s_);
  if (!open_.bootstrapped) {
    // The second keyframe is looked for among detected frames only (propagated frames carry a
    // subset of a detection frame's keypoints); the frames in between are localised once the
    // bootstrap succeeds.
    const bool detected = record.detected;
    if (open_.frames.empty()) {
      open_.start_focal = focal_;
      open_.start_k1 = k1_;
    }
    open_.frames.push_back(std::move(record));
    if (detected || open_.frames.size() == 1) TryBootstrap();
    return;
  }
  open_.frames.push_back(std::move(record));
  FrameRecord& current = open_.frames.back();
  if (!Track(current)) {
    if (PoseByRotationOnly(open_.frames.size() - 1)) {
      ++stats_.frames_rotation_only;
      return;  // no landmarks in view: nothing for the keyframe rules
    }
    ++stats_.tracking_losses;
    GLAM_LOG_INFO("tracking lost at frame {}: closing submap, bootstrapping a new one", current.index);
    FrameRecord lost = std::move(current);
    open_.frames.pop_back();
    // Closed by the loss, the submap still gets what a submap closed at its last keyframe gets:
    // the camera decisions (first submap) and the rebuild at the settled focal. Without them
    // a first submap cut short kept the focal its landmarks were triangulated with while it
    // moved, and so did every submap after it (a cut at frame 300 of the lawnmower: 531 px
    // against 563 px with the rebuild, true 554; the ground 4.7 m off at 100 m). Only for a
    // submap with keyframes enough to decide on (CameraDecidingSubmap): a fragment leaves the
    // decisions to the next submap. The replay ends at the last tracked frame; a loss earlier
    // in it is handled there, as any loss.
    while (open_.bootstrapped && CameraDecidingSubmap() && RebuildIfCameraMoved(completed)) {
    }
    // Frames posed by rotation only just before (a hovering yaw) are kept by this submap and
    // also replayed into the next one, which may see their ground as the drone flies on.
    std::deque<FrameRecord> restart;
    for (std::size_t p = open_.frames.size(); p-- > 0 && open_.frames[p].rotation_only();) {
      restart.push_front(open_.frames[p]);
    }
    restart.push_back(std::move(lost));
    if (static_cast<int>(open_.keyframes.size()) >= 3) {
      if (std::optional<Submap> submap = Complete()) completed->push_back(std::move(*submap));
    } else {
      ++stats_.submaps_discarded;
    }
    previous_tail_.clear();  // no shared ground with the next submap
    RestartWith(std::move(restart), {}, completed);
    return;
  }
  ++stats_.frames_tracked;
  const int inliers = static_cast<int>(current.landmark_matches.size());
  GLAM_LOG_TRACE("frame {}: {} PnP inliers of {} landmarks (tau_resection {})", current.index, inliers,
                 open_.landmarks.size(), open_.tau_resection);
  // Paper rule: a new keyframe when inliers fall below tau_resection. Added guards: not before
  // the parallax to the previous keyframe allows triangulating between the middle keyframe
  // and this frame, and on a detected frame (the next one is at most detection_interval
  // frames away) — unless tracking is about to be lost.
  // Optional parallax rule (SubmapOptions::max_keyframe_parallax_deg): a detected frame at that
  // parallax. Looked at only above tau_resection: below it, a detected frame that the paper
  // rule did not take has less parallax than triangulation needs, which Check() keeps below
  // the rule's angle, so the parallax is never computed twice.
  // Coverage rule (SubmapOptions::min_map_coverage): a detected frame of whose textured view
  // the map covers little, once it can triangulate (both looked at only when the other rules
  // did not take it).
  const bool about_to_lose = inliers < 2 * options_.min_tracking_inliers;
  const bool below_tau = inliers < open_.tau_resection;
  const bool paper_keyframe =
      below_tau && ((current.detected && CanTriangulateWithLastKeyframe(current)) || about_to_lose);
  const bool parallax_keyframe =
      !below_tau && current.detected && options_.max_keyframe_parallax_deg > 0 &&
      ParallaxToLastKeyframeDeg(current) >= options_.max_keyframe_parallax_deg;
  const bool coverage_keyframe = !below_tau && !parallax_keyframe && current.detected &&
                                 options_.min_map_coverage > 0 && MapCoverageLow(current) &&
                                 CanTriangulateWithLastKeyframe(current);
  if (paper_keyframe || parallax_keyframe || coverage_keyframe) InsertKeyframes(open_.frames.size() - 1);
  // May track the open submap again up to this frame (its completion rule below then looks at
  // whichever build was kept).
  if (BootstrapTwinCheckDue()) CheckBootstrapTwin(completed);

  if ((!extending_tail_ && static_cast<int>(open_.keyframes.size()) >= options_.keyframes_per_submap) ||
      static_cast<int>(open_.frames.size()) >= options_.max_frames_per_submap) {
    if (!RebuildIfCameraMoved(completed)) HandOffOverlap(completed);
  }
}

void SubmapBuilder::RestartWith(std::deque<FrameRecord> frames, const RestartCarry& carry,
                                std::vector<Submap>* completed) {
  std::deque<FrameRecord> start;
  start.push_back(std::move(frames.front()));
  frames.pop_front();
  StartSubmapAt(std::move(start));
  open_.rebuilds = carry.rebuilds;
  open_.bootstrap_preference = carry.bootstrap_preference;
  open_.bootstrap_twin_checked = carry.bootstrap_twin_checked;
  for (FrameRecord& f : frames) {
    cancel_.ThrowIfCancelled();
    f.ResetPose();
    Process(std::move(f), completed);
  }
}

double SubmapBuilder::ParallaxToLastKeyframeDeg(const FrameRecord& frame) const {
  const Eigen::Vector3d keyframe_centre = open_.keyframes.back().cam_from_submap.Inverse().translation();
  const Eigen::Vector3d frame_centre = frame.cam_from_submap->Inverse().translation();
  std::vector<double> angles;
  for (const auto& [feature, id] : frame.landmark_matches) {
    if (const Landmark* lm = FindLandmark(id)) {
      const Eigen::Vector3d a = (lm->point_in_submap - keyframe_centre).normalized();
      const Eigen::Vector3d b = (lm->point_in_submap - frame_centre).normalized();
      angles.push_back(std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * 180.0 / M_PI);
    }
  }
  return UpperMedian(std::move(angles));
}

double SubmapBuilder::MapCoverageOf(const FrameRecord& frame) const {
  const Camera camera = CurrentCamera();
  std::vector<Eigen::Vector2d> mapped;
  mapped.reserve(open_.landmarks.size());
  for (const Landmark& landmark : open_.landmarks) {
    Eigen::Vector2d px;
    if (camera.Project(*frame.cam_from_submap * landmark.point_in_submap, &px) && camera.InImage(px)) {
      mapped.push_back(px);
    }
  }
  return MapCoverage(frame.features.points, mapped, camera.intrinsics().width, camera.intrinsics().height);
}

bool SubmapBuilder::MapCoverageLow(const FrameRecord& frame) const {
  const double coverage = MapCoverageOf(frame);
  if (coverage >= options_.min_map_coverage) return false;
  GLAM_LOG_TRACE("frame {}: the map covers {:.2f} of the textured view", frame.index, coverage);
  return true;
}

bool SubmapBuilder::CanTriangulateWithLastKeyframe(const FrameRecord& frame) const {
  return ParallaxToLastKeyframeDeg(frame) >= 2.0 * options_.min_triangulation_angle_deg;
}

std::optional<std::size_t> SubmapBuilder::LastTrackedAfterLastKeyframe() const {
  if (open_.keyframe_frame_positions.empty()) return std::nullopt;
  for (std::size_t p = open_.frames.size(); p-- > open_.keyframe_frame_positions.back() + 1;) {
    if (open_.frames[p].cam_from_submap && !open_.frames[p].rotation_only()) return p;
  }
  return std::nullopt;
}

std::vector<Submap> SubmapBuilder::Finish() {
  std::vector<Submap> completed;
  if (options_.extend_short_final_submap && !open_.frames.empty() && !previous_tail_.empty() &&
      static_cast<double>(open_.keyframes.size()) <
          options_.short_final_submap_fraction * options_.keyframes_per_submap) {
    // Tracked again from the previous submap's middle keyframe, at the current focal (so the
    // focal rebuild below has nothing left to do). Also when it is still bootstrapping: its
    // few frames alone make a poor map (measured 1.9 m median error, extended 0.97 m).
    GLAM_LOG_INFO("end of input: submap with {} keyframes extended back to frame {}",
                  open_.keyframes.size(), previous_tail_.front().index);
    std::deque<FrameRecord> frames = std::move(previous_tail_);
    previous_tail_.clear();
    for (FrameRecord& f : open_.frames) frames.push_back(std::move(f));
    extending_tail_ = true;
    RestartWith(std::move(frames), RestartCarry{open_.rebuilds, std::nullopt, false}, &completed);
    extending_tail_ = false;
    // The ground seen after the last keyframe is mapped too: the last tracked frame becomes a
    // keyframe when its parallax allows triangulating.
    if (open_.bootstrapped) {
      const std::optional<std::size_t> last = LastTrackedAfterLastKeyframe();
      if (last && CanTriangulateWithLastKeyframe(open_.frames[*last])) {
        InsertKeyframes(*last);
      }
    }
  }
  // End of input: a submap that never reached its last keyframe still gets the rebuild at the
  // settled focal (a short clip is often one such submap), and the first submap the camera
  // decisions (k1, then focal: after a k1 hold the rebuilt submap gets the focal profile).
  // Bounded by SubmapOptions::max_submap_rebuilds per submap.
  while (open_.bootstrapped && RebuildIfCameraMoved(&completed)) {
  }
  // Then give the open submap its best chance to be kept. A pending bootstrap takes
  // the last frame as second keyframe if the parallax allows; a submap with fewer than three
  // keyframes makes its last tracked frame a keyframe.
  if (!open_.bootstrapped && open_.frames.size() >= 2) {
    finishing_ = true;
    TryBootstrap();
    finishing_ = false;
  }
  if (open_.bootstrapped && static_cast<int>(open_.keyframes.size()) < 3) {
    // The last tracked frame closes the submap as a keyframe (with a middle keyframe and new
    // landmarks, as usual) ...
    if (const std::optional<std::size_t> last = LastTrackedAfterLastKeyframe()) InsertKeyframes(*last);
  }
  if (open_.bootstrapped && static_cast<int>(open_.keyframes.size()) < 3) {
    // ... or, when the second keyframe is the last frame, the posed non-keyframe farthest from
    // every keyframe becomes one more keyframe.
    std::optional<std::size_t> best;
    std::size_t best_gap = 0;
    for (std::size_t p = 0; p < open_.frames.size(); ++p) {
      if (!open_.frames[p].cam_from_submap || open_.frames[p].rotation_only()) continue;
      std::size_t gap = open_.frames.size();
      for (std::size_t k : open_.keyframe_frame_positions) gap = std::min(gap, k > p ? k - p : p - k);
      if (gap > best_gap) {
        best_gap = gap;
        best = p;
      }
    }
    if (best && best_gap >= 2) {
      AddKeyframe(*best);
      OptimiseAndFilter();
    }
  }
  if (open_.bootstrapped && static_cast<int>(open_.keyframes.size()) >= 3) {
    if (std::optional<Submap> submap = Complete()) completed.push_back(std::move(*submap));
  } else if (!open_.frames.empty()) {
    ++stats_.submaps_discarded;
    GLAM_LOG_INFO("end of input: open submap with {} keyframes and {} frames discarded",
                  open_.keyframes.size(), open_.frames.size());
  }
  open_ = OpenSubmap{};
  return completed;
}

void SubmapBuilder::HandOffOverlap(std::vector<Submap>* completed) {
  const std::size_t n = open_.frames.size();
  const std::size_t overlap =
      std::max<std::size_t>(2, static_cast<std::size_t>(std::ceil(options_.overlap_fraction * n)));
  // The next submap's first keyframe should have full SIFT features: the overlap start moves
  // back to the nearest detected frame (at most one detection interval; the overlap grows).
  std::size_t first_position = n - std::min(overlap, n);
  for (std::size_t p = first_position + 1; p-- > 0 && first_position - p < kMaxOverlapShift;) {
    if (open_.frames[p].detected) {
      first_position = p;
      break;
    }
  }
  const std::size_t tail_position =
      options_.extend_short_final_submap && !open_.keyframe_frame_positions.empty()
          ? std::min(open_.keyframe_frame_positions[open_.keyframe_frame_positions.size() / 2], first_position)
          : first_position;
  if (std::optional<Submap> submap = Complete()) completed->push_back(std::move(*submap));
  // Complete() is done with the frames: the tail and the overlap are moved out, not copied
  // (features are ~270 KB per frame); their poses and matches are reset when re-tracked.
  const auto begin = std::make_move_iterator(open_.frames.begin());
  previous_tail_.assign(begin + static_cast<std::ptrdiff_t>(tail_position),
                        begin + static_cast<std::ptrdiff_t>(first_position));
  std::deque<FrameRecord> replay(begin + static_cast<std::ptrdiff_t>(first_position),
                                 std::make_move_iterator(open_.frames.end()));
  // The next submap bootstraps from the overlap's first frame and re-tracks the rest.
  RestartWith(std::move(replay), {}, completed);
}

}  // namespace glam
