// Thread 1 of GLAM: turns a stream of frame features into completed, rigid submaps (paper,
// "Local Submap Creation"). One instance per job; not thread-safe (it *is* the thread).
//
// Per frame: bootstrap (first keyframe fixed at the origin, essential-matrix RANSAC until
// the second keyframe), or tracking (landmarks projected with a constant-velocity prediction,
// guided descriptor matching, EPnP RANSAC). When PnP inliers fall below tau_resection a middle
// keyframe and the current frame become keyframes, new landmarks are triangulated between
// them and everything is bundle adjusted. At keyframes_per_submap keyframes the submap is
// completed: all its frames are relocalised against the final landmarks, and the next submap
// starts at the first frame of the last 10 % of this one's frames (replayed from memory), so
// consecutive submaps share ground. Tracking loss closes the submap at the previous frame and
// bootstraps a new one at the current frame. When the focal is being estimated and the
// estimate (or the radial distortion k1's effect at the image corner) moved by more than 2 %
// while a submap was built, the submap is tracked again from its first frame at the new
// camera before it completes (SubmapOptions::rebuild_focal_change).
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "engine/core/camera.h"
#include "engine/core/cancellation.h"
#include "engine/features/feature_matcher.h"
#include "engine/features/features.h"
#include "engine/geometry/ransac.h"
#include "engine/map/submap.h"
#include "engine/submap/frame_record.h"
#include "engine/submap/submap_options.h"

namespace glam {

struct SubmapBuilderStats {
  std::int64_t frames_seen = 0;
  std::int64_t frames_tracked = 0;   // posed by tracking (before relocalisation)
  std::int64_t keyframes = 0;        // over all submaps
  std::int64_t submaps_completed = 0;
  std::int64_t submaps_discarded = 0;  // closed with < 3 keyframes, or no map after completion
  std::int64_t tracking_losses = 0;
  // Tracked frames whose guided matching around the predicted pose failed, so they were
  // matched against every landmark of the open submap (25-70 ms each; posed or not).
  std::int64_t frames_matched_globally = 0;
  // Landmarks removed as lying on moving content (SubmapOptions::moving_landmark_frames).
  std::int64_t moving_landmarks_removed = 0;
  std::int64_t frames_rotation_only = 0;  // posed by rotation only (SubmapOptions::hover_max_speed)
  std::int64_t submap_rebuilds = 0;  // open submaps tracked again after a focal or k1 change
  // SubmapOptions::bootstrap_twin_*: open submaps tracked again from the other motion of a
  // focal-dependent bootstrap, and how many of those builds were kept.
  std::int64_t bootstrap_twin_checks = 0;
  std::int64_t bootstrap_twins_kept = 0;
  double bundle_adjust_seconds = 0;
  // Where the first completed submap's bundle adjustment takes a fixed focal when it is let
  // free (processing pixels; SubmapOptions::check_fixed_focal). Unset while refining anyway.
  std::optional<double> free_focal_px;
  // How much lower the free focal's reprojection rms is than the fixed one's (relative, >= 0
  // up to solver noise); set with free_focal_px.
  std::optional<double> free_focal_rms_gain;
  // SubmapOptions::focal_profile_step: the smaller relative rms increase of the two fixed-focal
  // adjustments either side of the estimate (unset when not checked), and whether the focal
  // was therefore held at its initial value.
  std::optional<double> focal_profile_rms_increase;
  bool focal_held = false;
  // SubmapOptions::k1_profile_min_rms_increase: how much higher (relative) the first submap's
  // reprojection rms is with k1 fixed at its initial value than at the estimate (unset when
  // not checked), and whether k1 was therefore held at the initial value.
  std::optional<double> k1_profile_rms_increase;
  bool k1_held = false;
  // SubmapOptions::estimate_readout: the rolling-shutter readout decided on the first submap
  // (ms; unset when not estimated) and the profile's rms at each readout tried (ms, px).
  std::optional<double> readout_ms;
  std::vector<std::pair<double, double>> readout_profile;
  // The submap whose profile decided (the submaps before it were mapped uncorrected).
  std::int64_t readout_decided_at_submap = 0;
};

// The rolling-shutter readout profile's adjustment problem (camera_estimation.cc).
struct ReadoutProblem;

class SubmapBuilder {
 public:
  // `intrinsics` at processing size; its fx is the initial focal guess, refined by BA.
  SubmapBuilder(const Intrinsics& intrinsics, const SubmapOptions& options,
                CancellationToken cancel = {});

