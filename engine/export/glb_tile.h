// Map tiles as binary glTF (architecture "Map delivery format"): one POINTS primitive
// (POSITION, COLOR_0 uint8 normalized) plus the camera trajectory as a LINE_STRIP, so a viewer
// shows the flight next to the points it produced.
//
// Two encodings of the same content:
//  * Draco (`KHR_draco_mesh_compression`): what our three.js viewer loads; about a quarter of
//    the raw size. Point clouds are outside the letter of that extension (it names TRIANGLES
//    and TRIANGLE_STRIP only), CesiumJS rejects them, and the glTF Validator does not look
//    inside Draco at all, hence
//  * Quantized (`KHR_mesh_quantization`): int16 normalized positions dequantized by the node's
//    scale + translation, uint8 normalized colours, no compression. Standard 3D Tiles clients
//    load it and the glTF Validator checks it completely.
//
// Geometry comes in the caller's z-up frame (submap or world coordinates) and is written in
// glTF's y-up convention, (x, y, z) -> (x, z, -y) (architecture Contracts "Tiles"): 3D Tiles
// clients and our viewer rotate glTF content +90 degrees about X back to z-up, so a tile's
// 3D Tiles transform is world_from_submap unchanged.
//
// Position error bounds (per coordinate, in the frame's units; `side` = the largest side of
// the axis-aligned bounding box of the points):
//  * Draco with b bits: side / (2 (2^b - 1)); with the default 14 bits that is 3.05e-5 side,
//    e.g. 3 mm for a 100 m submap — two orders of magnitude below what monocular mapping
//    reaches (the synthetic tests accept map errors of the order of 1 % of the flying height).
//  * Quantized: side / (4 * 32767) = 7.6e-6 side (int16 over the half-extent).
// Both plus float rounding (about one ulp of the largest coordinate: tiles are in submap
// coordinates, so that stays tiny). Colours are exact in both. Measured (100k points, 14 bits,
// speed 5): 6.1 bytes/point vs 15 raw, ~90 ms encode on one core; quantized 12 bytes/point.
//
// Empty geometry (no points, fewer than 2 camera centres) still gives a valid GLB: the missing
// primitive is left out, and with nothing at all the file holds an asset and no scene.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <vector>

#include "engine/export/ply_points.h"

namespace glam {

struct TileGeometry {
  std::vector<ColoredPoint> points;            // z-up frame of the tile
  std::vector<Eigen::Vector3f> trajectory;     // camera centres in frame order, same frame
};

// z-up (x, y, z) -> glTF y-up (x, z, -y), and back.
Eigen::Vector3f GltfFromZUp(const Eigen::Vector3f& p);
Eigen::Vector3f ZUpFromGltf(const Eigen::Vector3f& p);

// Axis-aligned bounds of points and trajectory in the geometry's z-up frame (empty box for
// empty geometry).
Eigen::AlignedBox3d TileBounds(const TileGeometry& geometry);

struct DracoTileOptions {
  int position_bits = 14;  // Draco position quantisation, 8..24 (see the bound above)
  int encode_speed = 5;    // Draco speed 0 (smallest) .. 10 (fastest); 5 = library default
  void Check() const;      // throws InputError
};

// Largest per-coordinate position error of a Draco tile of these points (see header comment).
double DracoPositionErrorBound(const std::vector<ColoredPoint>& points, int position_bits);
// Same for the quantized variant.
double QuantizedPositionErrorBound(const std::vector<ColoredPoint>& points);

// The GLB bytes. Throws EnvironmentError if Draco or tinygltf fail, InputError for
// non-finite coordinates.
std::string EncodeDracoTileGlb(const TileGeometry& geometry, const DracoTileOptions& options = {});
std::string EncodeQuantizedTileGlb(const TileGeometry& geometry);

}  // namespace glam
