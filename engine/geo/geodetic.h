// WGS84 geodetic coordinates and a local east-north-up (ENU) frame, metres, tangent to the
// ellipsoid at an origin: the frame a georeferenced map is written in (x east, y north, z up,
// like the synthetic worlds). Exact through earth-centred coordinates (no flat-earth
// approximation): over a 10 km flight the tangent plane drops ~8 m below the ellipsoid, which
// is the ENU frame's honest answer and what other tools (COLMAP's model_aligner, ODM) use.
#pragma once

#include <Eigen/Core>

namespace glam {

struct Geodetic {
  double latitude_deg = 0;
  double longitude_deg = 0;
  double altitude_m = 0;  // above the WGS84 ellipsoid or mean sea level: whatever the source gives
};

// Earth-centred, earth-fixed (metres).
Eigen::Vector3d EcefFromGeodetic(const Geodetic& g);
// Inverse (Bowring's method, two iterations: sub-millimetre at drone altitudes).
Geodetic GeodeticFromEcef(const Eigen::Vector3d& ecef);

// Local ENU frame with its origin at `origin`.
class EnuFrame {
 public:
  explicit EnuFrame(const Geodetic& origin);
  Eigen::Vector3d EnuFromGeodetic(const Geodetic& g) const;
  Geodetic GeodeticFromEnu(const Eigen::Vector3d& enu) const;
  // The rigid 4x4 taking ENU coordinates of this frame to earth-centred ones (metres): what a
  // 3D Tiles root `transform` holds to put an east-north-up tileset on the globe.
  Eigen::Matrix4d EcefFromEnu() const;
  const Geodetic& origin() const { return origin_; }

 private:
  Geodetic origin_;
  Eigen::Vector3d origin_ecef_;
  Eigen::Matrix3d enu_from_ecef_;  // rows: east, north, up
};

}  // namespace glam
