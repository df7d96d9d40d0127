// One frame's features as the feature stage hands them to the submap builder (thread 1).
#pragma once

#include <cstdint>

#include "engine/features/features.h"

namespace glam {

struct FrameFeatures {
  std::int64_t index = 0;   // input frame index
  double timestamp_s = 0;   // the frame's time (its middle row's, under a rolling shutter)
  Features features;
};

}  // namespace glam
