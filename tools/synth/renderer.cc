#include "tools/synth/renderer.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <opencv2/core/utility.hpp>

#include "engine/core/error.h"
#include "tools/synth/noise.h"

namespace glam::synth {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kMaxDistance = 20000;
// Added to a pixel's material code when it shows open water (materials are 0-2), so the
// silhouette pass also smooths the waterline and the water share is counted from the codes.
constexpr unsigned char kWaterFlag = 4;
const cv::Vec3f kSky(0.92f, 0.85f, 0.78f);      // BGR: pale hazy blue
const cv::Vec3f kGlass(0.26f, 0.22f, 0.18f);

// Fraction of [x - w/2, x + w/2] covered by the periodic pulse [0, width) + k * period:
// an exact box filter, so window rows do not alias at a distance.
double PulseCoverage(double x, double period, double width, double filter) {
  auto integral = [&](double v) {
    const double k = std::floor(v / period);
    return k * width + std::clamp(v - k * period, 0.0, width);
  };
  if (filter < 1e-4) return (x - std::floor(x / period) * period) < width ? 1.0 : 0.0;
  return (integral(x + 0.5 * filter) - integral(x - 0.5 * filter)) / filter;
}

cv::Vec3f Bilinear(const cv::Mat& img, double u, double v) {
  u = std::clamp(u, 0.0, img.cols - 1.0);
  v = std::clamp(v, 0.0, img.rows - 1.0);
  const int i = std::min(static_cast<int>(u), img.cols - 2);
  const int j = std::min(static_cast<int>(v), img.rows - 2);
  const float a = static_cast<float>(u - i);
  const float b = static_cast<float>(v - j);
  const cv::Vec3b* r0 = img.ptr<cv::Vec3b>(j) + i;
  const cv::Vec3b* r1 = img.ptr<cv::Vec3b>(j + 1) + i;
  cv::Vec3f out;
  for (int ch = 0; ch < 3; ++ch) {
    const float top = r0[0][ch] + a * (r0[1][ch] - r0[0][ch]);
    const float bottom = r1[0][ch] + a * (r1[1][ch] - r1[0][ch]);
    out[ch] = (top + b * (bottom - top)) * (1.0f / 255.0f);
  }
  return out;
}

}  // namespace

Renderer::Renderer(const World& world, const Intrinsics& intrinsics)
    : world_(world), camera_(intrinsics) {
  const int w = intrinsics.width;
  const int h = intrinsics.height;
  rays_.resize(static_cast<std::size_t>(w) * h);
  pixel_angle_.resize(rays_.size());
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      for (int x = 0; x < w; ++x) {
        const Eigen::Vector3d r = camera_.Unproject(Eigen::Vector2d(x, y)).normalized();
        const Eigen::Vector3d rx = camera_.Unproject(Eigen::Vector2d(x + 0.5, y)).normalized();
        const Eigen::Vector3d ry = camera_.Unproject(Eigen::Vector2d(x, y + 0.5)).normalized();
        const std::size_t k = static_cast<std::size_t>(y) * w + x;
        rays_[k] = r.cast<float>();
        pixel_angle_[k] = static_cast<float>(2.0 * std::max((rx - r).norm(), (ry - r).norm()));
      }
    }
  });
  const double elevation = 52.0 * kPi / 180.0;
  const double azimuth = 215.0 * kPi / 180.0;
  sun_ = Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                         std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
}

cv::Vec3f Renderer::SampleAlbedo(double x, double y, double footprint) const {
  const auto& mips = world_.albedo();
  const double texel = world_.texel();
  const double level = std::clamp(std::log2(std::max(footprint, 1e-9) / texel), 0.0,
                                  static_cast<double>(mips.size() - 1));
  const int l0 = std::min(static_cast<int>(level), static_cast<int>(mips.size()) - 2);
  const double frac = level - l0;
  const double u = (x - world_.surface().origin().x()) / texel;
  const double v = (y - world_.surface().origin().y()) / texel;
  auto at_level = [&](int l) {
    const double scale = 1.0 / (1 << l);
    return Bilinear(mips[l], (u + 0.5) * scale - 0.5, (v + 0.5) * scale - 0.5);
  };
  const cv::Vec3f c0 = at_level(l0);
  if (frac < 1e-3) return c0;
  return c0 + static_cast<float>(frac) * (at_level(l0 + 1) - c0);
}