  // Consumes the features of the next frame (increasing index). Returns the submaps this
  // frame completed (usually none, rarely two when a replayed overlap completes at once).
  std::vector<Submap> AddFrame(std::int64_t index, double timestamp_s, const Features& features);

  // End of input: closes the open submap if it has >= 3 keyframes. A submap that did not
  // reach keyframes_per_submap is first tracked again from the middle keyframe of the previous
  // submap (SubmapOptions::extend_short_final_submap).
  std::vector<Submap> Finish();

  // Running median of all keyframes' refined focal lengths (the paper's focal estimate).
  double focal() const { return focal_; }
  // Radial distortion estimate (BundleAdjustmentOptions::refine_k1): the latest bundle
  // adjustment's shared k1; the initial one while it is not refined.
  double k1() const { return k1_; }
  const SubmapBuilderStats& stats() const { return stats_; }
  // Continue a resumed run: the first submap this builder completes gets `next_submap_id`
  // (ids stay unique in the job's submaps/ folder). `focal_held`: the interrupted run held the
  // focal at its initial value (SubmapOptions::focal_profile_step), so this one keeps the
  // focal it was constructed with fixed as well; `k1_held` likewise for k1. Only before the
  // first AddFrame.
  // `readout_ms`: the rolling-shutter readout the interrupted run decided on (estimate_readout).
  void ResumeAt(std::uint32_t next_submap_id, bool focal_held = false, bool k1_held = false,
                std::optional<double> readout_ms = std::nullopt);
  // Id the next completed submap will get; also the number of submaps emitted so far.
  std::uint32_t next_submap_id() const { return next_submap_id_; }
  // Frame index of the first frame of the open submap (resume point), if any.
  std::optional<std::int64_t> open_submap_first_frame() const;

  // A provisional copy of the open submap, for showing the map grow between completions (a
  // submap of keyframes_per_submap keyframes spans tens of seconds of flight): id =
  // next_submap_id(), its keyframes, landmarks (positions and colours only: no descriptors or
  // observations) and the poses of its posed frames so far, as tracking left them (no completion
  // adjustment, relocalisation or filter pass yet). Unset until the open submap has at least
  // `min_keyframes` keyframes (>= 2: bootstrapped). Costs a copy of the landmarks' positions.
  std::optional<Submap> OpenSubmapPreview(std::size_t min_keyframes = 2) const;

 private:
  // Per-landmark data needed only while the submap is open.
  struct LandmarkExtra {
    Eigen::Vector3d first_view_direction;  // unit, submap frame
  };
  struct OpenSubmap {
    std::deque<FrameRecord> frames;
    std::vector<Keyframe> keyframes;
    std::vector<std::size_t> keyframe_frame_positions;  // position in `frames`
    std::vector<Landmark> landmarks;
    std::unordered_map<std::uint32_t, LandmarkExtra> extras;
    std::uint32_t next_landmark_id = 0;
    // SubmapOptions::moving_landmark_frames: per landmark, its run of PnP rejections in a row
    // whose residual kept its direction and grew (frames that do not match it do not end the
    // run, an inlier does) and the latest residual; the landmarks whose run reached the
    // option, removed before the next bundle adjustment unless an inlier again by then.
    struct Rejections {
      int frames = 0;
      Eigen::Vector2f residual_px = Eigen::Vector2f::Zero();
    };
    std::unordered_map<std::uint32_t, Rejections> rejections;
    std::unordered_set<std::uint32_t> moving_landmarks;
    // Landmarks with smaller ids have passed the isolated-point filter once (OptimiseAndFilter).
    std::uint32_t first_unfiltered_landmark_id = 0;
    int tau_resection = 0;
    int tau_stereo = 0;
    bool bootstrapped = false;
    std::size_t bootstrap_first = 0;  // position of the first keyframe candidate in `frames`
    double start_focal = 0;           // focal estimate when this submap (or its rebuild) started
    double start_k1 = 0;              // k1 estimate then
    int rebuilds = 0;                 // times this submap was rebuilt (SubmapOptions)
    // Reprojection rms (px) of the latest bundle adjustment of this submap.
    double last_ba_rms = 0;
    // Motions as camera centre directions of the second bootstrap keyframe seen from the
    // first (unit, submap frame): the bootstrap's, and for SubmapOptions::bootstrap_twin_* the
    // one it is steered to (set once a check decided; kept through rebuilds from the same
    // first frame) and, while its check is pending, the other basin's motion with the focal
    // at which the bootstrap's views gave it.
    std::optional<Eigen::Vector3d> bootstrap_direction;
    std::optional<Eigen::Vector3d> bootstrap_preference;
    struct Twin {
      Eigen::Vector3d direction;
      double focal = 0;
    };
    std::optional<Twin> bootstrap_twin;
    bool bootstrap_twin_checked = false;
  };
  // What a restarted open submap keeps from the one it replaces (RestartWith).
  struct RestartCarry {
    int rebuilds = 0;
    std::optional<Eigen::Vector3d> bootstrap_preference;
    bool bootstrap_twin_checked = false;
  };
  // Everything CheckBootstrapTwin() may have to put back.
  struct BuilderState {
    OpenSubmap open;
    double focal = 0;
    double k1 = 0;
    std::vector<double> completed_keyframe_focals;
    std::deque<FrameRecord> previous_tail;
    SubmapOptions options;
    std::uint32_t next_submap_id = 0;
    bool camera_decisions_open = true;
    SubmapBuilderStats stats;
  };

