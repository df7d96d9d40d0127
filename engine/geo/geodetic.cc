#include "engine/geo/geodetic.h"

#include <cmath>

namespace glam {
namespace {

constexpr double kA = 6378137.0;                 // WGS84 semi-major axis
constexpr double kF = 1.0 / 298.257223563;       // flattening
constexpr double kE2 = kF * (2.0 - kF);          // first eccentricity squared
constexpr double kB = kA * (1.0 - kF);           // semi-minor axis
constexpr double kEp2 = (kA * kA - kB * kB) / (kB * kB);  // second eccentricity squared

double Radians(double deg) { return deg * M_PI / 180.0; }
double Degrees(double rad) { return rad * 180.0 / M_PI; }

}  // namespace

Eigen::Vector3d EcefFromGeodetic(const Geodetic& g) {
  const double lat = Radians(g.latitude_deg), lon = Radians(g.longitude_deg);
  const double n = kA / std::sqrt(1.0 - kE2 * std::sin(lat) * std::sin(lat));
  return {(n + g.altitude_m) * std::cos(lat) * std::cos(lon), (n + g.altitude_m) * std::cos(lat) * std::sin(lon),
          (n * (1.0 - kE2) + g.altitude_m) * std::sin(lat)};
}

Geodetic GeodeticFromEcef(const Eigen::Vector3d& ecef) {
  const double p = std::hypot(ecef.x(), ecef.y());
  Geodetic g;
  g.longitude_deg = Degrees(std::atan2(ecef.y(), ecef.x()));
  double theta = std::atan2(ecef.z() * kA, p * kB);
  double lat = 0;
  for (int i = 0; i < 2; ++i) {
    lat = std::atan2(ecef.z() + kEp2 * kB * std::pow(std::sin(theta), 3), p - kE2 * kA * std::pow(std::cos(theta), 3));
    theta = std::atan((1.0 - kF) * std::tan(lat));
  }
  const double n = kA / std::sqrt(1.0 - kE2 * std::sin(lat) * std::sin(lat));
  g.latitude_deg = Degrees(lat);
  // Near the poles p / cos(lat) is ill-conditioned; use the z form there.
  g.altitude_m = std::abs(std::cos(lat)) > 1e-3 ? p / std::cos(lat) - n : ecef.z() / std::sin(lat) - n * (1.0 - kE2);
  return g;
}

EnuFrame::EnuFrame(const Geodetic& origin) : origin_(origin), origin_ecef_(EcefFromGeodetic(origin)) {
  const double lat = Radians(origin.latitude_deg), lon = Radians(origin.longitude_deg);
  enu_from_ecef_ << -std::sin(lon), std::cos(lon), 0,                                            //
      -std::sin(lat) * std::cos(lon), -std::sin(lat) * std::sin(lon), std::cos(lat),            //
      std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat);
}

Eigen::Vector3d EnuFrame::EnuFromGeodetic(const Geodetic& g) const {
  return enu_from_ecef_ * (EcefFromGeodetic(g) - origin_ecef_);
}

Geodetic EnuFrame::GeodeticFromEnu(const Eigen::Vector3d& enu) const {
  return GeodeticFromEcef(origin_ecef_ + enu_from_ecef_.transpose() * enu);
}

Eigen::Matrix4d EnuFrame::EcefFromEnu() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = enu_from_ecef_.transpose();
  m.topRightCorner<3, 1>() = origin_ecef_;
  return m;
}

}  // namespace glam
