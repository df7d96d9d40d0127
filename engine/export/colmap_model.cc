#include "engine/export/colmap_model.h"

#include <cerrno>
#include <cstring>
#include <system_error>

#include <fmt/format.h>

#include "engine/core/error.h"
#include "engine/core/options.h"

namespace glam {

namespace fs = std::filesystem;

namespace {

constexpr const char* kFiles[3] = {"cameras.txt", "images.txt", "points3D.txt"};
// COLMAP puts the centre of the top-left pixel at (0.5, 0.5), GLAM at (0, 0).
constexpr double kPixelCentreShift = 0.5;

fs::path PartPath(const fs::path& dir, const char* name) { return dir / (std::string(".") + name + ".part"); }

std::FILE* OpenPart(const fs::path& dir, const char* name) {
  std::FILE* file = std::fopen(PartPath(dir, name).c_str(), "w");
  if (file == nullptr) {
    throw EnvironmentError(fmt::format("cannot write {}: {}", PartPath(dir, name).string(), std::strerror(errno)));
  }
  return file;
}

std::string NameOf(const ColmapImage& image) {
  const bool usable = !image.name.empty() && image.name.find_first_of(" \t\r\n") == std::string::npos;
  return usable ? image.name : ColmapImageName(image.frame_index);
}

}  // namespace

std::string ColmapImageName(std::int64_t frame_index) { return fmt::format("frame_{:06d}.jpg", frame_index); }

void ColmapImageSize::Check() const {
  CheckGreaterEqual("ColmapImageSize.width", width, 0);
  CheckGreaterEqual("ColmapImageSize.height", height, 0);
  if ((width == 0) != (height == 0)) throw InputError("ColmapImageSize: width and height are both 0 or both set");
  CheckInRange("ColmapImageSize.processing_scale", processing_scale, 1e-4, 1e4);
}

ColmapModelWriter::ColmapModelWriter(const fs::path& dir, const ColmapImageSize& image_size)
    : dir_(dir), image_size_(image_size) {
  image_size_.Check();
  // Images at the processing size: no scale, whatever was passed with width 0.
  if (image_size_.width == 0) image_size_.processing_scale = 1.0;
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec) throw EnvironmentError(fmt::format("cannot create {}: {}", dir_.string(), ec.message()));
  cameras_ = OpenPart(dir_, kFiles[0]);
  images_ = OpenPart(dir_, kFiles[1]);
  points_ = OpenPart(dir_, kFiles[2]);
  fmt::print(cameras_,
             "# Camera list with one line of data per camera:\n"
             "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
             "# Written by GLAM: pixels of the input's frames or photos, centre of the top-left pixel at "
             "(0.5, 0.5).\n");
  fmt::print(images_,
             "# Image list with two lines of data per image:\n"
             "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
             "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
             "# Written by GLAM: one image per keyframe of the map, named after its frame index.\n");
  fmt::print(points_,
             "# 3D point list with one line of data per point:\n"
             "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n");
}

ColmapModelWriter::~ColmapModelWriter() {
  for (std::FILE* file : {cameras_, images_, points_}) {
    if (file != nullptr) std::fclose(file);
  }
  if (!finished_) {
    std::error_code ec;
    for (const char* name : kFiles) fs::remove(PartPath(dir_, name), ec);
  }
}

std::uint32_t ColmapModelWriter::CameraId(const Intrinsics& in) {
  const auto key = std::make_tuple(in.width, in.height, in.fx, in.fy, in.cx, in.cy, in.k1, in.k2);
  const auto [it, added] = camera_ids_.emplace(key, static_cast<std::uint32_t>(camera_ids_.size() + 1));
  if (!added) return it->second;
  const bool scaled = image_size_.width > 0;
  const int width = scaled ? image_size_.width : in.width;
  const int height = scaled ? image_size_.height : in.height;
  const double fx = in.fx / image_size_.processing_scale;
  const double fy = in.fy / image_size_.processing_scale;
  const Eigen::Vector2d c = ImagePixel({in.cx, in.cy});
  if (in.k1 == 0 && in.k2 == 0) {
    fmt::print(cameras_, "{} PINHOLE {} {} {:.17g} {:.17g} {:.17g} {:.17g}\n", it->second, width, height, fx, fy,
               c.x(), c.y());
  } else {
    // GLAM's radial model, x_d = x (1 + k1 r^2 + k2 r^4) on normalised coordinates, is OpenCV's
    // with no tangential terms.
    fmt::print(cameras_, "{} OPENCV {} {} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} 0 0\n", it->second,
               width, height, fx, fy, c.x(), c.y(), in.k1, in.k2);
  }
  return it->second;
}