  void Process(FrameRecord record, std::vector<Submap>* completed);
  // Median angle (degrees) between the rays from the last keyframe and from `frame` to the
  // landmarks `frame` tracks.
  double ParallaxToLastKeyframeDeg(const FrameRecord& frame) const;
  // Parallax to the last keyframe of at least twice min_triangulation_angle_deg: the middle
  // keyframe / `frame` pair of a new keyframe can triangulate.
  bool CanTriangulateWithLastKeyframe(const FrameRecord& frame) const;
  // MapCoverage of the posed `frame`: the open submap's landmarks projected with its pose.
  double MapCoverageOf(const FrameRecord& frame) const;
  // MapCoverageOf(frame) below SubmapOptions::min_map_coverage (logged).
  bool MapCoverageLow(const FrameRecord& frame) const;
  // Position in `frames` of the newest posed frame after the last keyframe, if any.
  std::optional<std::size_t> LastTrackedAfterLastKeyframe() const;

  // bootstrap.cc: returns true once the second keyframe exists.
  bool TryBootstrap();
  RansacOptions BootstrapRansacOptions() const;
  // SubmapOptions::bootstrap_twin_focal_step: the motion the bootstrap's views give at a
  // focal that much lower or higher, if it lies in another basin than the bootstrap's
  // (open_.bootstrap_direction); only while the first submap estimates the focal.
  std::optional<OpenSubmap::Twin> FocalTwin(const FrameRecord& first, const FrameRecord& second,
                                            const std::vector<Match>& matches) const;
  // bootstrap_twin.cc (SubmapOptions::bootstrap_twin_*): whether the open submap's
  // focal-dependent bootstrap is due for its check, and the check itself (the open submap is
  // tracked again from the other motion; the better build is kept).
  bool BootstrapTwinCheckDue() const;
  void CheckBootstrapTwin(std::vector<Submap>* completed);
  BuilderState SaveState() const;
  void RestoreState(BuilderState state);
  void StartSubmapAt(std::deque<FrameRecord> frames);
  // At completion (and at the end of input): re-tracks the open submap's frames from its first
  // one at the current camera when the focal estimate, or the k1 estimate's radial scale at
  // the image corner, moved by more than SubmapOptions::rebuild_focal_change since the submap
  // started; the replay then goes on as usual (and completes it). Returns whether it did.
  bool RebuildIfCameraMoved(std::vector<Submap>* completed);
  // max(|relative focal change|, |k1 change| * r^2 at the image corner) since the open submap
  // started: both are relative changes of a corner pixel's distance from the centre.
  double CameraChangeSinceSubmapStart() const;
  // SubmapOptions::focal_profile_step, on the open submap: the smaller relative rms increase
  // of fixing the focal (1 -/+ step) times the estimate instead of at it (each adjusted to
  // convergence on a copy).
  double FocalProfileRmsIncrease();
  // The focal goes back to the builder's initial one and stays fixed (stats().focal_held); the
  // caller re-tracks the open submap if it was adjusted with another.
  void HoldInitialFocal();
  // Reprojection rms of the open submap's keyframes and landmarks bundle adjusted on a copy
  // with `ba` and `camera` (every keyframe at `focal` when given); the time counts in stats().
  // `adjusted_focal`, when given, receives the copy's focal after the adjustment (the median
  // over its keyframes).
  double AdjustedCopyRms(const Intrinsics& camera, const BundleAdjustmentOptions& ba,
                         std::optional<double> focal, double* adjusted_focal = nullptr);
  // SubmapOptions::k1_profile_min_rms_increase, on the open submap: the relative rms increase
  // of k1 fixed at its initial value over k1 fixed at the estimate (each adjusted to
  // convergence on a copy); `focal_at_initial_k1` receives the focal of the copy adjusted at
  // the initial k1.
  double K1ProfileRmsIncrease(double* focal_at_initial_k1);
  // k1 goes back to the initial one and stays fixed (stats().k1_held); the caller re-tracks.
  void HoldInitialK1();
  // SubmapOptions::estimate_readout, at the completion of the first submaps until decided (at
  // most readout_max_submaps): the readout profile. Returns whether the readout changed (the caller then re-tracks the open submap, whose
  // frames Process() corrects for the new readout).
  bool DecideReadout();
  // The open submap's keyframes and a subset of its landmarks bundle adjusted on a copy whose
  // observations are corrected for `readout_s` instead of the current readout, starting from
  // `start` (another readout's solution) or from the submap's current state.
  struct ReadoutSolution {
    std::vector<Keyframe> keyframes;
    std::vector<Eigen::Vector3d> points;  // per landmark of the problem
    double rms_px = 0;
  };
  ReadoutSolution AdjustAtReadout(const ReadoutProblem& problem, double readout_s, const ReadoutSolution* start);
  // On the job's first submap, once, while k1 is refined: the k1 profile, and HoldInitialK1()
  // when it says the images do not ask for the estimate. Returns whether it held k1, nullopt
  // when it did not decide (already decided, decisions closed, k1 not refined).
  std::optional<bool> DecideK1();
  // Whether the open submap, about to be completed, takes the camera decisions: the first one
  // with at least half of keyframes_per_submap keyframes (or the one open at the end of the
  // input). A shorter first submap closed by a tracking loss is a fragment (measured: a
  // gimbal tilting down from near the horizon at the start, 5 keyframes over 59 frames, whose
  // k1 profile then held k1 and whose focal ended 4.4 % off for the whole flight): the
  // decisions wait for the next submap.
  bool CameraDecidingSubmap() const;
  // Starts a new open submap at frames.front() (with what `carry` keeps) and feeds the other
  // frames, kept in memory, through Process() again, forgetting their earlier poses. Shared by
  // the overlap hand-off, the rebuild and the twin check.
  void RestartWith(std::deque<FrameRecord> frames, const RestartCarry& carry, std::vector<Submap>* completed);

