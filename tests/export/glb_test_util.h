// Reading GLAM's map tiles back for tests: tinygltf parses the GLB (which also proves the
// tinygltf-before-draco link order), Draco decodes the point primitive, the quantized variant
// is dequantized through its node transform, and the Khronos glTF Validator (npm, installed by
// scripts/setup-node.sh) checks a file.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>

#include "engine/export/glb_tile.h"
#include "tests/support/temp_dir.h"  // FreshTempDir

namespace glam::testing {

// Parses GLB bytes; fails the current test (and returns an empty model) on error.
tinygltf::Model ParseGlb(const std::string& bytes);

// The node whose mesh is named `mesh_name` ("points" / "trajectory"), or -1.
int FindNode(const tinygltf::Model& model, const std::string& mesh_name);

// Points of the Draco POINTS primitive, decoded with Draco, back in the z-up frame, in the
// decoder's order (Draco's kd-tree encoder reorders points).
std::vector<ColoredPoint> DecodeDracoPoints(const tinygltf::Model& model);

// Points of the KHR_mesh_quantization primitive, dequantized by the node's scale +
// translation, back in the z-up frame, in stored order.
std::vector<ColoredPoint> DequantizePoints(const tinygltf::Model& model);

// The LINE_STRIP trajectory's float positions, back in the z-up frame.
std::vector<Eigen::Vector3f> TrajectoryPoints(const tinygltf::Model& model);

// Runs the Khronos glTF Validator on `file`; returns its JSON report (fails the test if the
// validator cannot run).
nlohmann::json ValidateGltf(const std::filesystem::path& file);

std::string ReadBytes(const std::filesystem::path& path);

// A tileset `transform` (16 numbers, column-major) as a matrix; fails the test on another size.
Eigen::Matrix4d FromColumnMajor(const nlohmann::json& a);

// The points of a tileset child's Draco tile (its content uri under `out_dir`, the `?v=`
// query dropped), placed in the tileset's world frame by the child's `transform`.
std::vector<ColoredPoint> ChildTileWorldPoints(const std::filesystem::path& out_dir, const nlohmann::json& child);

}  // namespace glam::testing
