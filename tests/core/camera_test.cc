// Camera model (projection, Jacobian, undistortion) and intrinsics.json I/O.
#include "engine/core/camera.h"

#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "engine/core/error.h"
#include "engine/core/intrinsics_io.h"

namespace glam {
namespace {

Intrinsics Radial() {
  Intrinsics k;
  k.model = "radial";
  k.width = 1280;
  k.height = 720;
  k.fx = 1000.0;
  k.fy = 980.0;
  k.cx = 640.5;
  k.cy = 359.25;
  k.k1 = -0.12;
  k.k2 = 0.03;
  return k;
}

TEST(CameraTest, ProjectsKnownPoint) {
  Intrinsics k;
  k.model = "radial";
  k.width = 640;
  k.height = 480;
  k.fx = 500;
  k.fy = 400;
  k.cx = 320;
  k.cy = 240;
  k.k1 = 0.1;
  k.k2 = 0.01;
  const Camera camera(k);
  Eigen::Vector2d pixel;
  ASSERT_TRUE(camera.Project(Eigen::Vector3d(1, 2, 4), &pixel));
  // x' = 0.25, y' = 0.5, r^2 = 0.3125, d = 1 + 0.1 r^2 + 0.01 r^4 = 1.0322265625.
  EXPECT_NEAR(pixel.x(), 500 * 1.0322265625 * 0.25 + 320, 1e-12);
  EXPECT_NEAR(pixel.y(), 400 * 1.0322265625 * 0.5 + 240, 1e-12);
  // The principal point is where the optical axis lands.
  ASSERT_TRUE(camera.Project(Eigen::Vector3d(0, 0, 7), &pixel));
  EXPECT_NEAR(pixel.x(), 320, 1e-12);
  EXPECT_NEAR(pixel.y(), 240, 1e-12);
}

TEST(CameraTest, RejectsPointsBehindCamera) {
  const Camera camera(Radial());
  Eigen::Vector2d pixel(-7, -7);
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(0.1, 0.2, -1.0), &pixel));
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(0.1, 0.2, 0.0), &pixel));
  EXPECT_EQ(pixel, Eigen::Vector2d(-7, -7));
  EXPECT_TRUE(camera.Project(Eigen::Vector3d(0.1, 0.2, 1e-3), &pixel));
}

TEST(CameraTest, UnprojectInvertsProjectWithDistortion) {
  const Camera camera(Radial());
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> u(-0.5, 1279.49), v(-0.5, 719.49), depth(0.5, 300.0);
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector2d pixel(u(rng), v(rng));
    const Eigen::Vector3d ray = camera.Unproject(pixel);
    EXPECT_DOUBLE_EQ(ray.z(), 1.0);
    Eigen::Vector2d back;
    ASSERT_TRUE(camera.Project(depth(rng) * ray, &back));
    EXPECT_LT((back - pixel).norm(), 1e-9) << pixel.transpose();
  }
  // And the other way round: point -> pixel -> ray hits the point's direction.
  std::uniform_real_distribution<double> xy(-0.6, 0.6);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(xy(rng), 0.6 * xy(rng), 1.0);
    Eigen::Vector2d pixel;
    ASSERT_TRUE(camera.Project(3.0 * p, &pixel));
    EXPECT_LT((camera.Unproject(pixel) - p).norm(), 1e-12);
  }
}

TEST(CameraTest, DistortionActuallyMovesPixels) {
  // Guards the round-trip test above against a model that ignores k1, k2.
  Intrinsics no_dist = Radial();
  no_dist.k1 = no_dist.k2 = 0;
  Eigen::Vector2d a, b;
  ASSERT_TRUE(Camera(Radial()).Project(Eigen::Vector3d(0.5, 0.3, 1.0), &a));
  ASSERT_TRUE(Camera(no_dist).Project(Eigen::Vector3d(0.5, 0.3, 1.0), &b));
  EXPECT_GT((a - b).norm(), 10.0);
  EXPECT_LT((Camera(no_dist).Unproject(b) - Eigen::Vector3d(0.5, 0.3, 1.0)).norm(), 1e-15);
}