  // tracking.cc: poses `record` against the landmarks; false if tracking is lost.
  bool Track(FrameRecord& record);
  // SubmapOptions::moving_landmark_frames: updates the rejection runs with the posed `record`.
  void FollowRejectedLandmarks(const FrameRecord& record);
  // Removes the landmarks FollowRejectedLandmarks found moving (before an adjustment).
  void RemoveMovingLandmarks();
  // `predicted` is taken by value: callers pass record.cam_from_submap itself (relocalisation
  // from the tracked pose), which Localise clears first.
  bool Localise(FrameRecord& record, std::optional<SE3> predicted) const;
  // Guided from `predicted` (when given), then against all landmarks (25-70 ms per frame) only
  // if that fails; *matched_globally (when given) is set when a guided attempt fell back.
  bool LocaliseGuidedFirst(FrameRecord& record, std::optional<SE3> predicted,
                           bool* matched_globally = nullptr) const;
  // Constant-velocity prediction (motion_prediction.h) from the newest two posed frames before
  // `record` (a frame of the open submap), to its time.
  std::optional<SE3> PredictPose(const FrameRecord& record) const;

  // tracking_rotation.cc (SubmapOptions::hover_max_speed): poses the frame at `position`, which
  // tracking could not pose, by rotation only from the frame before it when the drone was
  // hovering; false when it cannot.
  bool PoseByRotationOnly(std::size_t position);
  // Whether the camera was hovering at the posed frame at `position` (the start of a rotation
  // chain): its centre moved less than hover_max_speed x the median depth of its landmarks per
  // second between the first and the last frame of HoverWindow(position).
  bool HoveringAt(std::size_t position) const;
  // Positions of the PnP-posed frames 0.2-0.7 s before the frame at `position`, newest first,
  // and the mean of their centres (the frame's own centre when there are none): where a chain
  // starting after `position` holds the camera.
  std::vector<std::size_t> HoverWindow(std::size_t position) const;
  Eigen::Vector3d HoverCentre(std::size_t position) const;
  // After relocalisation and smoothing: every rotation-only frame takes the centre of the frame
  // before it and its rotation composed with that frame's (in order, so chains follow their
  // first frame's final pose); unposed when that frame lost its pose.
  void RederiveRotationOnlyPoses();

