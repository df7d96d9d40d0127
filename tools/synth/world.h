// The synthetic world: terrain with relief, box buildings (flat or gable roofs) and a rich,
// non-repeating colour texture (fields with furrows, meadows, forest crowns, roads, yards,
// roof tiles, facades). Everything is a pure function of the options' seed.
//
// Geometry lives in one Heightfield (the ground truth). Colour lives in an albedo texture
// over the same area with a mip pyramid, so the renderer can filter by pixel footprint and
// textures do not shimmer from frame to frame. Walls are not in the top-down texture (they
// are one cell wide there); the renderer shades them procedurally from the Building table.
#pragma once

#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "engine/core/camera.h"
#include "engine/core/se3.h"
#include "tools/synth/dynamic_surface.h"
#include "tools/synth/heightfield.h"
#include "tools/synth/synth_options.h"

namespace glam::synth {

// Intrinsics of the synthetic camera ("radial" when k1 or k2 is non-zero).
Intrinsics MakeIntrinsics(const SynthOptions& options);

// Terrain height without buildings; defined on the whole plane (the flight plan needs it
// before the world's extent is known).
double TerrainHeight(double x, double y, const SynthOptions& options);

struct Building {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // footprint (snapped to heightfield vertices)
  double base_z = 0;                       // ground level
  double eave_z = 0;                       // top of the walls
  double ridge_z = 0;                      // == eave_z for flat roofs
  bool gable = false;
  bool ridge_along_x = true;
  cv::Vec3f wall_color;                    // BGR in [0, 1]
  cv::Vec3f roof_color;
  double floor_height = 3.0;
  double window_period = 3.0;
  double window_width = 1.4;
};

class World {
 public:
  // Builds a world that covers everything the cameras at `poses` can see.
  // Throws InputError if that area would need an unreasonable amount of memory.
  static World Generate(const SynthOptions& options, const std::vector<SE3>& poses);

  const Heightfield& surface() const { return surface_; }
  // Water and cloud shadows (the parts of the world that change over time).
  const DynamicSurface& dynamic() const { return *dynamic_; }
  const std::vector<Building>& buildings() const { return buildings_; }

  // Building index + 1 at heightfield vertex (i, j), 0 = open ground.
  int BuildingAt(int i, int j) const {
    return building_id_[static_cast<std::size_t>(j) * surface_.cols() + i];
  }

  // Albedo mip pyramid: level 0 has texel size texel(), origin at the surface origin; texel
  // (c, r) of level 0 is centred at origin + (c, r) * texel. CV_8UC3, BGR.
  const std::vector<cv::Mat>& albedo() const { return albedo_; }
  double texel() const { return texel_; }

 private:
  Heightfield surface_;
  std::shared_ptr<const DynamicSurface> dynamic_;
  std::vector<int> building_id_;
  std::vector<Building> buildings_;
  std::vector<cv::Mat> albedo_;
  double texel_ = 0.1;
};

}  // namespace glam::synth
