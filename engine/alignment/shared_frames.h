// Correspondences from the frames two consecutive submaps share (the hand-off overlap: the
// next submap starts inside the previous one's last 10 % of frames and poses them again).
// The paper links such submaps through matched landmarks only; but both submaps also posed
// the same frames, and a camera pose is known far better than a single landmark (it rests on
// hundreds of them). Each shared frame contributes two point pairs: its camera centre, and
// the point one viewing depth ahead on its optical axis (which pins the rotation about the
// direction of flight, left free by centres along a nearly straight path). They join the
// temporal edge's landmark matches in the factor graph as ordinary nodes.
//
// Keys: frame f's pairs use the ids kSharedFrameIdBase + 2f and + 2f + 1 in both submaps, a
// range submap landmark ids never reach (they count up from 0 within one submap). A frame
// shared by three submaps thus stays one node per point, as it should.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "engine/alignment/landmark_match.h"
#include "engine/core/sim3.h"
#include "engine/map/submap.h"

namespace glam {

inline constexpr std::uint32_t kSharedFrameIdBase = 0xF0000000u;
// Frames from here on contribute no pairs (their ids would overflow); ~134 M frames.
inline constexpr std::int64_t kMaxSharedFrameIndex = (0xFFFFFFFFu - kSharedFrameIdBase) / 2;

struct SharedFrameOptions {
  // A shared frame whose two poses disagree (after reference_from_query) by more than this
  // fraction of the reference submap's viewing depth, at either of its points, is left out:
  // one of the submaps posed it badly (e.g. at a submap's unstable first frames).
  double max_disagreement_fraction = 0.02;

  void Check() const;  // throws InputError
};

// Pairs for every frame posed in both submaps (a = reference, b = query), consistent with
// `reference_from_query` (the verified Sim3 of the edge). Empty when they share no frames.
std::vector<LandmarkMatch> SharedFrameMatches(const Submap& reference, const Submap& query,
                                              const Sim3& reference_from_query,
                                              const SharedFrameOptions& options = {});

// reference_from_query from the shared frames alone, without landmark matching: where the
// hand-off puts a submap before alignment has verified it (the live preview of the open submap,
// engine/pipeline/open_submap_preview.h).
//  * Scale: in the shared frames, landmarks of the two submaps that project to the same pixel
//    (within 2 px) lie on the same ray, and the median ratio of their depths is the scale (the
//    camera centres of the few shared frames span too short a path to give it to better than
//    1-2 %). Without 20 such pairs it is fitted with the rest.
//  * Rotation and translation: each shared frame's centre, the point one viewing depth ahead
//    and one beside that along the image x axis (the camera's orientation fixes the rotation
//    about the flight path and the yaw, which centres along a short path leave loose).
//  * Frames that disagree (a point missing the fit by more than max_disagreement_fraction of
//    the reference depth) are found by fitting every pair of frames and keeping the largest
//    agreeing set, which is fitted again.
// Unset with fewer than 2 agreeing frames, or when their rms residual stays above that
// fraction: one of the two posed the shared frames differently.
std::optional<Sim3> EstimateFromSharedFrames(const Submap& reference, const Submap& query,
                                             const SharedFrameOptions& options = {});

}  // namespace glam