  // keyframe_insertion.cc
  void InsertKeyframes(std::size_t current_position);
  void AddKeyframe(std::size_t position);
  void ObserveNewLandmarksInEarlierKeyframes(std::size_t first_new);
  std::size_t TriangulateBetween(std::size_t first_position, std::size_t second_position);
  // The matches (query = row of rows_second, train = row of rows_first) triangulated between
  // two posed frames (SubmapOptions::epipolar_triangulation_matching); *_rays: those rows'
  // normalised image coordinates.
  std::vector<Match> MatchForTriangulation(const FrameRecord& first, const std::vector<int>& rows_first,
                                           const std::vector<Eigen::Vector2d>& first_rays, const FrameRecord& second,
                                           const std::vector<int>& rows_second,
                                           const std::vector<Eigen::Vector2d>& second_rays) const;
  void OptimiseAndFilter();
  void UpdateFocalEstimate();

  // submap_completion.cc
  // The open submap as a finished Submap, or nullopt (counted in submaps_discarded) when the
  // completion filters leave it fewer landmarks than tracking needs to pose one frame
  // (SubmapOptions::min_tracking_inliers): such a submap is no map. Seen after a hovering yaw,
  // where a submap bootstrapped between a frame before the yaw and one after it (74 landmarks
  // at an apparent 6.4 degrees) kept keyframes only a few frames apart until tracking was lost;
  // the adjustments then showed the true parallax (under 1 degree) and the weak-triangulation
  // filter removed every landmark, leaving a 27-frame part with no points.
  std::optional<Submap> Complete();
  // Relocalises frames by PnP against the final landmarks; frames whose position in `frames`
  // is in `keep` (already refined) are left as they are.
  void RelocaliseFrames(const std::vector<bool>& keep = {});
  // The completion bundle adjustment (SubmapOptions::completion_ba_max_frames); returns which
  // frame positions it refined.
  std::vector<bool> RefineWithTrackedFrames();
  // SubmapOptions::centre_smoothing over the posed frames of the open submap (after the
  // relocalisation; centre_smoothing.h).
  void SmoothFrameCentres();
  void HandOffOverlap(std::vector<Submap>* completed);
  // SubmapOptions::check_fixed_focal, on the open submap (once per builder).
  void CheckFixedFocal();

  Camera CurrentCamera() const;
  const Landmark* FindLandmark(std::uint32_t id) const;
  Landmark* FindLandmark(std::uint32_t id);

  Intrinsics intrinsics_;
  SubmapOptions options_;
  CancellationToken cancel_;
  double focal_;
  double k1_;
  // Rolling-shutter readout (s) the frames are corrected for (CompactFeatures::ApplyReadout);
  // decided by DecideReadout() while readout_decision_open_.
  double readout_s_ = 0;
  bool readout_decision_open_ = false;
  int readout_profiles_ = 0;  // readout profiles run (one per submap while undecided)
  std::int64_t readout_profiled_submap_ = -1;
  std::vector<double> completed_keyframe_focals_;  // for the running median
  OpenSubmap open_;
  // Frames of the last completed submap from its middle keyframe to the overlap start, kept
  // so that a short submap closed by the end of input can be rebuilt over them (Finish()).
  std::deque<FrameRecord> previous_tail_;
  bool extending_tail_ = false;  // replaying previous_tail_: no completion by keyframe count
  bool finishing_ = false;  // end of input: bootstrap accepts any frame with enough parallax
  std::uint32_t next_submap_id_ = 0;
  // The camera decisions (focal and k1 profiles) are still to be taken: until the first
  // submap that is not a fragment is emitted (CameraDecidingSubmap), and never in a resumed run.
  bool camera_decisions_open_ = true;
  SubmapBuilderStats stats_;
};

}  // namespace glam
