// The COLMAP text model (engine/export/colmap_model.h) read back by COLMAP's rules
// (tests/support/colmap_text_model.h): every observation is where COLMAP's projection of its
// point puts it, in COLMAP's pixel convention (+0.5 px), for a pinhole and a radial camera;
// a frame added twice (a keyframe of two submaps' overlap) is one image; a point left with one
// observation is dropped; images are named after their photo or their frame; cameras and
// observations are at the input's image size where GLAM mapped at a smaller one.
#include "engine/export/colmap_model.h"

#include <map>
#include <string>

#include <gtest/gtest.h>

#include "engine/core/camera.h"
#include "engine/core/error.h"
#include "tests/support/colmap_text_model.h"
#include "tests/support/temp_dir.h"

namespace glam {
namespace {

Intrinsics TestIntrinsics(double k1) {
  Intrinsics in;
  in.width = 640;
  in.height = 360;
  in.fx = 500;
  in.fy = 510;
  in.cx = 319.5;
  in.cy = 179.5;
  in.SetK1(k1);
  in.k2 = k1 != 0 ? 0.01 : 0.0;
  return in;
}

// A camera 50 m above the ground at (x, 0), looking down, turned by yaw.
SE3 CamFromWorldAbove(double x, double yaw) {
  const SE3 world_from_cam(SO3(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                                                  Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()))),
                           Eigen::Vector3d(x, 0, 50));
  return world_from_cam.Inverse();
}

// Points on the ground, each observed where `images` see it (GLAM pixel convention).
std::vector<ColmapPoint> GroundPoints(const std::vector<ColmapImage>& images, int count) {
  std::vector<ColmapPoint> points;
  for (int i = 0; i < count; ++i) {
    ColmapPoint p;
    p.position_in_world = Eigen::Vector3d(-10 + 0.7 * i, -8 + 1.3 * (i % 11), 0.1 * (i % 5));
    p.color = {static_cast<std::uint8_t>(i), 2, 3};
    for (std::size_t k = 0; k < images.size(); ++k) {
      Eigen::Vector2d pixel;
      if (Camera(images[k].intrinsics).Project(images[k].cam_from_world * p.position_in_world, &pixel)) {
        p.observations.emplace_back(k, pixel);
      }
    }
    points.push_back(p);
  }
  return points;
}

TEST(ColmapModel, ObservationsAreWhereColmapProjectsTheirPoints) {
  const std::filesystem::path dir = glam::testing::FreshTempDir("colmap_model") / "colmap";
  // Frames of a video (no name: frame_<index>.jpg), a photo's own name, and a name COLMAP could
  // not read (a space: the frame name instead).
  const std::vector<ColmapImage> first = {{0, CamFromWorldAbove(0, 0.0), TestIntrinsics(0), ""},
                                          {5, CamFromWorldAbove(4, 0.1), TestIntrinsics(0), "DJI_0005.JPG"},
                                          {9, CamFromWorldAbove(8, 0.2), TestIntrinsics(0), "DJI 0009.JPG"}};
  // The next submap: frame 9 again (the overlap), then a lens with radial distortion.
  const std::vector<ColmapImage> second = {{9, CamFromWorldAbove(8.01, 0.2), TestIntrinsics(0), ""},
                                           {14, CamFromWorldAbove(12, 0.3), TestIntrinsics(-0.1), ""},
                                           {18, CamFromWorldAbove(14, 0.4), TestIntrinsics(-0.1), ""}};
  ColmapModelWriter writer(dir);
  writer.Add(first, GroundPoints(first, 30));
  std::vector<ColmapPoint> second_points = GroundPoints(second, 20);
  ColmapPoint lone;  // seen by the new image and by the repeated frame only: one observation left
  lone.position_in_world = Eigen::Vector3d(9, 0, 0);
  Eigen::Vector2d pixel;
  ASSERT_TRUE(Camera(second[1].intrinsics).Project(second[1].cam_from_world * lone.position_in_world, &pixel));
  lone.observations = {{0, Eigen::Vector2d(300, 200)}, {1, pixel}};
  second_points.push_back(lone);
  writer.Add(second, second_points);
  EXPECT_FALSE(std::filesystem::exists(dir / "points3D.txt"));  // not before Finish
  writer.Finish();
  EXPECT_EQ(writer.images_written(), 5);

  const glam::testing::ColmapTextModel model = glam::testing::ReadColmapTextModel(dir);
  ASSERT_EQ(model.cameras.size(), 2u);
  EXPECT_EQ(model.cameras.at(1).model, "PINHOLE");
  EXPECT_EQ(model.cameras.at(1).params, (std::vector<double>{500, 510, 320, 180}));
  EXPECT_EQ(model.cameras.at(2).model, "OPENCV");
  EXPECT_EQ(model.cameras.at(2).params, (std::vector<double>{500, 510, 320, 180, -0.1, 0.01, 0, 0}));
  ASSERT_EQ(model.images.size(), 5u);
  std::vector<std::string> names;
  for (const auto& [id, image] : model.images) names.push_back(image.name);
  EXPECT_EQ(names, (std::vector<std::string>{"frame_000000.jpg", "DJI_0005.JPG", "frame_000009.jpg",
                                             "frame_000014.jpg", "frame_000018.jpg"}));
  EXPECT_NEAR((model.images.at(3).Centre() - Eigen::Vector3d(8, 0, 50)).norm(), 0, 1e-9);  // the first one's

  std::map<std::string, std::size_t> observations;
  for (const auto& [id, point] : model.points) {
    EXPECT_GE(point.track.size(), 2u);
    EXPECT_LT(point.error, 1e-3);
    EXPECT_NE(point.position, lone.position_in_world);
    for (const auto& [image_id, index] : point.track) {
      const glam::testing::ColmapTextImage& image = model.images.at(image_id);
      ASSERT_LT(index, image.points2d.size());
      EXPECT_EQ(image.point3d_ids[index], id);
      Eigen::Vector2d projected;
      ASSERT_TRUE(glam::testing::ProjectColmap(model, image, point.position, &projected));
      EXPECT_LT((projected - image.points2d[index]).norm(), 1e-3) << image.name;
      ++observations[image.name];
    }
  }
  // 30 points of the first batch and 20 of the second: those seen by both new images (the
  // repeated frame's observations are dropped); the lone point is dropped.
  EXPECT_EQ(model.points.size(), 50u);
  EXPECT_EQ(observations["frame_000000.jpg"], 30u);
  EXPECT_EQ(observations["frame_000009.jpg"], 30u);  // the first batch's view of frame 9 only
  EXPECT_EQ(observations["frame_000014.jpg"], 20u);  // through the radial camera
  EXPECT_EQ(observations["frame_000018.jpg"], 20u);
}

