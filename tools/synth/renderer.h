// Ray-casting renderer for the synthetic world. Each output pixel casts the ray through
// Camera::Unproject(pixel), so lens distortion in the image is exactly the one the camera
// model describes. Anti-aliasing: texture lookups are trilinear in the albedo mip pyramid at
// the pixel's footprint on the surface (no shimmer as the drone moves); pixels on depth or
// material discontinuities (building silhouettes) are re-rendered with 4 extra sub-samples.
// Shading is Lambertian under a fixed sun, so the appearance of a surface point never
// changes over time, except where the world has water or cloud shadows (dynamic_surface.h):
// those are rendered at the frame's time. Rows are rendered in parallel (cv::parallel_for_), each from its own
// pose if asked (a rolling shutter).
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "engine/core/camera.h"
#include "engine/core/se3.h"
#include "tools/synth/world.h"

namespace glam::synth {

class Renderer {
 public:
  // `world` must outlive the renderer.
  Renderer(const World& world, const Intrinsics& intrinsics);

  // BGR 8-bit image of size intrinsics.width x intrinsics.height, at time `time_s` (only
  // water and cloud shadows depend on it). `water_share`, if given, receives the fraction of
  // pixels that show open water.
  cv::Mat Render(const SE3& world_from_cam, double time_s = 0, double* water_share = nullptr) const;
  // The same under a rolling shutter: image row y is seen from world_from_cam_of_row[y]
  // (one pose per row, the camera where it was when that row was exposed).
  cv::Mat Render(const std::vector<SE3>& world_from_cam_of_row, double time_s = 0,
                 double* water_share = nullptr) const;

 private:
  struct Sample {
    cv::Vec3f color;
    float depth = 0;     // ray distance, 0 for sky
    int material = 0;    // 0 sky, 1 top surface, 2 wall
    bool water = false;  // open water (cover >= 0.5)
  };
  Sample Shade(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double pixel_angle,
               double time_s) const;
  cv::Vec3f SampleAlbedo(double x, double y, double footprint) const;
  cv::Vec3f WallAlbedo(const RayHit& hit, const Building& b, double footprint) const;

  const World& world_;
  Camera camera_;
  std::vector<Eigen::Vector3f> rays_;   // unit ray per pixel in the camera frame
  std::vector<float> pixel_angle_;      // angular size of each pixel (radians)
  Eigen::Vector3d sun_;
};

}  // namespace glam::synth
