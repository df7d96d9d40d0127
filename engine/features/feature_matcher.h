// Descriptor matching between two feature sets: 2-nearest-neighbour search with Lowe's ratio
// test (an ambiguous match, whose best and second-best candidates are almost equally close, is
// more often wrong than right) and an optional mutual (cross) check. Two search back-ends:
// a FLANN randomised kd-tree forest (approximate, sub-quadratic) and exact brute force
// (OpenCV's SIMD BFMatcher); kAuto picks whichever measured faster for the sizes at hand
// (see kAutoBruteForceMaxPairs).
#pragma once

#include <limits>
#include <vector>

#include <opencv2/core.hpp>

namespace glam {

struct Match {
  int query = -1;
  int train = -1;
  float distance = 0.f;  // L2 descriptor distance (not squared)
};

enum class MatcherType { kAuto, kFlann, kBruteForce };

struct MatchOptions {
  // Keep a match only if best < ratio * second best (Lowe's ratio test). 1 disables it.
  float ratio = 0.8f;
  // Keep a match only if the query is also the train feature's nearest query.
  bool mutual = false;
  // Reject matches farther than this (descriptor units; RootSIFT rows have unit norm, so
  // distances lie in [0, sqrt(2)]).
  float max_distance = std::numeric_limits<float>::infinity();
  MatcherType type = MatcherType::kAuto;
  // One kd-tree with 64 checks found 99.3 % of brute force's correct matches at half its time
  // (2000 x 2000 RootSIFT); 4 trees cost 1.7x more for +0.1 %.
  int flann_trees = 1;
  int flann_checks = 64;  // leaves visited per query: higher = more exact, slower
  unsigned seed = 0;      // kd-tree randomisation (deterministic results)

  void Check() const;  // throws InputError
};

// kAuto uses brute force when query rows x train rows is at most this. Measured on one core,
// RootSIFT from 720p aerial frames: FLANN (1 tree, 64 checks) costs about 4 ms to build per
// 2000 train rows plus 12 us per query; brute force about 14 ns per pair. So 500 x 2000:
// FLANN 10 ms vs 14 ms; 2000 x 2000: 28 vs 56 ms; 4000 x 4000: 67 vs 211 ms; below about
// 0.5 M pairs brute force wins (and is exact).
inline constexpr double kAutoBruteForceMaxPairs = 5e5;

// Matches each query row (CV_32F, N x D) to a train row (M x D). Returns matches sorted by
// query index; every train index appears at most once when mutual is set.
std::vector<Match> MatchDescriptors(const cv::Mat& query, const cv::Mat& train,
                                    const MatchOptions& options = {});

// The back-end kAuto would use for these sizes.
MatcherType ChooseMatcher(int query_rows, int train_rows);

}  // namespace glam
