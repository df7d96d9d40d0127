// Reads a COLMAP text model (cameras.txt, images.txt, points3D.txt) the way COLMAP defines
// it, independently of engine/export/colmap_model.cc, and projects with COLMAP's conventions
// (pixel centres at +0.5, cam_from_world, PINHOLE / OPENCV), so tests can check that what GLAM
// writes means to COLMAP what it means to GLAM.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace glam::testing {

struct ColmapTextCamera {
  std::string model;
  int width = 0;
  int height = 0;
  std::vector<double> params;
};

struct ColmapTextImage {
  Eigen::Quaterniond cam_from_world_rotation;
  Eigen::Vector3d cam_from_world_translation;
  std::uint32_t camera_id = 0;
  std::string name;
  std::vector<Eigen::Vector2d> points2d;
  std::vector<std::int64_t> point3d_ids;  // -1: none
  Eigen::Vector3d Centre() const { return -(cam_from_world_rotation.inverse() * cam_from_world_translation); }
};

struct ColmapTextPoint {
  Eigen::Vector3d position;
  int r = 0, g = 0, b = 0;
  double error = 0;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> track;  // (image id, point2D index)
};

struct ColmapTextModel {
  std::map<std::uint32_t, ColmapTextCamera> cameras;
  std::map<std::uint32_t, ColmapTextImage> images;
  std::map<std::int64_t, ColmapTextPoint> points;
};

// Throws std::runtime_error on a malformed file.
ColmapTextModel ReadColmapTextModel(const std::filesystem::path& dir);

// The pixel (COLMAP convention) at which `image` sees the world point; false behind it.
bool ProjectColmap(const ColmapTextModel& model, const ColmapTextImage& image, const Eigen::Vector3d& point,
                   Eigen::Vector2d* pixel);

}  // namespace glam::testing
