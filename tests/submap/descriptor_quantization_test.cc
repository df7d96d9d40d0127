// CompactFeatures keeps descriptors as bytes, min(255, round(512 v)) (frame_record.h). The
// quantisation avoids a libm call per value; it must give exactly what clamp(lround(512 v))
// gives, ties (k + 0.5) / 512 included, so that maps do not change with it.
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "engine/submap/frame_record.h"

namespace glam {
namespace {

std::uint8_t Reference(float v) {
  if (std::isnan(v)) return 0;
  return static_cast<std::uint8_t>(std::clamp(std::lround(512.0f * v), 0L, 255L));
}

TEST(DescriptorQuantization, RoundsHalfAwayFromZeroAndClampsLikeLround) {
  std::vector<float> values;
  for (int k = -4; k <= 600; ++k) {
    const float tie = (static_cast<float>(k) + 0.5f) / 512.0f;
    values.push_back(static_cast<float>(k) / 512.0f);
    values.push_back(tie);
    values.push_back(std::nextafter(tie, 0.0f));
    values.push_back(std::nextafter(tie, 1.0f));
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> uniform(-0.1f, 0.7f);
  for (int i = 0; i < 200000; ++i) values.push_back(uniform(rng));
  values.push_back(std::numeric_limits<float>::infinity());
  values.push_back(-std::numeric_limits<float>::infinity());
  values.push_back(std::numeric_limits<float>::quiet_NaN());
  values.push_back(1e30f);
  values.push_back(-0.0f);
  while (values.size() % kDescriptorSize != 0) values.push_back(0.25f);

  std::size_t checked = 0;
  for (std::size_t start = 0; start < values.size(); start += kDescriptorSize) {
    const Descriptor d = QuantizeDescriptor(&values[start]);
    for (int i = 0; i < kDescriptorSize; ++i) {
      const float v = values[start + static_cast<std::size_t>(i)];
      if (v > 1e9f) {  // beyond lround's range (it overflows there): saturated
        EXPECT_EQ(d[i], 255);
      } else {
        ASSERT_EQ(d[i], Reference(v)) << "v = " << v << " (512 v = " << 512.0f * v << ")";
      }
      ++checked;
    }
  }
  EXPECT_EQ(checked, values.size());
  // Dequantising inverts it to within 1/1024 inside the range.
  std::vector<float> row(kDescriptorSize, 0.2f);
  float back[kDescriptorSize];
  DequantizeDescriptor(QuantizeDescriptor(row.data()), back);
  for (float b : back) EXPECT_NEAR(b, 0.2f, 1.0 / 1024.0);
}

}  // namespace
}  // namespace glam