TEST(CameraTest, ProjectJacobianMatchesFiniteDifferences) {
  const Camera camera(Radial());
  std::mt19937 rng(32);
  std::uniform_real_distribution<double> xy(-3.0, 3.0), z(2.0, 50.0);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d p(xy(rng), xy(rng), z(rng));
    Eigen::Matrix<double, 2, 3> numeric;
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector2d plus, minus;
      ASSERT_TRUE(camera.Project(p + h * Eigen::Vector3d::Unit(k), &plus));
      ASSERT_TRUE(camera.Project(p - h * Eigen::Vector3d::Unit(k), &minus));
      numeric.col(k) = (plus - minus) / (2 * h);
    }
    const Eigen::Matrix<double, 2, 3> J = camera.ProjectJacobian(p);
    EXPECT_LT((J - numeric).norm(), 1e-6 * (1 + numeric.norm())) << p.transpose();
  }
}

TEST(CameraTest, InImageUsesPixelCentreConvention) {
  const Camera camera(Radial());  // 1280 x 720
  EXPECT_TRUE(camera.InImage({0, 0}));
  EXPECT_TRUE(camera.InImage({-0.5, -0.5}));
  EXPECT_TRUE(camera.InImage({1279.4, 719.4}));
  EXPECT_FALSE(camera.InImage({1279.5, 100}));
  EXPECT_FALSE(camera.InImage({100, 719.5}));
  EXPECT_FALSE(camera.InImage({-0.51, 100}));
  EXPECT_FALSE(camera.InImage({5, 100}, 10));
  EXPECT_TRUE(camera.InImage({9.5, 100}, 10));
  EXPECT_FALSE(camera.InImage({1270, 100}, 10));
}

TEST(CameraTest, KMatrix) {
  const Camera camera(Radial());
  const Eigen::Matrix3d K = camera.K();
  const Eigen::Vector3d p(0.2, -0.1, 1.0);
  const Eigen::Vector3d h = K * p;
  EXPECT_NEAR(h.x(), 1000.0 * 0.2 + 640.5, 1e-12);
  EXPECT_NEAR(h.y(), 980.0 * -0.1 + 359.25, 1e-12);
  EXPECT_EQ(h.z(), 1.0);
}

TEST(CameraTest, SetK1KeepsTheModelValid) {
  Intrinsics pinhole = Radial();
  pinhole.model = "pinhole";
  pinhole.k1 = pinhole.k2 = 0;
  pinhole.SetK1(0.0);
  EXPECT_EQ(pinhole.model, "pinhole");  // no distortion: stays a pinhole
  pinhole.SetK1(-0.05);
  EXPECT_EQ(pinhole.model, "radial");
  EXPECT_EQ(pinhole.k1, -0.05);
  EXPECT_NO_THROW(pinhole.Check());
  Intrinsics radial = Radial();
  radial.SetK1(0.0);
  EXPECT_EQ(radial.model, "radial");  // k2 still needs it
  EXPECT_EQ(radial.k1, 0.0);
  EXPECT_NO_THROW(radial.Check());
}

TEST(CameraTest, CheckRejectsBadIntrinsics) {
  auto expect_error = [](Intrinsics k, const std::string& field) {
    try {
      Camera camera(k);
      ADD_FAILURE() << "accepted bad " << field;
    } catch (const InputError& e) {
      EXPECT_THAT(e.what(), testing::HasSubstr(field));
    }
  };
  EXPECT_NO_THROW(Radial().Check());
  Intrinsics k = Radial();
  k.fx = 0;
  expect_error(k, "fx");
  k = Radial();
  k.fy = -3;
  expect_error(k, "fy");
  k = Radial();
  k.width = 0;
  expect_error(k, "width");
  k = Radial();
  k.height = -1;
  expect_error(k, "height");
  k = Radial();
  k.model = "fisheye";
  expect_error(k, "model");
  k = Radial();
  k.model = "pinhole";
  expect_error(k, "pinhole");
  k = Radial();
  k.cx = std::numeric_limits<double>::quiet_NaN();
  expect_error(k, "cx");
}

