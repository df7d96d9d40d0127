#include "engine/geo/geodetic.h"

#include <Eigen/LU>
#include <gtest/gtest.h>

namespace glam {
namespace {

TEST(Geodetic, EcefOfKnownPoints) {
  // On the equator at the prime meridian: x = the semi-major axis; at the pole: z = the
  // semi-minor axis.
  const Eigen::Vector3d equator = EcefFromGeodetic({0, 0, 0});
  EXPECT_NEAR(equator.x(), 6378137.0, 1e-6);
  EXPECT_NEAR(equator.y(), 0.0, 1e-6);
  const Eigen::Vector3d pole = EcefFromGeodetic({90, 0, 100});
  EXPECT_NEAR(pole.z(), 6356752.314245 + 100, 1e-3);
}

TEST(Geodetic, RoundTripsThroughEcefAndEnu) {
  for (const Geodetic g : {Geodetic{47.3769, 8.5417, 408}, Geodetic{-33.86, 151.21, 20}, Geodetic{64.1, -21.9, 1500},
                           Geodetic{0.5, 179.9, -30}}) {
    const Geodetic back = GeodeticFromEcef(EcefFromGeodetic(g));
    EXPECT_NEAR(back.latitude_deg, g.latitude_deg, 1e-9);
    EXPECT_NEAR(back.longitude_deg, g.longitude_deg, 1e-9);
    EXPECT_NEAR(back.altitude_m, g.altitude_m, 1e-4);
    const EnuFrame frame(g);
    EXPECT_LT(frame.EnuFromGeodetic(g).norm(), 1e-6);
    const Eigen::Vector3d p(1234.5, -678.9, 55.5);
    EXPECT_LT((frame.EnuFromGeodetic(frame.GeodeticFromEnu(p)) - p).norm(), 1e-4);
  }
}

TEST(Geodetic, EnuAxesPointEastNorthUp) {
  const EnuFrame frame({47.0, 8.0, 400});
  // 0.001 deg of latitude is ~111 m north; of longitude at 47 deg ~76 m east; +10 m is up.
  const Eigen::Vector3d north = frame.EnuFromGeodetic({47.001, 8.0, 400});
  EXPECT_NEAR(north.y(), 111.2, 0.3);
  EXPECT_NEAR(north.x(), 0.0, 1e-6);
  const Eigen::Vector3d east = frame.EnuFromGeodetic({47.0, 8.001, 400});
  EXPECT_NEAR(east.x(), 76.0, 0.3);
  EXPECT_NEAR(east.y(), 0.0, 0.01);
  EXPECT_NEAR(frame.EnuFromGeodetic({47.0, 8.0, 410}).z(), 10.0, 1e-6);
}

TEST(Geodetic, EcefFromEnuIsTheRigidMapOfTheFrame) {
  const EnuFrame frame({-33.86, 151.21, 20});
  const Eigen::Matrix4d ecef_from_enu = frame.EcefFromEnu();
  // Rigid: an orthonormal rotation, no scale, the bottom row of a homogeneous transform.
  const Eigen::Matrix3d r = ecef_from_enu.topLeftCorner<3, 3>();
  EXPECT_LT((r.transpose() * r - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
  EXPECT_EQ(ecef_from_enu.row(3), Eigen::RowVector4d(0, 0, 0, 1));
  // It agrees with the geodetic conversions: any ENU point lands on its own ECEF position.
  for (const Eigen::Vector3d& enu : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(250, -40, 60)}) {
    const Eigen::Vector3d ecef = r * enu + ecef_from_enu.topRightCorner<3, 1>();
    EXPECT_LT((ecef - EcefFromGeodetic(frame.GeodeticFromEnu(enu))).norm(), 1e-6);
  }
  // Up is the ellipsoid normal, pointing away from the earth's centre.
  EXPECT_GT(r.col(2).dot(EcefFromGeodetic(frame.origin()).normalized()), 0.99);
}

}  // namespace
}  // namespace glam
