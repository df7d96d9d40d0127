#include "engine/geo/georeference.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace glam {
namespace {

const Geodetic kOrigin{47.0, 8.0, 400.0};

struct Flight {
  std::map<std::int64_t, Eigen::Vector3d> world;  // by frame, map units
  std::vector<GpsSample> gps;
};

// A flight of `frames` frames at 30 fps along `path` (ENU metres), seen by the map through
// world = enu_from_world^-1 * enu, with GPS at every 3rd frame carrying Gaussian noise.
Flight MakeFlight(const Sim3& enu_from_world, int frames, double noise_m,
                  const std::function<Eigen::Vector3d(double)>& path, std::uint32_t seed = 1) {
  Flight f;
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, noise_m);
  const EnuFrame frame(kOrigin);
  const Eigen::Vector3d start = path(0);
  const Sim3 world_from_enu = enu_from_world.Inverse();
  for (int i = 0; i < frames; ++i) {
    const Eigen::Vector3d enu = path(i / 30.0) - start;  // the first GPS sample is the origin
    f.world[i] = world_from_enu * enu;
    if (i % 3 == 0) {
      const Eigen::Vector3d noisy = i == 0 ? enu : Eigen::Vector3d(enu + Eigen::Vector3d(n(rng), n(rng), n(rng)));
      f.gps.push_back({i / 30.0, frame.GeodeticFromEnu(noisy)});
    }
  }
  return f;
}

double MaxError(const Flight& f, const Sim3& fitted, const Sim3& truth) {
  double worst = 0;
  for (const auto& [index, w] : f.world) worst = std::max(worst, (fitted * w - truth * w).norm());
  return worst;
}

TEST(Georeference, RecoversATiltedScaledMapFromNoisyGps) {
  // A lawnmower-like area flight: the full similarity is observable.
  const Sim3 truth(12.5, SO3::Exp(Eigen::Vector3d(0.05, -0.03, 1.2)), Eigen::Vector3d(3, -2, 1));
  auto area = [](double t) { return Eigen::Vector3d(10 * t, 200 * std::sin(0.2 * t), 60 + 0.5 * t); };
  const Flight f = MakeFlight(truth, 1800, 1.0, area);
  const GeoreferenceResult r = FitGeoreference(f.world, 30.0, f.gps);
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_TRUE(r.full);
  EXPECT_EQ(r.samples_matched, 600);
  EXPECT_NEAR(r.enu_from_world.scale(), 12.5, 0.05);
  EXPECT_LT(MaxError(f, r.enu_from_world, truth), 0.5);  // 1 m noise averaged over 600 samples
  EXPECT_NEAR(r.rms_m, std::sqrt(3.0), 0.2);
  EXPECT_DOUBLE_EQ(r.origin.latitude_deg, kOrigin.latitude_deg);
}

TEST(Georeference, AStraightFlightGetsYawScaleAndOffset) {
  // Along a line the roll about it is not observable: the map's z stays up.
  const Sim3 truth(0.8, SO3::Exp(Eigen::Vector3d(0, 0, -2.0)), Eigen::Vector3d(5, 5, 0));
  auto line = [](double t) { return Eigen::Vector3d(8 * t, 6 * t, 50); };
  const Flight f = MakeFlight(truth, 900, 1.0, line);
  const GeoreferenceResult r = FitGeoreference(f.world, 30.0, f.gps);
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_FALSE(r.full);
  EXPECT_NEAR(r.enu_from_world.scale(), 0.8, 0.01);
  EXPECT_LT(MaxError(f, r.enu_from_world, truth), 0.6);
}

TEST(Georeference, GpsOutliersAreDropped) {
  const Sim3 truth(2.0, SO3(), Eigen::Vector3d::Zero());
  auto area = [](double t) { return Eigen::Vector3d(10 * t, 30 * std::cos(0.3 * t), 80); };
  Flight f = MakeFlight(truth, 1200, 0.5, area);
  const EnuFrame frame(kOrigin);
  for (std::size_t i = 5; i < f.gps.size(); i += 10) {  // 10 % of the fixes 40 m off (multipath)
    f.gps[i].position = frame.GeodeticFromEnu(frame.EnuFromGeodetic(f.gps[i].position) + Eigen::Vector3d(40, -25, 10));
  }
  const GeoreferenceResult r = FitGeoreference(f.world, 30.0, f.gps);
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_LE(r.samples_used, r.samples_matched * 91 / 100);
  EXPECT_LT(MaxError(f, r.enu_from_world, truth), 0.3);
  EXPECT_LT(r.rms_m, 1.5);
}

TEST(Georeference, RefusesWhatCannotSetScaleOrHeading) {
  const Sim3 truth;
  auto hover = [](double t) { return Eigen::Vector3d(0.2 * t, 0, 30); };  // 2 m in 10 s
  const Flight f = MakeFlight(truth, 300, 0.5, hover);
  GeoreferenceResult r = FitGeoreference(f.world, 30.0, f.gps);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.reason.find("span"), std::string::npos) << r.reason;
  // A hover whose GPS wanders 2 m per axis: the scatter is no flight.
  auto still = [](double) { return Eigen::Vector3d(0, 0, 30); };
  const Flight noisy = MakeFlight(truth, 900, 2.0, still);
  r = FitGeoreference(noisy.world, 30.0, noisy.gps);
  EXPECT_FALSE(r.ok);
  // GPS times that match no posed frame (another video's track).
  std::vector<GpsSample> late = f.gps;
  for (GpsSample& s : late) s.time_s += 1000;
  r = FitGeoreference(f.world, 30.0, late);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.reason.find("posed frames"), std::string::npos) << r.reason;
}

}  // namespace
}  // namespace glam
