// Verification of a candidate pair of submaps (paper, "Global Submap Alignment"): landmarks
// are matched by descriptor and the similarity reference_from_query is found by Sim3 RANSAC
// (closed-form Umeyama on 3-point samples, the project's one RANSAC template) on the 3D-3D
// correspondences; the pair is accepted only with enough inliers AND a high enough inlier
// ratio, and only the inlier correspondences go on to the factor graph.
//
// Used for both kinds of edges: temporal neighbours (the next submap starts inside the
// previous one's last 10 % of frames, so both triangulated the same ground) and candidates
// retrieved by the vocabulary tree (loop closures, re-localisation after a tracking loss).
// Submap units are arbitrary (monocular), so the inlier threshold is a fraction of the
// reference submap's own depth scale (median distance of its landmarks to the nearest
// keyframe centre, i.e. roughly the flying height in submap units).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "engine/alignment/landmark_match.h"
#include "engine/core/sim3.h"
#include "engine/map/submap.h"

namespace glam {

struct VerificationOptions {
  float match_ratio = 0.8f;        // Lowe's ratio test on landmark descriptors
  bool mutual = true;              // cross-checked matches only
  // RANSAC inlier threshold = this x SubmapDepthScale(reference).
  double inlier_threshold_fraction = 0.02;
  int min_inliers = 15;            // fewer -> the pair is rejected
  double min_inlier_ratio = 0.2;   // inliers / matches below this -> rejected
  // Rejects a pair whose inliers pin the rotation down worse than this (standard deviation in
  // degrees about the weakest axis, from the inliers' spread and residual; 0 = no check).
  // True edges on the loop clip measure 0.02-0.41 deg; the false ones, 30-35 inliers in a
  // small patch 3-5 deg off, 0.97-1.55 deg.
  double max_rotation_sigma_deg = 0.6;
  int max_iterations = 1000;
  double confidence = 0.999;
  unsigned seed = 1;

  void Check() const;  // throws InputError
};

struct PairVerification {
  bool verified = false;
  Sim3 reference_from_query;  // identity when !verified
  int matches = 0;
  int inliers = 0;
  double inlier_rmse = 0;  // in the reference submap's units
  // Standard deviation (degrees) of the rotation about its weakest axis implied by the inlier
  // residual and the inliers' spread: a few inliers in a small patch leave it loose.
  double rotation_sigma_deg = 0;
  // a = reference, b = query; empty when !verified.
  std::vector<LandmarkMatch> inlier_pairs;
};

// Median over landmarks of the distance to the nearest keyframe centre; 1 if undefined.
double SubmapDepthScale(const Submap& submap);

PairVerification VerifySubmapPair(const Submap& reference, const Submap& query,
                                  const VerificationOptions& options = {});

}  // namespace glam