cv::Vec3f Renderer::WallAlbedo(const RayHit& hit, const Building& b, double footprint) const {
  const bool faces_x = std::abs(hit.normal.x()) > std::abs(hit.normal.y());
  const double h = faces_x ? hit.point.y() - b.y0 : hit.point.x() - b.x0;
  const double z = hit.point.z() - b.base_z;
  const double fade = std::clamp(1.0 - footprint / 0.8, 0.0, 1.0);
  const double plaster =
      1 + fade * 0.07 * ValueNoise(h / 0.6, z / 0.6, static_cast<std::uint64_t>(b.x0 * 131 + b.y0 * 7));
  cv::Vec3f color = b.wall_color * static_cast<float>(plaster);
  const double wall_height = b.eave_z - b.base_z;
  if (z > 0.6 && z < wall_height - 0.4) {
    const double offset = 0.5 * (b.window_period - b.window_width);
    const double across = PulseCoverage(h - offset, b.window_period, b.window_width, footprint);
    const double up = PulseCoverage(z - 0.9, b.floor_height, 1.4, footprint);
    color += static_cast<float>(across * up) * (kGlass - color);
  }
  if (z < 0.5) color *= 0.8f;  // plinth
  return color;
}

Renderer::Sample Renderer::Shade(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                                 double pixel_angle, double time_s) const {
  Sample s;
  RayHit hit;
  if (!world_.surface().Intersect(origin, dir, kMaxDistance, &hit)) {
    s.color = kSky;
    return s;
  }
  const double perp = hit.t * pixel_angle;
  const double cos_incidence = std::max(std::abs(hit.normal.dot(dir)), 0.1);
  // Between the isotropic (perp) and anisotropic (major) footprints, leaning to blur.
  const double footprint = perp * std::exp(0.7 * std::log(1.0 / cos_incidence));
  s.depth = static_cast<float>(hit.t);
  s.material = 1;
  cv::Vec3f albedo;
  int building = 0;
  if (hit.normal.z() < 0.4) {
    float best = -1e30f;
    for (int dj = 0; dj <= 1; ++dj) {
      for (int di = 0; di <= 1; ++di) {
        const int id = world_.BuildingAt(hit.cell_i + di, hit.cell_j + dj);
        const float z = world_.surface().at(hit.cell_i + di, hit.cell_j + dj);
        if (id > 0 && z > best) {
          best = z;
          building = id;
        }
      }
    }
  }
  if (building > 0) {
    s.material = 2;
    albedo = WallAlbedo(hit, world_.buildings()[building - 1], footprint);
  } else {
    albedo = SampleAlbedo(hit.point.x(), hit.point.y(), footprint);
  }
  const DynamicSurface& dynamic = world_.dynamic();
  const double shadow = dynamic.CloudShadow(hit.point.x(), hit.point.y(), time_s);
  const double light = 0.45 + 0.6 * std::max(0.0, hit.normal.dot(sun_)) * (1.0 - 0.85 * shadow);
  if (building > 0 || !dynamic.has_water()) {
    s.color = albedo * static_cast<float>(light);
    return s;
  }
  const DynamicSurface::Shore shore = dynamic.ShoreAt(hit.point.x(), hit.point.y());
  const double water = shore.water;
  if (water < 1) albedo += static_cast<float>(shore.sand) * (DynamicSurface::ShoreColor() - albedo);
  s.color = albedo * static_cast<float>(light);
  if (water > 0) {
    const cv::Vec3f surface = dynamic.ShadeWater(hit.point, dir, footprint, time_s, sun_, kSky) *
                              static_cast<float>(1.0 - 0.4 * shadow);
    s.color += static_cast<float>(water) * (surface - s.color);
    s.water = water >= 0.5;
  }
  return s;
}

