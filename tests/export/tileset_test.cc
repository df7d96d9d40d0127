// tileset.json from a MapSnapshot: the 3D Tiles 1.1 fields of the Contracts (revision as
// asset.tilesetVersion string and extras.revision number, refine ADD, one child per submap,
// disconnected marked), transforms equal to the snapshot's Sim3s (column-major), a tile point
// taken through glTF -> z-up -> transform lands at world_from_submap * point_in_submap, and the
// bounding volumes contain their points (child: submap frame; root: world frame).
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "engine/export/glb_tile.h"
#include "engine/export/tileset.h"
#include "tests/export/glb_test_util.h"

namespace glam {
namespace {

using nlohmann::json;

Sim3 RandomSim3(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  Vector7d xi;
  for (int k = 0; k < 7; ++k) xi[k] = n(rng);
  xi.head<3>() *= 50.0;
  xi[6] *= 0.7;
  return Sim3::Exp(xi);
}

std::vector<Eigen::Vector3d> RandomPoints(std::mt19937& rng, int n) {
  std::uniform_real_distribution<double> u(-20, 20);
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < n; ++i) out.emplace_back(u(rng) + 5, u(rng) - 3, 0.1 * u(rng) + 1);
  return out;
}

using glam::testing::FromColumnMajor;

// Point inside an axis-aligned 3D Tiles box [c, x-half, y-half, z-half] (relative tolerance).
bool InBox(const json& box, const Eigen::Vector3d& p) {
  for (int a = 0; a < 3; ++a) {
    const double c = box[static_cast<std::size_t>(a)].get<double>();
    const double h = box[static_cast<std::size_t>(3 + a * 4)].get<double>();
    if (std::abs(p[a] - c) > h * (1 + 1e-9) + 1e-9) return false;
  }
  return true;
}

struct Fixture {
  MapSnapshot snapshot;
  std::map<std::uint32_t, std::vector<Eigen::Vector3d>> points;
  std::map<std::uint32_t, Eigen::AlignedBox3d> bounds;
};

Fixture MakeFixture() {
  std::mt19937 rng(42);
  Fixture f;
  f.snapshot.revision = 17;
  for (std::uint32_t id = 0; id < 4; ++id) {
    SubmapPlacement placement;
    placement.id = id;
    placement.world_from_submap = RandomSim3(rng);
    placement.disconnected = id == 2;
    placement.first_frame = 100 * id;
    placement.last_frame = 100 * id + 120;
    f.snapshot.submaps.push_back(placement);
    f.points[id] = RandomPoints(rng, 200);
    for (const Eigen::Vector3d& p : f.points[id]) f.bounds[id].extend(p);
  }
  return f;
}

TEST(Tileset, CarriesTheRevisionAndOneChildPerSubmap) {
  const Fixture f = MakeFixture();
  const json tileset = BuildTileset(f.snapshot, f.bounds, TileVariant::kDraco);
  EXPECT_EQ(tileset["asset"]["version"], "1.1");
  EXPECT_EQ(tileset["asset"]["tilesetVersion"], "17");
  EXPECT_EQ(tileset["extras"]["revision"], 17);
  EXPECT_TRUE(tileset["extras"]["revision"].is_number_integer());
  EXPECT_GT(tileset["geometricError"].get<double>(), 0);
  const json& root = tileset["root"];
  EXPECT_EQ(root["refine"], "ADD");
  EXPECT_FALSE(root.contains("content"));
  ASSERT_EQ(root["children"].size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    const json& child = root["children"][i];
    EXPECT_EQ(child["content"]["uri"], "tiles/" + std::to_string(i) + ".glb");
    EXPECT_EQ(child["refine"], "ADD");
    EXPECT_EQ(child["geometricError"], 0.0);
    EXPECT_EQ(child["extras"]["submap"], i);
    EXPECT_EQ(child["extras"]["disconnected"], i == 2);
    EXPECT_EQ(child["extras"]["first_frame"], 100 * i);
    EXPECT_EQ(child["extras"]["last_frame"], 100 * i + 120);
  }
  const json quantized = BuildTileset(f.snapshot, f.bounds, TileVariant::kQuantized);
  EXPECT_EQ(quantized["root"]["children"][3]["content"]["uri"], "tiles/3.quantized.glb");
  EXPECT_EQ(TilesetFileName(TileVariant::kQuantized), "tileset.quantized.json");
  // With a run id, every content URI carries it as a query (cache key of the immutable tiles).
  const json versioned = BuildTileset(f.snapshot, f.bounds, TileVariant::kQuantized, "0123abcd");
  EXPECT_EQ(versioned["root"]["children"][1]["content"]["uri"], "tiles/1.quantized.glb?v=0123abcd");
}

TEST(Tileset, TransformsAreTheSnapshotSim3sAndPlaceTilePointsInTheWorld) {
  const Fixture f = MakeFixture();
  const json tileset = BuildTileset(f.snapshot, f.bounds, TileVariant::kDraco);
  // What a 3D Tiles client does with glTF content: rotate y-up to z-up, then the transform.
  const Eigen::Matrix3d y_up_to_z_up = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  for (std::size_t i = 0; i < f.snapshot.submaps.size(); ++i) {
    const SubmapPlacement& placement = f.snapshot.submaps[i];
    const Eigen::Matrix4d transform = FromColumnMajor(tileset["root"]["children"][i]["transform"]);
    EXPECT_TRUE(transform.isApprox(placement.world_from_submap.matrix(), 1e-15));
    // Uniform scale, no shear: a similarity.
    const Eigen::Matrix3d sR = transform.topLeftCorner<3, 3>();
    EXPECT_TRUE((sR.transpose() * sR).isApprox(std::pow(placement.world_from_submap.scale(), 2) * Eigen::Matrix3d::Identity(), 1e-12));
    EXPECT_EQ(transform.row(3), Eigen::RowVector4d(0, 0, 0, 1));
    for (const Eigen::Vector3d& p : f.points.at(placement.id)) {
      const Eigen::Vector3d in_gltf = GltfFromZUp(p.cast<float>()).cast<double>();
      const Eigen::Vector3d world = (transform * (y_up_to_z_up * in_gltf).homogeneous()).head<3>();
      EXPECT_LE((world - placement.world_from_submap * p).norm(),
                1e-5 * (1 + p.norm()) * placement.world_from_submap.scale());
    }
  }
}

TEST(Tileset, BoundingVolumesContainThePoints) {
  const Fixture f = MakeFixture();
  const json tileset = BuildTileset(f.snapshot, f.bounds, TileVariant::kDraco);
  const json& root_box = tileset["root"]["boundingVolume"]["box"];
  for (std::size_t i = 0; i < f.snapshot.submaps.size(); ++i) {
    const SubmapPlacement& placement = f.snapshot.submaps[i];
    const json& box = tileset["root"]["children"][i]["boundingVolume"]["box"];
    for (const Eigen::Vector3d& p : f.points.at(placement.id)) {
      EXPECT_TRUE(InBox(box, p)) << p.transpose();
      EXPECT_TRUE(InBox(root_box, placement.world_from_submap * p)) << p.transpose();
    }
    // Tight: the child box is the points' box (the points span it).
    const Eigen::AlignedBox3d& b = f.bounds.at(placement.id);
    EXPECT_NEAR(box[3].get<double>(), 0.5 * b.sizes().x(), 1e-12);
    EXPECT_NEAR(box[0].get<double>(), b.center().x(), 1e-12);
  }
}

TEST(Tileset, AGeoreferencedMapGetsARootTransformOntoTheGlobe) {
  Fixture f = MakeFixture();
  // A map in its own frame has no root transform: clients show it as it is.
  EXPECT_FALSE(BuildTileset(f.snapshot, f.bounds, TileVariant::kDraco)["root"].contains("transform"));
  // Georeferenced: ECEF from the east-north-up world (a rotation and a translation of earth
  // radius size, as EnuFrame::EcefFromEnu gives).
  Eigen::Matrix4d ecef_from_world = Eigen::Matrix4d::Identity();
  ecef_from_world.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.5, 0.8).normalized()).toRotationMatrix();
  ecef_from_world.topRightCorner<3, 1>() = Eigen::Vector3d(4.3e6, 0.6e6, 4.6e6);
  f.snapshot.ecef_from_world = ecef_from_world;
  for (const TileVariant variant : {TileVariant::kDraco, TileVariant::kQuantized}) {
    const json tileset = BuildTileset(f.snapshot, f.bounds, variant);
    const Eigen::Matrix4d root = FromColumnMajor(tileset["root"]["transform"]);
    EXPECT_TRUE(root.isApprox(ecef_from_world, 1e-15));
    // 3D Tiles composes transforms down the tree: root * child takes a tile point to ECEF.
    for (std::size_t i = 0; i < f.snapshot.submaps.size(); ++i) {
      const SubmapPlacement& placement = f.snapshot.submaps[i];
      const Eigen::Matrix4d child = FromColumnMajor(tileset["root"]["children"][i]["transform"]);
      EXPECT_TRUE(child.isApprox(placement.world_from_submap.matrix(), 1e-15));  // unchanged
      const Eigen::Vector3d p = f.points.at(placement.id).front();
      const Eigen::Vector3d expected = (ecef_from_world * (placement.world_from_submap * p).homogeneous()).head<3>();
      EXPECT_LT(((root * child * p.homogeneous()).head<3>() - expected).norm(), 1e-6);
    }
    // The root box stays in world coordinates, under the root transform (3D Tiles: a tile's
    // bounding volume is in its own frame, after its transform).
    const json& root_box = tileset["root"]["boundingVolume"]["box"];
    EXPECT_TRUE(InBox(root_box, f.snapshot.submaps[0].world_from_submap * f.points.at(0).front()));
  }
}