// The model describes the input's own images: a 1920x1080 camera mapped at 640x360 (scale 1/3)
// is written at 1920x1080, and every observation is where that camera, independently of the
// writer, sees the point.
TEST(ColmapModel, DescribesTheInputImagesAtTheirOwnSize) {
  const std::filesystem::path dir = glam::testing::FreshTempDir("colmap_model_input_size") / "colmap";
  Intrinsics input;  // GLAM pixel convention
  input.width = 1920;
  input.height = 1080;
  input.fx = 1500;
  input.fy = 1530;
  input.cx = 959.5;
  input.cy = 539.5;
  input.SetK1(-0.1);
  input.k2 = 0.01;
  // At the processing size, as ResolveIntrinsics rescales it: c' = (c + 0.5) s - 0.5.
  const Intrinsics processing = TestIntrinsics(-0.1);
  const std::vector<ColmapImage> images = {{0, CamFromWorldAbove(0, 0.0), processing, ""},
                                           {7, CamFromWorldAbove(5, 0.2), processing, ""}};
  ColmapModelWriter writer(dir, ColmapImageSize{1920, 1080, 1.0 / 3.0});
  writer.Add(images, GroundPoints(images, 25));
  writer.Finish();

  const glam::testing::ColmapTextModel model = glam::testing::ReadColmapTextModel(dir);
  ASSERT_EQ(model.cameras.size(), 1u);
  const glam::testing::ColmapTextCamera& camera = model.cameras.at(1);
  EXPECT_EQ(camera.width, 1920);
  EXPECT_EQ(camera.height, 1080);
  const std::vector<double> expected = {1500, 1530, 960, 540, -0.1, 0.01, 0, 0};  // COLMAP: centre +0.5
  ASSERT_EQ(camera.params.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_NEAR(camera.params[i], expected[i], 1e-9) << i;
  ASSERT_EQ(model.points.size(), 25u);
  for (const auto& [id, point] : model.points) {
    EXPECT_LT(point.error, 1e-3);
    for (const auto& [image_id, index] : point.track) {
      const glam::testing::ColmapTextImage& image = model.images.at(image_id);
      const ColmapImage& written = images[image_id - 1];
      Eigen::Vector2d truth;
      ASSERT_TRUE(Camera(input).Project(written.cam_from_world * point.position, &truth));
      EXPECT_LT((truth + Eigen::Vector2d(0.5, 0.5) - image.points2d[index]).norm(), 2e-3);
      Eigen::Vector2d projected;
      ASSERT_TRUE(glam::testing::ProjectColmap(model, image, point.position, &projected));
      EXPECT_LT((projected - image.points2d[index]).norm(), 2e-3);
    }
  }
  EXPECT_THROW(ColmapModelWriter(dir, ColmapImageSize{1920, 0, 0.5}), InputError);
}

TEST(ColmapModel, NothingIsLeftBehindWithoutFinish) {
  const std::filesystem::path dir = glam::testing::FreshTempDir("colmap_model_unfinished") / "colmap";
  {
    ColmapModelWriter writer(dir);
    const std::vector<ColmapImage> images = {{0, CamFromWorldAbove(0, 0), TestIntrinsics(0), ""},
                                             {1, CamFromWorldAbove(1, 0), TestIntrinsics(0), ""}};
    writer.Add(images, GroundPoints(images, 5));
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

}  // namespace
}  // namespace glam
