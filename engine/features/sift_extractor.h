// SIFT (Lowe 2004), the paper's feature, through cv::SIFT. Aerial footage is smooth: with
// OpenCV's default contrast threshold 0.04 a 720p frame yields a few hundred keypoints, so the
// default here is 0.01 (about 2000 on the same frame). Optional grid bucketing keeps the
// strongest keypoints per cell so that features cover the whole image (texture-rich corners
// otherwise take the whole budget and the pose becomes ill-conditioned); optional downscaling
// trades accuracy for speed (SIFT cost grows with pixel count).
#pragma once

#include <memory>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "engine/features/features.h"

namespace glam {

struct SiftOptions {
  int max_features = 2000;
  double contrast_threshold = 0.01;
  double edge_threshold = 10.0;
  double sigma = 1.6;
  int octave_layers = 3;
  // Grid bucketing: keep at most ceil(max_features / cells) strongest keypoints per cell
  // (then fill the remaining budget with the strongest leftovers). grid_cols = 0: off.
  // grid_rows = 0: from the aspect ratio, floor(grid_cols * height / width), at least 1.
  // On (4 columns) by default: on four 300-frame lawnmower clips it raised the ground covered
  // by the map from 57-72 % to 64-80 % (docs/algorithm.md); the paper's method (SIFT alone)
  // is grid_cols = 0.
  int grid_cols = 4;
  int grid_rows = 0;
  // Detect on the image resized by this factor (0 < s <= 1); keypoints are mapped back to
  // full-resolution coordinates. 1 = full resolution.
  double extraction_scale = 1.0;
  // Hellinger-kernel normalisation (Arandjelovic & Zisserman 2012): L1-normalise, square root.
  // Matches better than plain SIFT under L2 at no cost; every consumer of descriptors (tracking,
  // duplicate removal, vocabulary) must use the same setting.
  bool root_sift = true;
  // With bucketing, how the descriptors are computed (the output is the same either way).
  // cv::SIFT rebuilds its Gaussian pyramid (image upsampled x2: ~11 ms at 640x360, one core)
  // when asked to describe given keypoints, and describes a keypoint in ~16 us. So when the
  // previous frame this extractor saw had at most max_features + single_pass_extra_keypoints
  // keypoints, all keypoints are detected and described in one pass and the bucketing picks
  // descriptor rows (describing up to ~700 extra keypoints costs less than the second
  // pyramid); otherwise the strongest are picked first and described in a second pass.
  // Measured (glam_bench_feature_stage, 640x360, one core): the loop benchmark video (~1700-1900
  // keypoints, fewer than the budget) 70 -> 65 ms per detection; the lawnmower video (~3800)
  // keeps the second pass. 0: one pass only when the previous frame fitted the budget;
  // -1: always two passes.
  int single_pass_extra_keypoints = 600;

  void Check() const;  // throws InputError
};

class SiftExtractor {
 public:
  explicit SiftExtractor(const SiftOptions& options = {});

  // image: 8-bit BGR (colours are sampled) or grey (colours are grey). Not thread-safe, not
  // even for const calls (it remembers the last keypoint count to choose the descriptor pass,
  // see SiftOptions::single_pass_extra_keypoints): use one extractor per thread.
  Features Extract(const cv::Mat& image) const;

  const SiftOptions& options() const { return options_; }

 private:
  // Indices of the keypoints the grid bucketing keeps (all of them when within the budget).
  std::vector<std::size_t> Bucket(const std::vector<cv::KeyPoint>& keypoints, cv::Size size) const;

  SiftOptions options_;
  cv::Ptr<cv::SIFT> sift_;
  // Keypoints detected on the previous image (before bucketing); 0 before the first.
  mutable std::size_t last_detected_ = 0;
};

// Offset (pixels, in x and y) of cv::SIFT keypoints relative to the integer-pixel-centre
// convention, subtracted by SiftExtractor (see Extract and tests/features).
inline constexpr float kSiftKeypointOffset = 0.25f;

// In-place RootSIFT on CV_32F rows.
void ApplyRootSift(cv::Mat* descriptors);

}  // namespace glam
