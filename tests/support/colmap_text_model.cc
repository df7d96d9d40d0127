#include "tests/support/colmap_text_model.h"

#include <fstream>
#include <sstream>
#include <stdexcept>

namespace glam::testing {

namespace {

std::vector<std::string> DataLines(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line[0] == '#') continue;
    lines.push_back(line);
  }
  return lines;
}

}  // namespace

ColmapTextModel ReadColmapTextModel(const std::filesystem::path& dir) {
  ColmapTextModel model;
  for (const std::string& line : DataLines(dir / "cameras.txt")) {
    if (line.empty()) continue;
    std::istringstream in(line);
    std::uint32_t id = 0;
    ColmapTextCamera camera;
    if (!(in >> id >> camera.model >> camera.width >> camera.height)) throw std::runtime_error("bad camera: " + line);
    for (double v; in >> v;) camera.params.push_back(v);
    model.cameras[id] = camera;
  }
  const std::vector<std::string> image_lines = DataLines(dir / "images.txt");
  for (std::size_t i = 0; i + 1 < image_lines.size(); i += 2) {
    std::istringstream in(image_lines[i]);
    std::uint32_t id = 0;
    double qw, qx, qy, qz;
    ColmapTextImage image;
    if (!(in >> id >> qw >> qx >> qy >> qz >> image.cam_from_world_translation.x() >>
          image.cam_from_world_translation.y() >> image.cam_from_world_translation.z() >> image.camera_id >>
          image.name)) {
      throw std::runtime_error("bad image: " + image_lines[i]);
    }
    image.cam_from_world_rotation = Eigen::Quaterniond(qw, qx, qy, qz);
    std::istringstream points(image_lines[i + 1]);
    double x, y;
    std::int64_t point_id;
    while (points >> x >> y >> point_id) {
      image.points2d.emplace_back(x, y);
      image.point3d_ids.push_back(point_id);
    }
    model.images[id] = image;
  }
  for (const std::string& line : DataLines(dir / "points3D.txt")) {
    if (line.empty()) continue;
    std::istringstream in(line);
    std::int64_t id = 0;
    ColmapTextPoint point;
    if (!(in >> id >> point.position.x() >> point.position.y() >> point.position.z() >> point.r >> point.g >>
          point.b >> point.error)) {
      throw std::runtime_error("bad point: " + line);
    }
    std::uint32_t image_id, index;
    while (in >> image_id >> index) point.track.emplace_back(image_id, index);
    model.points[id] = point;
  }
  return model;
}

bool ProjectColmap(const ColmapTextModel& model, const ColmapTextImage& image, const Eigen::Vector3d& point,
                   Eigen::Vector2d* pixel) {
  const Eigen::Vector3d p = image.cam_from_world_rotation * point + image.cam_from_world_translation;
  if (p.z() <= 0) return false;
  const ColmapTextCamera& camera = model.cameras.at(image.camera_id);
  const double u = p.x() / p.z(), v = p.y() / p.z();
  const std::vector<double>& k = camera.params;
  if (camera.model == "PINHOLE") {
    *pixel = {k[0] * u + k[2], k[1] * v + k[3]};
  } else if (camera.model == "OPENCV") {  // fx fy cx cy k1 k2 p1 p2
    const double r2 = u * u + v * v;
    const double radial = 1 + k[4] * r2 + k[5] * r2 * r2;
    const double ud = u * radial + 2 * k[6] * u * v + k[7] * (r2 + 2 * u * u);
    const double vd = v * radial + k[6] * (r2 + 2 * v * v) + 2 * k[7] * u * v;
    *pixel = {k[0] * ud + k[2], k[1] * vd + k[3]};
  } else {
    throw std::runtime_error("camera model not handled here: " + camera.model);
  }
  return true;
}

}  // namespace glam::testing