Eigen::Vector2d ColmapModelWriter::ImagePixel(const Eigen::Vector2d& processing_pixel) const {
  return (processing_pixel + Eigen::Vector2d::Constant(kPixelCentreShift)) / image_size_.processing_scale;
}

void ColmapModelWriter::Add(const std::vector<ColmapImage>& images, const std::vector<ColmapPoint>& points) {
  GLAM_CHECK(!finished_, "ColmapModelWriter::Add after Finish");
  // Image ids of this batch; 0 = a frame the model already has.
  std::vector<std::uint32_t> ids(images.size(), 0);
  for (std::size_t i = 0; i < images.size(); ++i) {
    if (image_of_frame_.emplace(images[i].frame_index, next_image_id_).second) ids[i] = next_image_id_++;
  }
  struct Point2D {
    Eigen::Vector2d pixel;
    std::uint64_t point_id;
  };
  std::vector<std::vector<Point2D>> points2d(images.size());
  std::vector<Camera> cameras;
  cameras.reserve(images.size());
  for (const ColmapImage& image : images) cameras.emplace_back(image.intrinsics);
  std::string track;
  for (const ColmapPoint& point : points) {
    int kept = 0;
    for (const auto& [image, pixel] : point.observations) kept += ids.at(image) != 0 ? 1 : 0;
    if (kept < 2) continue;
    const std::uint64_t id = next_point_id_++;
    double error_sum = 0;
    track.clear();
    for (const auto& [image, pixel] : point.observations) {
      if (ids[image] == 0) continue;
      Eigen::Vector2d projected;
      const bool in_front =
          cameras[image].Project(images[image].cam_from_world * point.position_in_world, &projected);
      error_sum += in_front ? (ImagePixel(projected) - ImagePixel(pixel)).norm() : 0.0;
      track += fmt::format(" {} {}", ids[image], points2d[image].size());
      points2d[image].push_back({pixel, id});
    }
    fmt::print(points_, "{} {:.9g} {:.9g} {:.9g} {} {} {} {:.6g}{}\n", id, point.position_in_world.x(),
               point.position_in_world.y(), point.position_in_world.z(), point.color[0], point.color[1],
               point.color[2], error_sum / kept, track);
  }
  for (std::size_t i = 0; i < images.size(); ++i) {
    if (ids[i] == 0) continue;
    const Eigen::Quaterniond& q = images[i].cam_from_world.rotation().quaternion();
    const Eigen::Vector3d& t = images[i].cam_from_world.translation();
    fmt::print(images_, "{} {:.15g} {:.15g} {:.15g} {:.15g} {:.12g} {:.12g} {:.12g} {} {}\n", ids[i], q.w(), q.x(),
               q.y(), q.z(), t.x(), t.y(), t.z(), CameraId(images[i].intrinsics), NameOf(images[i]));
    std::string line;
    for (const Point2D& p : points2d[i]) {
      const Eigen::Vector2d pixel = ImagePixel(p.pixel);
      line += fmt::format("{}{:.4f} {:.4f} {}", line.empty() ? "" : " ", pixel.x(), pixel.y(), p.point_id);
    }
    fmt::print(images_, "{}\n", line);
  }
}

void ColmapModelWriter::Finish() {
  bool ok = true;
  for (std::FILE** file : {&cameras_, &images_, &points_}) {
    ok = std::fflush(*file) == 0 && ok;
    ok = std::fclose(*file) == 0 && ok;
    *file = nullptr;
  }
  if (!ok) throw EnvironmentError(fmt::format("cannot write the COLMAP model in {}", dir_.string()));
  for (const char* name : kFiles) {
    std::error_code ec;
    fs::rename(PartPath(dir_, name), dir_ / name, ec);
    if (ec) throw EnvironmentError(fmt::format("cannot write {}: {}", (dir_ / name).string(), ec.message()));
  }
  finished_ = true;
}

}  // namespace glam
