// Map tiles: the Draco tile decodes (with Draco) to the source points within the stated
// quantisation bound and the exact colours; the KHR_mesh_quantization variant dequantizes within
// its bound and passes the Khronos glTF Validator without errors or warnings; empty and
// degenerate geometry gives valid files; the y-up convention is the +90 degree X rotation
// 3D Tiles clients undo.
#include <cmath>
#include <fstream>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "engine/core/atomic_file.h"
#include "engine/core/error.h"
#include "engine/export/glb_tile.h"
#include "tests/export/glb_test_util.h"

namespace glam {
namespace {

namespace fs = std::filesystem;
using glam::testing::DecodeDracoPoints;
using glam::testing::DequantizePoints;
using glam::testing::ParseGlb;
using glam::testing::TrajectoryPoints;

// An aerial-looking submap: a wide, shallow slab of points away from the origin, each with a
// unique colour (colour = point index) so decoded points can be matched to their source.
TileGeometry SyntheticGeometry(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> x(-40.f, 85.f), y(-30.f, 22.f), z(-3.f, 4.f);
  TileGeometry g;
  for (std::size_t i = 0; i < n; ++i) {
    ColoredPoint p;
    p.position = Eigen::Vector3f(x(rng) + 1000.f, y(rng) - 500.f, z(rng) + 12.f);
    p.color = {static_cast<std::uint8_t>(i & 0xff), static_cast<std::uint8_t>((i >> 8) & 0xff),
               static_cast<std::uint8_t>((i >> 16) & 0xff)};
    g.points.push_back(p);
  }
  for (int k = 0; k < 40; ++k) {
    g.trajectory.emplace_back(1000.f - 30.f + 2.f * static_cast<float>(k), -500.f + std::sin(0.2f * static_cast<float>(k)), 60.f);
  }
  return g;
}

std::size_t IndexOf(const ColoredPoint& p) {
  return static_cast<std::size_t>(p.color[0]) | (static_cast<std::size_t>(p.color[1]) << 8) |
         (static_cast<std::size_t>(p.color[2]) << 16);
}

// Every source point appears once among `decoded`, with its exact colour, within `bound` per
// coordinate (plus float rounding of coordinates of this magnitude). Returns the largest error.
double MatchPoints(const std::vector<ColoredPoint>& source, const std::vector<ColoredPoint>& decoded, double bound) {
  EXPECT_EQ(decoded.size(), source.size());
  std::set<std::size_t> seen;
  double worst = 0;
  const double rounding = 2e-4;  // a few float ulps at |x| ~ 1000
  for (const ColoredPoint& d : decoded) {
    const std::size_t index = IndexOf(d);
    if (index >= source.size()) {
      ADD_FAILURE() << "decoded colour matches no source point";
      continue;
    }
    EXPECT_TRUE(seen.insert(index).second) << "point " << index << " decoded twice";
    const double err = (d.position - source[index].position).cast<double>().cwiseAbs().maxCoeff();
    worst = std::max(worst, err);
    EXPECT_LE(err, bound + rounding) << "point " << index;
  }
  EXPECT_EQ(seen.size(), source.size());
  return worst;
}

TEST(GlbTile, YUpConventionIsUndoneByThePlus90DegreeXRotationOf3DTilesClients) {
  const Eigen::Matrix3f y_up_to_z_up = Eigen::AngleAxisf(static_cast<float>(M_PI / 2), Eigen::Vector3f::UnitX()).toRotationMatrix();
  const Eigen::Vector3f p(1.5f, -2.25f, 7.f);
  EXPECT_TRUE((y_up_to_z_up * GltfFromZUp(p)).isApprox(p, 1e-6f));
  EXPECT_EQ(GltfFromZUp(p), Eigen::Vector3f(1.5f, 7.f, 2.25f));
  EXPECT_EQ(ZUpFromGltf(GltfFromZUp(p)), p);
}

TEST(GlbTile, DracoTileDecodesWithinTheStatedBoundWithExactColours) {
  const TileGeometry geometry = SyntheticGeometry(20000, 7);
  const DracoTileOptions options;
  const std::string glb = EncodeDracoTileGlb(geometry, options);
  const tinygltf::Model model = ParseGlb(glb);
  ASSERT_EQ(model.extensionsRequired, std::vector<std::string>{"KHR_draco_mesh_compression"});
  const double bound = DracoPositionErrorBound(geometry.points, options.position_bits);
  // Stated bound: largest side (125 m here) / (2 * (2^14 - 1)).
  EXPECT_NEAR(bound, 125.0 / (2.0 * 16383.0), 0.01 * bound);
  const double worst = MatchPoints(geometry.points, DecodeDracoPoints(model), bound);
  // The bound is what Draco reaches, not a loose guess (uniform points fill the cells).
  EXPECT_GT(worst, 0.5 * bound);
  RecordProperty("draco_max_error_m", std::to_string(worst));
  RecordProperty("draco_bytes_per_point", std::to_string(double(glb.size()) / double(geometry.points.size())));
  std::printf("Draco tile: %zu points, %zu bytes (%.2f B/point, raw 15), max error %.2e (bound %.2e)\n",
              geometry.points.size(), glb.size(), double(glb.size()) / double(geometry.points.size()), worst, bound);
  // Trajectory stays float: exact after the axis round trip.
  const std::vector<Eigen::Vector3f> trajectory = TrajectoryPoints(model);
  ASSERT_EQ(trajectory.size(), geometry.trajectory.size());
  for (std::size_t k = 0; k < trajectory.size(); ++k) EXPECT_EQ(trajectory[k], geometry.trajectory[k]);
}

TEST(GlbTile, CoarserDracoQuantisationIsStillWithinItsBound) {
  const TileGeometry geometry = SyntheticGeometry(3000, 11);
  DracoTileOptions options;
  options.position_bits = 10;
  const tinygltf::Model model = ParseGlb(EncodeDracoTileGlb(geometry, options));
  const double bound = DracoPositionErrorBound(geometry.points, options.position_bits);
  const double worst = MatchPoints(geometry.points, DecodeDracoPoints(model), bound);
  EXPECT_GT(worst, 0.5 * bound);
}

TEST(GlbTile, QuantizedTileDequantizesWithinItsBoundAndValidates) {
  const TileGeometry geometry = SyntheticGeometry(5000, 3);
  const std::string glb = EncodeQuantizedTileGlb(geometry);
  const tinygltf::Model model = ParseGlb(glb);
  EXPECT_EQ(model.extensionsRequired, std::vector<std::string>{"KHR_mesh_quantization"});
  EXPECT_TRUE(model.extensionsUsed == std::vector<std::string>{"KHR_mesh_quantization"});
  const double bound = QuantizedPositionErrorBound(geometry.points);
  const std::vector<ColoredPoint> points = DequantizePoints(model);
  MatchPoints(geometry.points, points, bound);
  // Stored in source order.
  for (std::size_t i = 0; i < points.size(); ++i) ASSERT_EQ(IndexOf(points[i]), i);
  EXPECT_EQ(TrajectoryPoints(model).size(), geometry.trajectory.size());

  const fs::path dir = glam::testing::FreshTempDir("quantized_tile");
  WriteFileAtomically(dir / "tile.glb", glb);
  const nlohmann::json report = glam::testing::ValidateGltf(dir / "tile.glb");
  ASSERT_FALSE(report.is_null());
  EXPECT_EQ(report["issues"]["numErrors"], 0) << report.dump(1);
  EXPECT_EQ(report["issues"]["numWarnings"], 0) << report.dump(1);
  EXPECT_EQ(report["info"]["drawCallCount"], 2) << report.dump(1);
  fs::remove_all(dir);
}

TEST(GlbTile, DegenerateGeometryGivesValidFiles) {
  const fs::path dir = glam::testing::FreshTempDir("degenerate_tile");
  std::vector<TileGeometry> cases(4);
  // 0: nothing at all; 1: one point, one camera centre; 2: a flat tile (all z equal) with
  // repeated points; 3: a trajectory only.
  ColoredPoint single;
  single.position = Eigen::Vector3f(3, 4, 5);
  single.color = {10, 20, 30};
  cases[1].points = {single};
  cases[1].trajectory = {Eigen::Vector3f(0, 0, 50)};
  for (int i = 0; i < 50; ++i) {
    ColoredPoint p;
    p.position = Eigen::Vector3f(static_cast<float>(i % 7), static_cast<float>(i % 5), 2.f);
    p.color = {static_cast<std::uint8_t>(i), 0, 0};
    cases[2].points.push_back(p);
  }
  cases[3].trajectory = {Eigen::Vector3f(0, 0, 50), Eigen::Vector3f(1, 0, 50)};
  for (std::size_t c = 0; c < cases.size(); ++c) {
    SCOPED_TRACE("case " + std::to_string(c));
    const TileGeometry& g = cases[c];
    const tinygltf::Model draco = ParseGlb(EncodeDracoTileGlb(g));
    const std::string quantized_glb = EncodeQuantizedTileGlb(g);
    const tinygltf::Model quantized = ParseGlb(quantized_glb);
    EXPECT_EQ(glam::testing::FindNode(draco, "points") >= 0, !g.points.empty());
    EXPECT_EQ(glam::testing::FindNode(quantized, "trajectory") >= 0, g.trajectory.size() >= 2);
    if (!g.points.empty()) {
      const std::vector<ColoredPoint> decoded = DecodeDracoPoints(draco);
      const std::vector<ColoredPoint> dequantized = DequantizePoints(quantized);
      ASSERT_EQ(decoded.size(), g.points.size());
      ASSERT_EQ(dequantized.size(), g.points.size());
      std::multiset<std::array<std::uint8_t, 3>> want, got;
      for (std::size_t i = 0; i < g.points.size(); ++i) {
        want.insert(g.points[i].color);
        got.insert(decoded[i].color);
        EXPECT_LE((dequantized[i].position - g.points[i].position).cwiseAbs().maxCoeff(), 1e-4f);
      }
      EXPECT_EQ(want, got);
    }
    const fs::path file = dir / ("case" + std::to_string(c) + ".glb");
    WriteFileAtomically(file, quantized_glb);
    const nlohmann::json report = glam::testing::ValidateGltf(file);
    ASSERT_FALSE(report.is_null());
    EXPECT_EQ(report["issues"]["numErrors"], 0) << report.dump(1);
  }
  fs::remove_all(dir);
}

TEST(GlbTile, RejectsNonFiniteCoordinatesAndBadOptions) {
  TileGeometry g = SyntheticGeometry(10, 1);
  g.points[4].position.y() = std::nanf("");
  EXPECT_THROW(EncodeDracoTileGlb(g), InputError);
  EXPECT_THROW(EncodeQuantizedTileGlb(g), InputError);
  DracoTileOptions bad;
  bad.position_bits = 40;
  EXPECT_THROW(EncodeDracoTileGlb(SyntheticGeometry(10, 1), bad), InputError);
}

}  // namespace
}  // namespace glam
