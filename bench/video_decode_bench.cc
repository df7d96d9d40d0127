// Decoding a video into processing-size BGR frames, two ways side by side: GLAM's frame source
// (engine/video/video_decoder.h: FFmpeg's libraries, YUV scaled and converted to BGR in one
// swscale pass) and what GLAM did before, cv::VideoCapture (full-size BGR) followed by
// cv::resize(INTER_AREA). Prints wall and CPU time per frame for each, and how far apart the
// two outputs are (mean absolute difference of the grey images, in grey levels), so a change
// of the decoder shows both its cost and that it still delivers the same pictures.
//
// Usage: glam_bench_video_decode VIDEO [max_image_size=1280 [max_frames=300]]
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "engine/video/frame_source.h"

namespace glam {
namespace {

double CpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + usage.ru_stime.tv_sec +
         1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

struct Timing {
  double wall_s = 0;
  double cpu_s = 0;
  int frames = 0;
};

template <typename ReadFrame>
Timing Time(ReadFrame&& read) {
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = CpuSeconds();
  Timing timing;
  while (read()) ++timing.frames;
  timing.cpu_s = CpuSeconds() - cpu_start;
  timing.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return timing;
}

cv::Mat Grey(const cv::Mat& bgr) {
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  return grey;
}

int Run(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s VIDEO [max_image_size=1280 [max_frames=300]]\n", argv[0]);
    return 2;
  }
  const char* video = argv[1];
  FrameSourceOptions options;
  options.max_image_size = argc > 2 ? std::atoi(argv[2]) : 1280;
  const int max_frames = argc > 3 ? std::atoi(argv[3]) : 300;

  // Every 10th frame of each path is kept (grey) to compare the outputs.
  std::vector<cv::Mat> glam_samples, opencv_samples;
  auto source = OpenFrameSource(video, options);
  const cv::Size processing = source->info().processing_size;
  int glam_read = 0;
  const Timing glam = Time([&] {
    if (glam_read >= max_frames) return false;
    auto frame = source->Next();
    if (!frame) return false;
    if (glam_read++ % 10 == 0) glam_samples.push_back(Grey(frame->bgr));
    return true;
  });

  cv::VideoCapture capture(video, cv::CAP_FFMPEG);
  int opencv_read = 0;
  const Timing opencv = Time([&] {
    cv::Mat bgr;
    if (opencv_read >= max_frames || !capture.read(bgr) || bgr.empty()) return false;
    cv::Mat scaled = ToProcessingSize(bgr, processing);
    if (opencv_read++ % 10 == 0) opencv_samples.push_back(Grey(scaled));
    return true;
  });

  double difference = 0;
  const std::size_t compared = std::min(glam_samples.size(), opencv_samples.size());
  for (std::size_t i = 0; i < compared; ++i) {
    if (glam_samples[i].size() != opencv_samples[i].size()) {
      std::fprintf(stderr, "frame %zu: sizes differ\n", 10 * i);
      return 1;
    }
    cv::Mat diff;
    cv::absdiff(glam_samples[i], opencv_samples[i], diff);
    difference += cv::mean(diff)[0];
  }
  if (compared > 0) difference /= static_cast<double>(compared);

  std::printf("%s: %dx%d -> %dx%d\n\n", video, source->info().original_size.width,
              source->info().original_size.height, processing.width, processing.height);
  std::printf("| path | frames | wall ms/frame | CPU ms/frame |\n|---|---|---|---|\n");
  auto row = [](const char* name, const Timing& t) {
    const double n = std::max(1, t.frames);
    std::printf("| %s | %d | %.1f | %.1f |\n", name, t.frames, 1e3 * t.wall_s / n,
                1e3 * t.cpu_s / n);
  };
  row("GLAM frame source (libav, scaled in swscale)", glam);
  row("cv::VideoCapture + cv::resize(INTER_AREA)", opencv);
  std::printf("\ngrey-level difference between the two (mean abs, %zu frames): %.2f\n", compared,
              difference);
  return 0;
}

}  // namespace
}  // namespace glam

int main(int argc, char** argv) { return glam::Run(argc, argv); }