class IntrinsicsJsonTest : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("glam_intrinsics_test_" + std::to_string(::getpid()) + "_" +
            testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::filesystem::path Write(const std::string& text) {
    const auto path = dir_ / "intrinsics.json";
    std::ofstream(path) << text;
    return path;
  }

  void ExpectError(const std::string& text, const std::string& needle) {
    const auto path = Write(text);
    try {
      ReadIntrinsicsJson(path);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const InputError& e) {
      EXPECT_THAT(e.what(), testing::HasSubstr(needle)) << text;
    }
  }

  std::filesystem::path dir_;
};

TEST_F(IntrinsicsJsonTest, RoundTripIsExact) {
  Intrinsics k = Radial();
  k.fx = 1000.0 / 3.0;  // not representable in a short decimal
  const auto path = dir_ / "out.json";
  WriteIntrinsicsJson(k, path);
  const Intrinsics back = ReadIntrinsicsJson(path);
  EXPECT_EQ(back.model, k.model);
  EXPECT_EQ(back.width, k.width);
  EXPECT_EQ(back.height, k.height);
  EXPECT_EQ(back.fx, k.fx);
  EXPECT_EQ(back.fy, k.fy);
  EXPECT_EQ(back.cx, k.cx);
  EXPECT_EQ(back.cy, k.cy);
  EXPECT_EQ(back.k1, k.k1);
  EXPECT_EQ(back.k2, k.k2);
}

TEST_F(IntrinsicsJsonTest, DistortionIsOptional) {
  const auto path = Write(
      R"({"model": "pinhole", "width": 640, "height": 480, "fx": 500, "fy": 501.5,
          "cx": 319.5, "cy": 239.5})");
  const Intrinsics k = ReadIntrinsicsJson(path);
  EXPECT_EQ(k.model, "pinhole");
  EXPECT_EQ(k.width, 640);
  EXPECT_EQ(k.height, 480);
  EXPECT_EQ(k.fx, 500.0);
  EXPECT_EQ(k.fy, 501.5);
  EXPECT_EQ(k.cx, 319.5);
  EXPECT_EQ(k.cy, 239.5);
  EXPECT_EQ(k.k1, 0.0);
  EXPECT_EQ(k.k2, 0.0);
}

TEST_F(IntrinsicsJsonTest, BadFilesGiveInputErrorNamingTheProblem) {
  EXPECT_THROW(ReadIntrinsicsJson(dir_ / "does_not_exist.json"), InputError);
  ExpectError("{\"model\": \"pinhole\", \"width\": 640,", "malformed");
  ExpectError("[1, 2, 3]", "object");
  ExpectError(R"({"model": "pinhole", "width": 640, "height": 480, "fx": 500,
                  "cx": 319.5, "cy": 239.5})",
              "\"fy\"");
  ExpectError(R"({"model": "pinhole", "width": "640", "height": 480, "fx": 500, "fy": 500,
                  "cx": 319.5, "cy": 239.5})",
              "\"width\"");
  ExpectError(R"({"model": "radial", "width": 640, "height": 480, "fx": 500, "fy": 500,
                  "cx": 319.5, "cy": 239.5, "k1": "big"})",
              "\"k1\"");
  ExpectError(R"({"model": "radial", "width": 640, "height": 480, "fx": -500, "fy": 500,
                  "cx": 319.5, "cy": 239.5})",
              "fx");
  ExpectError(R"({"width": 640, "height": 480, "fx": 500, "fy": 500, "cx": 1, "cy": 1})",
              "\"model\"");
}

}  // namespace
}  // namespace glam
