// MapCoverage (engine/submap/frame_record.h): the share of a frame's textured grid cells that
// hold a projected landmark, what the coverage keyframe rule (SubmapOptions::min_map_coverage)
// reads. Known answers on hand-placed keypoints and projections.
#include <vector>

#include <gtest/gtest.h>

#include "engine/submap/frame_record.h"

namespace glam {
namespace {

// Keypoints: `per_cell` at the centre of every cell of a `columns` x `rows` grid over the image.
std::vector<Eigen::Vector2f> KeypointsInEveryCell(int width, int height, int columns, int rows, int per_cell) {
  std::vector<Eigen::Vector2f> points;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < columns; ++c) {
      for (int k = 0; k < per_cell; ++k) {
        points.emplace_back((c + 0.5f) * width / columns, (r + 0.5f) * height / rows);
      }
    }
  }
  return points;
}

TEST(MapCoverage, CountsTexturedCellsHoldingAMappedPoint) {
  // 640x360 with 8 columns: 5 rows of 80x72 px cells, 40 cells in all.
  const std::vector<Eigen::Vector2f> keypoints = KeypointsInEveryCell(640, 360, 8, 5, 3);
  EXPECT_DOUBLE_EQ(MapCoverage(keypoints, {}, 640, 360), 0.0);
  // A drone that climbed: its landmarks project into the central 4 x 3 cells only.
  std::vector<Eigen::Vector2d> central;
  for (int r = 1; r <= 3; ++r) {
    for (int c = 2; c <= 5; ++c) central.emplace_back(c * 80 + 40, r * 72 + 10);
  }
  EXPECT_DOUBLE_EQ(MapCoverage(keypoints, central, 640, 360), 12.0 / 40.0);
  // Several mapped points in one cell count once; points on the image border are clamped in.
  central.emplace_back(2 * 80 + 1, 72 + 1);
  central.emplace_back(639.9, 359.9);
  EXPECT_DOUBLE_EQ(MapCoverage(keypoints, central, 640, 360), 13.0 / 40.0);
}

TEST(MapCoverage, UntexturedCellsDoNotCount) {
  // Keypoints in the two bottom rows only (ground below a textureless sky): 16 of the 40
  // cells are textured; a mapped point in the sky changes nothing.
  std::vector<Eigen::Vector2f> keypoints;
  for (const Eigen::Vector2f& p : KeypointsInEveryCell(640, 360, 8, 5, 3)) {
    if (p.y() > 3 * 72) keypoints.push_back(p);
  }
  std::vector<Eigen::Vector2d> mapped = {{40, 3 * 72 + 36}, {120, 4 * 72 + 36}, {300, 20}};
  EXPECT_DOUBLE_EQ(MapCoverage(keypoints, mapped, 640, 360), 2.0 / 16.0);
  // Below min_features keypoints a cell is not textured.
  const std::vector<Eigen::Vector2f> sparse = KeypointsInEveryCell(640, 360, 8, 5, 2);
  EXPECT_DOUBLE_EQ(MapCoverage(sparse, {}, 640, 360), 1.0);  // nothing textured: nothing unmapped
  EXPECT_DOUBLE_EQ(MapCoverage(sparse, {}, 640, 360, 8, 2), 0.0);
}

TEST(MapCoverage, GridRowsFollowTheAspectRatio) {
  // A portrait frame 360x640 with 4 columns has 7 rows (round(4 * 640 / 360)).
  const std::vector<Eigen::Vector2f> keypoints = KeypointsInEveryCell(360, 640, 4, 7, 3);
  std::vector<Eigen::Vector2d> mapped;
  for (const Eigen::Vector2f& p : keypoints) {
    if (p.y() < 640.0 / 7) mapped.push_back(p.cast<double>());  // the top row
  }
  EXPECT_DOUBLE_EQ(MapCoverage(keypoints, mapped, 360, 640, 4), 4.0 / 28.0);
}

}  // namespace
}  // namespace glam