cv::Mat Renderer::Render(const SE3& world_from_cam, double time_s, double* water_share) const {
  return Render(std::vector<SE3>(static_cast<std::size_t>(camera_.intrinsics().height), world_from_cam),
                time_s, water_share);
}

cv::Mat Renderer::Render(const std::vector<SE3>& world_from_cam_of_row, double time_s,
                         double* water_share) const {
  const int w = camera_.intrinsics().width;
  const int h = camera_.intrinsics().height;
  GLAM_CHECK(world_from_cam_of_row.size() == static_cast<std::size_t>(h),
             "one pose per image row expected: {} poses for {} rows", world_from_cam_of_row.size(), h);
  cv::Mat color(h, w, CV_32FC3);
  std::vector<float> depth(static_cast<std::size_t>(w) * h);
  std::vector<unsigned char> material(depth.size());
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      const Eigen::Matrix3d rotation = world_from_cam_of_row[y].rotation().matrix();
      const Eigen::Vector3d origin = world_from_cam_of_row[y].translation();
      for (int x = 0; x < w; ++x) {
        const std::size_t k = static_cast<std::size_t>(y) * w + x;
        const Eigen::Vector3d dir = rotation * rays_[k].cast<double>();
        const Sample s = Shade(origin, dir, pixel_angle_[k], time_s);
        color.at<cv::Vec3f>(y, x) = s.color;
        depth[k] = s.depth;
        material[k] = static_cast<unsigned char>(s.material + (s.water ? kWaterFlag : 0));
      }
    }
  });
  // Second pass: supersample pixels on silhouettes (depth or material jumps).
  cv::Mat out(h, w, CV_8UC3);
  static const double kOffsets[4][2] = {{-0.125, -0.375}, {0.375, -0.125}, {0.125, 0.375}, {-0.375, 0.125}};
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      const Eigen::Matrix3d rotation = world_from_cam_of_row[y].rotation().matrix();
      const Eigen::Vector3d origin = world_from_cam_of_row[y].translation();
      for (int x = 0; x < w; ++x) {
        const std::size_t k = static_cast<std::size_t>(y) * w + x;
        bool edge = false;
        const int nx[4] = {x - 1, x + 1, x, x};
        const int ny[4] = {y, y, y - 1, y + 1};
        for (int n = 0; n < 4 && !edge; ++n) {
          if (nx[n] < 0 || ny[n] < 0 || nx[n] >= w || ny[n] >= h) continue;
          const std::size_t m = static_cast<std::size_t>(ny[n]) * w + nx[n];
          edge = material[m] != material[k] || std::abs(depth[m] - depth[k]) > 0.02f * depth[k];
        }
        cv::Vec3f c = color.at<cv::Vec3f>(y, x);
        if (edge) {
          for (const auto& off : kOffsets) {
            const Eigen::Vector3d ray =
                camera_.Unproject(Eigen::Vector2d(x + off[0], y + off[1])).normalized();
            c += Shade(origin, rotation * ray, 0.5 * pixel_angle_[k], time_s).color;
          }
          c *= 0.2f;
        }
        out.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<uchar>(c[0] * 255.0f),
                                            cv::saturate_cast<uchar>(c[1] * 255.0f),
                                            cv::saturate_cast<uchar>(c[2] * 255.0f));
      }
    }
  });
  if (water_share != nullptr) {
    const auto water_pixels = std::count_if(material.begin(), material.end(), [](unsigned char m) { return m >= kWaterFlag; });
    *water_share = static_cast<double>(water_pixels) / static_cast<double>(material.size());
  }
  return out;
}

}  // namespace glam::synth
