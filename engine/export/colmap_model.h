// The map as a COLMAP sparse model in text form (colmap/cameras.txt, images.txt, points3D.txt
// of a result), so the tools that start from one can start from GLAM's map: COLMAP's own
// dense reconstruction (image_undistorter, patch_match_stereo), OpenMVS, and the Gaussian
// splatting and NeRF trainers that read COLMAP models. The format is COLMAP's documented text
// format (colmap.github.io/format.html):
//   cameras.txt   CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]  (PINHOLE fx fy cx cy, or OPENCV
//                 fx fy cx cy k1 k2 0 0 for a lens with radial distortion)
//   images.txt    IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME (cam_from_world), then a line of
//                 POINTS2D: X Y POINT3D_ID ...
//   points3D.txt  POINT3D_ID X Y Z R G B ERROR TRACK[] as IMAGE_ID POINT2D_IDX ...
// Two conventions differ from GLAM's and are converted here: COLMAP puts the centre of the
// top-left pixel at (0.5, 0.5), GLAM at (0, 0), so principal points and observations move by
// +0.5 px; and COLMAP stores cam_from_world where trajectory.tum has world_from_cam.
// And the model describes the images as the input stores them (ColmapImageSize): GLAM maps at a
// processing size (4K video and 20-megapixel photos at 1280 px), but the tools that go on
// from the model (dense stereo, splatting) want the input's own frames and photos, at full
// resolution, so cameras and observations are scaled up to it.
//
// The writer streams: entries are appended submap by submap, so a long flight's model needs
// the memory of one submap, not of the whole map.
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include <Eigen/Core>

#include "engine/core/camera.h"
#include "engine/core/se3.h"
#include "engine/map/landmark.h"

namespace glam {

// An image of the model: a keyframe.
struct ColmapImage {
  std::int64_t frame_index = 0;
  SE3 cam_from_world;
  Intrinsics intrinsics;  // processing size, GLAM pixel convention
  // The image's file name: a photo's own; empty = ColmapImageName(frame_index), the name of a
  // video frame extracted as the docs say. COLMAP splits lines at spaces, so a name with
  // whitespace is replaced by the frame name too.
  std::string name;
};

// A point of the model: its position in the world and its observations, each an image (index
// into the images passed with it) and a pixel (GLAM convention).
struct ColmapPoint {
  Eigen::Vector3d position_in_world = Eigen::Vector3d::Zero();
  Rgb color{0, 0, 0};
  std::vector<std::pair<std::size_t, Eigen::Vector2d>> observations;
};

// The image name of a video frame: frame_<index, 6 digits>.jpg (the name `ffmpeg
// -start_number 0 frame_%06d.jpg` gives the frame, docs/file-formats.md).
std::string ColmapImageName(std::int64_t frame_index);

// The size of the input's images, which the model describes, against the processing size of
// the intrinsics and pixels it is given. A uniform resize maps a pixel centre x (GLAM
// convention) of the processing image to (x + 0.5) / processing_scale in COLMAP's convention
// on the input image; focal lengths divide by processing_scale, k1 and k2 (on normalised
// coordinates) stay.
struct ColmapImageSize {
  int width = 0;   // 0: the images are at the processing size (the intrinsics' own)
  int height = 0;
  // Processing pixels per input pixel (FrameSourceInfo::scale; one factor for both axes, as
  // for the intrinsics given with the input, ResolveIntrinsics).
  double processing_scale = 1.0;

  void Check() const;  // throws InputError
};

class ColmapModelWriter {
 public:
  // Creates `dir` and its three files (replacing earlier ones). Throws EnvironmentError.
  explicit ColmapModelWriter(const std::filesystem::path& dir, const ColmapImageSize& image_size = {});
  ~ColmapModelWriter();
  ColmapModelWriter(const ColmapModelWriter&) = delete;
  ColmapModelWriter& operator=(const ColmapModelWriter&) = delete;

  // Appends images and the points they observe (one submap's keyframes and landmarks).
  // Observations of images this model already has under the same frame (a keyframe of the
  // overlap, already added from the submap before) are dropped, and with them points left
  // with fewer than two observations. ERROR of a point: its mean reprojection error.
  void Add(const std::vector<ColmapImage>& images, const std::vector<ColmapPoint>& points);

  // Completes the files (renamed into place, so a reader never sees half a model). Throws
  // EnvironmentError.
  void Finish();

  std::int64_t images_written() const { return next_image_id_ - 1; }
  std::int64_t points_written() const { return next_point_id_ - 1; }

 private:
  std::uint32_t CameraId(const Intrinsics& intrinsics);

  // A pixel of the processing image (GLAM convention) on the written image (COLMAP's).
  Eigen::Vector2d ImagePixel(const Eigen::Vector2d& processing_pixel) const;

  std::filesystem::path dir_;
  ColmapImageSize image_size_;
  std::FILE* cameras_ = nullptr;
  std::FILE* images_ = nullptr;
  std::FILE* points_ = nullptr;
  std::map<std::tuple<int, int, double, double, double, double, double, double>, std::uint32_t> camera_ids_;
  std::map<std::int64_t, std::uint32_t> image_of_frame_;
  std::uint32_t next_image_id_ = 1;
  std::uint64_t next_point_id_ = 1;
  bool finished_ = false;
};

}  // namespace glam
