// The one grey conversion of the feature stage: SIFT detects on grey images and KLT tracks
// on them, both from the decoder's BGR frames (or from already-grey images, passed through).
#pragma once

#include <opencv2/core.hpp>

namespace glam {

// `image` (8-bit, 1 or 3 channels, BGR) as one 8-bit grey channel; a grey input is returned
// as is (shared, not copied).
cv::Mat ToGray(const cv::Mat& image);

}  // namespace glam
