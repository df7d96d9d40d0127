// points.ply (architecture Contracts): binary little-endian PLY with one `vertex` element of
// properties `x y z` (float) and `red green blue` (uchar). This is the whole-map point cloud
// download and the input of `glam eval`'s map metrics; fixing one layout keeps the writer
// trivial and lets the reader reject anything else with a clear message instead of guessing
// at property meanings. The reader also accepts the same layout in ASCII PLY, because people
// edit or generate small clouds by hand and by script.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <vector>

namespace glam {

struct ColoredPoint {
  Eigen::Vector3f position = Eigen::Vector3f::Zero();
  std::array<std::uint8_t, 3> color = {0, 0, 0};  // red, green, blue
};

// Throws EnvironmentError if the file cannot be written.
void WritePlyPoints(const std::filesystem::path& path, const std::vector<ColoredPoint>& points);

// Reads the contract layout (binary_little_endian or ascii). Comment and obj_info header
// lines are ignored; `float32`/`uint8` are accepted as synonyms of `float`/`uchar`. Throws
// InputError naming the file for a missing file, another format (e.g. big-endian), other
// elements or properties, a truncated body, or a non-finite coordinate.
std::vector<ColoredPoint> ReadPlyPoints(const std::filesystem::path& path);

}  // namespace glam