TEST(Tileset, EmptySubmapsAndEmptySnapshots) {
  Fixture f = MakeFixture();
  f.bounds[1] = Eigen::AlignedBox3d();  // submap 1 has no points
  f.bounds.erase(3);                    // submap 3's tile is unknown
  json tileset = BuildTileset(f.snapshot, f.bounds, TileVariant::kDraco);
  ASSERT_EQ(tileset["root"]["children"].size(), 2u);
  EXPECT_EQ(tileset["root"]["children"][0]["extras"]["submap"], 0);
  EXPECT_EQ(tileset["root"]["children"][1]["extras"]["submap"], 2);

  const MapSnapshot empty;
  tileset = BuildTileset(empty, {}, TileVariant::kDraco);
  EXPECT_EQ(tileset["asset"]["tilesetVersion"], "0");
  EXPECT_FALSE(tileset["root"].contains("children"));  // 3D Tiles: children has minItems 1
  EXPECT_GT(tileset["root"]["boundingVolume"]["box"][3].get<double>(), 0);

  // A single-point tile still gets a box with non-zero extent around it.
  MapSnapshot one;
  one.submaps.push_back(SubmapPlacement{});
  tileset = BuildTileset(one, {{0, Eigen::AlignedBox3d(Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(1, 2, 3))}},
                         TileVariant::kDraco);
  const json& box = tileset["root"]["children"][0]["boundingVolume"]["box"];
  EXPECT_TRUE(InBox(box, Eigen::Vector3d(1, 2, 3)));
  for (int a = 0; a < 3; ++a) EXPECT_GT(box[static_cast<std::size_t>(3 + 4 * a)].get<double>(), 0);
}

}  // namespace
}  // namespace glam
