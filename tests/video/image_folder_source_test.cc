#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "engine/core/error.h"
#include "engine/video/frame_source.h"
#include "engine/video/image_folder_source.h"
#include "engine/video/photo_capture_time.h"
#include "tests/support/exif_photo.h"
#include "tests/video/test_media.h"

namespace glam {
namespace {

using testing::DecodeIndex;
using testing::MakeFrame;

class ImageFolderSourceTest : public testing::TempDirTest {
 protected:
  // frame_<n>.png holding index n, written in an order unlike the natural one.
  void WriteImages(std::initializer_list<int> numbers, cv::Size size = {200, 100}) {
    for (int n : numbers) {
      ASSERT_TRUE(cv::imwrite((dir_ / ("frame_" + std::to_string(n) + ".png")).string(),
                              MakeFrame(size, n)));
    }
  }
};

TEST_F(ImageFolderSourceTest, NaturalNameOrderSkipsNonImages) {
  WriteImages({10, 2, 1, 33});
  std::ofstream(dir_ / "notes.txt") << "not an image";
  std::ofstream(dir_ / "frame_5.jpg.part") << "partial download";
  std::filesystem::create_directory(dir_ / "sub.png");  // a folder named like an image

  auto source = OpenFrameSource(dir_);
  EXPECT_DOUBLE_EQ(source->info().fps, 1.0);
  EXPECT_EQ(source->info().frame_count, 4);
  EXPECT_EQ(source->info().original_size, cv::Size(200, 100));
  std::vector<int> decoded;
  std::vector<int64_t> indices;
  while (auto frame = source->Next()) {
    EXPECT_DOUBLE_EQ(frame->timestamp_s, static_cast<double>(frame->index));
    decoded.push_back(DecodeIndex(frame->bgr, 40));
    indices.push_back(frame->index);
  }
  EXPECT_EQ(decoded, (std::vector<int>{1, 2, 10, 33}));
  EXPECT_EQ(indices, (std::vector<int64_t>{0, 1, 2, 3}));
}

// Large JPEGs are decoded at a reduced size by libjpeg (1/4 here: 2000x1500 -> 500x375 still
// covers 480x360) and then resized: the frames must match a full decode resized with
// INTER_AREA, and a JPEG of another size must still be told apart and skipped.
TEST_F(ImageFolderSourceTest, LargeJpegsDecodedReducedMatchAFullDecode) {
  cv::RNG rng(5);
  std::vector<cv::Mat> photos;
  for (int i = 0; i < 3; ++i) {
    cv::Mat photo(1500, 2000, CV_8UC3);
    rng.fill(photo, cv::RNG::UNIFORM, cv::Scalar::all(0), cv::Scalar::all(255));
    cv::GaussianBlur(photo, photo, cv::Size(0, 0), 6.0);
    cv::normalize(photo, photo, 0, 255, cv::NORM_MINMAX);
    // Named .png but JPEG inside: decoding goes by content.
    const std::string name = i == 1 ? "photo_1.png" : "photo_" + std::to_string(i) + ".jpg";
    std::vector<unsigned char> jpeg;
    ASSERT_TRUE(cv::imencode(".jpg", photo, jpeg, {cv::IMWRITE_JPEG_QUALITY, 95}));
    std::ofstream(dir_ / name, std::ios::binary)
        .write(reinterpret_cast<const char*>(jpeg.data()), static_cast<std::streamsize>(jpeg.size()));
    photos.push_back(photo);
  }
  // 1800x1350 decodes to 450x338 at 1/4: not the 500x375 of the others.
  cv::Mat other;
  cv::resize(photos[0], other, {1800, 1350});
  ASSERT_TRUE(cv::imwrite((dir_ / "photo_3.jpg").string(), other));

  FrameSourceOptions options;
  options.max_image_size = 480;
  options.photos_by_capture_time = false;
  auto source = OpenFrameSource(dir_, options);
  EXPECT_EQ(source->info().original_size, cv::Size(2000, 1500));
  EXPECT_EQ(source->info().processing_size, cv::Size(480, 360));
  int delivered = 0;
  while (auto frame = source->Next()) {
    ASSERT_LT(frame->index, 3);
    EXPECT_EQ(frame->original_size, cv::Size(2000, 1500));
    ASSERT_EQ(frame->bgr.size(), cv::Size(480, 360));
    const auto file = dynamic_cast<ImageFolderSource&>(*source).files()[frame->index];
    const cv::Mat full = ToProcessingSize(cv::imread(file.string()), {480, 360});
    cv::Mat grey, full_grey, diff;
    cv::cvtColor(frame->bgr, grey, cv::COLOR_BGR2GRAY);
    cv::cvtColor(full, full_grey, cv::COLOR_BGR2GRAY);
    cv::absdiff(grey, full_grey, diff);
    EXPECT_LT(cv::mean(diff)[0], 1.5) << file;
    ++delivered;
  }
  EXPECT_EQ(delivered, 3);  // photo_3 skipped: another size
}

TEST_F(ImageFolderSourceTest, StrideSeekAndDownscale) {
  WriteImages({0, 1, 2, 3, 4, 5, 6}, {800, 400});
  FrameSourceOptions options;
  options.stride = 2;
  options.max_image_size = 400;
  auto source = OpenFrameSource(dir_, options);
  EXPECT_EQ(source->info().processing_size, cv::Size(400, 200));
  std::vector<int> decoded;
  while (auto frame = source->Next()) {
    EXPECT_EQ(frame->bgr.size(), cv::Size(400, 200));
    EXPECT_EQ(frame->original_size, cv::Size(800, 400));
    decoded.push_back(DecodeIndex(frame->bgr, 10));
  }
  EXPECT_EQ(decoded, (std::vector<int>{0, 2, 4, 6}));
  source->SeekTo(5);
  EXPECT_EQ(DecodeIndex(source->Next()->bgr, 10), 5);
  source->SeekTo(7);  // the end: nothing left
  EXPECT_FALSE(source->Next().has_value());
  EXPECT_THROW(source->SeekTo(8), InputError);
}

TEST_F(ImageFolderSourceTest, SkipsUndecodableAndMismatchedImages) {
  WriteImages({1, 3});
  std::ofstream(dir_ / "frame_2.png") << "broken";
  ASSERT_TRUE(cv::imwrite((dir_ / "frame_4.png").string(), MakeFrame({100, 100}, 4)));
  auto source = OpenFrameSource(dir_);
  std::vector<int> decoded;
  while (auto frame = source->Next()) decoded.push_back(DecodeIndex(frame->bgr, 10));
  EXPECT_EQ(decoded, (std::vector<int>{1, 3}));
}

TEST_F(ImageFolderSourceTest, EmptyOrImagelessFolderIsInputError) {
  EXPECT_THROW(OpenFrameSource(dir_), InputError);
  std::ofstream(dir_ / "readme.md") << "# no images";
  try {
    OpenFrameSource(dir_);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no image files"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ProbeVideo(dir_), InputError);
}

// Photos copied from two card folders (the camera's counter restarted) and a wrapped counter:
// by name the flight would jump back and forth; by EXIF capture time it is in order. A file
// without a capture time keeps its place in name order.
TEST_F(ImageFolderSourceTest, PhotosWithACaptureTimeAreInCaptureOrder) {
  const cv::Mat image = MakeFrame({200, 100}, 0);
  // name -> capture time (the flight's order: C, D, E, A, B by name is A B C D E)
  glam::testing::WritePhoto(dir_ / "DJI_0001.JPG", image, nullptr, "2026:12:05 10:00:30");  // 4th
  glam::testing::WritePhoto(dir_ / "DJI_0002.JPG", image, nullptr, "2026:12:05 10:00:32");  // 5th
  ASSERT_TRUE(cv::imwrite((dir_ / "DJI_0003.png").string(), image));                         // no EXIF
  glam::testing::WritePhoto(dir_ / "DJI_9998.JPG", image, nullptr, "2026:12:05 10:00:00");  // 1st
  glam::testing::WritePhoto(dir_ / "DJI_9999.JPG", image, nullptr, "2026:12:05 10:00:02");  // 2nd
  glam::testing::WritePhoto(dir_ / "DJI_9999_1.JPG", image, nullptr, "2026:12:05 10:00:02");  // same second

  const auto names = [](const ImageFolderSource& source) {
    std::vector<std::string> out;
    for (const auto& f : source.files()) out.push_back(f.filename().string());
    return out;
  };
  const ImageFolderSource by_time(dir_, FrameSourceOptions{});
  EXPECT_EQ(names(by_time), (std::vector<std::string>{"DJI_9998.JPG", "DJI_9999.JPG", "DJI_0003.png",
                                                      "DJI_9999_1.JPG", "DJI_0001.JPG", "DJI_0002.JPG"}));
  EXPECT_EQ(by_time.photos_reordered_by_time(), 5u);
  FrameSourceOptions name_order;
  name_order.photos_by_capture_time = false;
  const ImageFolderSource by_name(dir_, name_order);
  EXPECT_EQ(names(by_name), (std::vector<std::string>{"DJI_0001.JPG", "DJI_0002.JPG", "DJI_0003.png",
                                                      "DJI_9998.JPG", "DJI_9999.JPG", "DJI_9999_1.JPG"}));
  EXPECT_EQ(by_name.photos_reordered_by_time(), 0u);
  // Frames come in that order, indexed (and timed) by their place.
  auto source = OpenFrameSource(dir_);
  std::vector<int64_t> indices;
  while (auto frame = source->Next()) indices.push_back(frame->index);
  EXPECT_EQ(indices, (std::vector<int64_t>{0, 1, 2, 3, 4, 5}));
}

TEST(PhotoCaptureTime, ParsesExifDateTimeWithSubSeconds) {
  EXPECT_EQ(ParseExifDateTimeMs("1970:01:01 00:00:00"), 0);
  EXPECT_EQ(ParseExifDateTimeMs("1970:01:02 00:00:01"), 86401000);
  EXPECT_EQ(ParseExifDateTimeMs("2000:03:01 00:00:00"), 951868800000);  // after a leap day
  EXPECT_EQ(ParseExifDateTimeMs("2026:12:05 10:00:00", "5"), *ParseExifDateTimeMs("2026:12:05 10:00:00") + 500);
  EXPECT_EQ(ParseExifDateTimeMs("2026:12:05 10:00:00", "057"), *ParseExifDateTimeMs("2026:12:05 10:00:00") + 57);
  EXPECT_EQ(ParseExifDateTimeMs("2026:12:05 10:00:00", "0571"), *ParseExifDateTimeMs("2026:12:05 10:00:00") + 57);
  // Unset clocks and malformed values.
  EXPECT_FALSE(ParseExifDateTimeMs("0000:00:00 00:00:00").has_value());
  EXPECT_FALSE(ParseExifDateTimeMs("    :  :     :  :  ").has_value());
  EXPECT_FALSE(ParseExifDateTimeMs("2026-12-05 10:00:00").has_value());
  EXPECT_FALSE(ParseExifDateTimeMs("2026:13:05 10:00:00").has_value());
  EXPECT_FALSE(ParseExifDateTimeMs("2026:12:05 10:00").has_value());
  EXPECT_FALSE(ParseExifDateTimeMs("").has_value());
}

TEST_F(ImageFolderSourceTest, ReadsTheCaptureTimeOfAPhoto) {
  const cv::Mat image = MakeFrame({64, 32}, 0);
  glam::testing::WritePhoto(dir_ / "timed.jpg", image, nullptr, "2026:12:05 10:00:30");
  glam::testing::WritePhoto(dir_ / "plain.jpg", image, nullptr);
  std::ofstream(dir_ / "broken.jpg") << "not a jpeg";
  EXPECT_EQ(ReadPhotoCaptureTimeMs(dir_ / "timed.jpg"), ParseExifDateTimeMs("2026:12:05 10:00:30"));
  EXPECT_FALSE(ReadPhotoCaptureTimeMs(dir_ / "plain.jpg").has_value());
  EXPECT_FALSE(ReadPhotoCaptureTimeMs(dir_ / "broken.jpg").has_value());
  EXPECT_FALSE(ReadPhotoCaptureTimeMs(dir_ / "missing.jpg").has_value());
}

TEST(NaturalLess, OrdersDigitRunsByValue) {
  EXPECT_TRUE(NaturalLess("img2.png", "img10.png"));
  EXPECT_FALSE(NaturalLess("img10.png", "img2.png"));
  EXPECT_TRUE(NaturalLess("a.png", "b.png"));
  EXPECT_TRUE(NaturalLess("img.png", "img1.png"));
  EXPECT_TRUE(NaturalLess("img007.png", "img08.png"));
  EXPECT_FALSE(NaturalLess("x1", "x1"));
  EXPECT_TRUE(NaturalLess("f99999999999999999999999.png", "f100000000000000000000000.png"));
}

TEST(HasImageExtension, CaseInsensitive) {
  EXPECT_TRUE(HasImageExtension("a/B.JPG"));
  EXPECT_TRUE(HasImageExtension("c.tiff"));
  EXPECT_FALSE(HasImageExtension("d.txt"));
  EXPECT_FALSE(HasImageExtension("noext"));
}

}  // namespace
}  // namespace glam
