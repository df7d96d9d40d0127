#include "engine/map/submap_io.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>

#include "engine/core/error.h"

namespace glam {
namespace {

namespace fs = std::filesystem;

class SubmapIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() /
            ("glam_submap_io_" + std::to_string(::getpid()) + "_" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  static Submap RandomSubmap(std::uint32_t id) {
    std::mt19937 rng(id);
    std::uniform_real_distribution<double> u(-1, 1);
    Submap s;
    s.id = id;
    s.first_frame = 100;
    s.last_frame = 250;
    s.intrinsics.model = "radial";
    s.intrinsics.width = 640;
    s.intrinsics.height = 360;
    s.intrinsics.fx = s.intrinsics.fy = 512.5;
    s.intrinsics.cx = 319.5;
    s.intrinsics.cy = 179.5;
    s.intrinsics.k1 = -0.01;
    for (int k = 0; k < 5; ++k) {
      Keyframe kf;
      kf.frame_index = 100 + 30 * k;
      kf.cam_from_submap = SE3(SO3::Exp(Eigen::Vector3d(u(rng), u(rng), u(rng))),
                               Eigen::Vector3d(u(rng), u(rng), u(rng)) * 10);
      kf.focal = 500 + k;
      s.keyframes.push_back(kf);
    }
    for (int i = 0; i < 300; ++i) {
      Landmark lm;
      lm.id = static_cast<std::uint32_t>(1000 + 3 * i);
      lm.point_in_submap = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 50;
      lm.color = {static_cast<std::uint8_t>(i), 20, 200};
      for (auto& d : lm.descriptor) d = static_cast<std::uint8_t>(rng());
      for (std::uint32_t k = 0; k < static_cast<std::uint32_t>(1 + i % 4); ++k) {
        lm.observations.push_back({k, Eigen::Vector2f(float(u(rng) * 300), float(u(rng) * 200))});
      }
      s.landmarks.push_back(lm);
    }
    for (int f = 100; f <= 250; ++f) {
      FramePose fp;
      fp.frame_index = f;
      fp.timestamp_s = f / 30.0;
      fp.cam_from_submap = SE3(SO3::Exp(Eigen::Vector3d(u(rng), 0, 0)), Eigen::Vector3d(f, 0, 1));
      fp.pnp_inliers = static_cast<std::uint32_t>(f);
      s.frame_poses.push_back(fp);
    }
    s.stats.build_seconds = 1.25;
    s.stats.frames_unposed = 3;
    return s;
  }

  fs::path root_;
};

TEST_F(SubmapIoTest, RoundTripPreservesEverything) {
  const Submap in = RandomSubmap(7);
  WriteSubmap(in, root_);
  EXPECT_TRUE(fs::exists(SubmapDirectory(root_, 7) / "submap.bin"));
  EXPECT_FALSE(fs::exists(SubmapDirectory(root_, 7) / "submap.bin.tmp"));
  const Submap out = ReadSubmap(root_, 7);

  EXPECT_EQ(out.id, in.id);
  EXPECT_EQ(out.first_frame, in.first_frame);
  EXPECT_EQ(out.last_frame, in.last_frame);
  EXPECT_EQ(out.intrinsics.model, "radial");
  EXPECT_DOUBLE_EQ(out.intrinsics.k1, -0.01);
  EXPECT_DOUBLE_EQ(out.intrinsics.cx, 319.5);
  ASSERT_EQ(out.keyframes.size(), in.keyframes.size());
  for (size_t k = 0; k < in.keyframes.size(); ++k) {
    EXPECT_EQ(out.keyframes[k].frame_index, in.keyframes[k].frame_index);
    EXPECT_TRUE(out.keyframes[k].cam_from_submap.matrix().isApprox(in.keyframes[k].cam_from_submap.matrix(), 1e-15));
    EXPECT_EQ(out.keyframes[k].focal, in.keyframes[k].focal);
  }
  ASSERT_EQ(out.landmarks.size(), in.landmarks.size());
  for (size_t i = 0; i < in.landmarks.size(); ++i) {
    EXPECT_EQ(out.landmarks[i].id, in.landmarks[i].id);
    EXPECT_EQ(out.landmarks[i].point_in_submap, in.landmarks[i].point_in_submap);
    EXPECT_EQ(out.landmarks[i].color, in.landmarks[i].color);
    EXPECT_EQ(out.landmarks[i].descriptor, in.landmarks[i].descriptor);
    ASSERT_EQ(out.landmarks[i].observations.size(), in.landmarks[i].observations.size());
    for (size_t o = 0; o < in.landmarks[i].observations.size(); ++o) {
      EXPECT_EQ(out.landmarks[i].observations[o].keyframe, in.landmarks[i].observations[o].keyframe);
      EXPECT_EQ(out.landmarks[i].observations[o].pixel, in.landmarks[i].observations[o].pixel);
    }
  }
  ASSERT_EQ(out.frame_poses.size(), in.frame_poses.size());
  EXPECT_EQ(out.frame_poses.back().frame_index, 250);
  EXPECT_EQ(out.frame_poses.back().pnp_inliers, 250u);
  EXPECT_DOUBLE_EQ(out.frame_poses.back().timestamp_s, 250 / 30.0);
  EXPECT_DOUBLE_EQ(out.stats.build_seconds, 1.25);
  EXPECT_EQ(out.stats.frames_unposed, 3u);
}

TEST_F(SubmapIoTest, MissingFileIsInputError) {
  EXPECT_THROW(ReadSubmap(root_, 3), InputError);
}

TEST_F(SubmapIoTest, TruncatedFileIsRejected) {
  WriteSubmap(RandomSubmap(1), root_);
  const fs::path file = SubmapDirectory(root_, 1) / "submap.bin";
  fs::resize_file(file, fs::file_size(file) / 2);
  EXPECT_THROW(ReadSubmap(root_, 1), InputError);
}

TEST_F(SubmapIoTest, FutureVersionIsRejectedWithVersionInMessage) {
  WriteSubmap(RandomSubmap(2), root_);
  const fs::path file = SubmapDirectory(root_, 2) / "submap.bin";
  {
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(8);
    const std::uint32_t future = kSubmapFormatVersion + 1;
    f.write(reinterpret_cast<const char*>(&future), sizeof(future));
  }
  try {
    ReadSubmap(root_, 2);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("version 2"), std::string::npos) << e.what();
  }
}

TEST_F(SubmapIoTest, ForeignFileIsRejected) {
  fs::create_directories(SubmapDirectory(root_, 4));
  std::ofstream(SubmapDirectory(root_, 4) / "submap.bin") << "PK\x03\x04 not a submap at all";
  EXPECT_THROW(ReadSubmap(root_, 4), InputError);
}

TEST_F(SubmapIoTest, CorruptObservationIndexIsRejected) {
  Submap s = RandomSubmap(5);
  s.landmarks[0].observations[0].keyframe = 99;  // only 5 keyframes exist
  WriteSubmap(s, root_);
  EXPECT_THROW(ReadSubmap(root_, 5), InputError);
}

}  // namespace
}  // namespace glam
