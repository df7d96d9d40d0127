// CPU cost of the feature stage per operation, one thread, on a real video: decoding, SIFT on
// the detection frames, and KLT propagation of their keypoints into the frames in between,
// for several KLT settings side by side (how many keypoints survive each, and how far each
// variant's positions are from the reference setting's). It answers "what does one frame of
// the default schedule cost, and what would a cheaper KLT give up" without the builder and
// the other worker competing for the cores. Prints a Markdown table (docs/benchmarks.md).
//
// Usage: glam_bench_feature_stage VIDEO [detect_every=6 [max_frames=300]]
#include <malloc.h>

#include <opencv2/core.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "engine/features/gray_image.h"
#include "engine/features/klt_propagator.h"
#include "engine/features/sift_extractor.h"
#include "engine/video/frame_source.h"

namespace glam {
namespace {

using Clock = std::chrono::steady_clock;

double Ms(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

struct Variant {
  std::string name;
  double ms = 0;
  double survivors = 0;
  double position_error_sum = 0;  // against the default variant, same keypoint
  std::size_t compared = 0;
  KltPropagator klt;
  Variant(std::string n, const KltOptions& options) : name(std::move(n)), klt(options) {}
};

int Run(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s VIDEO [detect_every=6 [max_frames=300]]\n", argv[0]);
    return 2;
  }
  const int detect_every = argc > 2 ? std::atoi(argv[2]) : 6;
  const int max_frames = argc > 3 ? std::atoi(argv[3]) : 300;
  cv::setNumThreads(1);
  // Keep freed heap memory in the process. cv::SIFT allocates ~50 MB of pyramid buffers per
  // call; with glibc's default (dynamic) trim and mmap thresholds a single-threaded loop like
  // this one may hand them back to the kernel after every call and fault them in again on the
  // next, and on this VM a page fault costs ~12 us: SIFT then measured 115-160 ms per 640x360
  // frame instead of 30-65 ms, bimodally from one process to the next (perf stat: 151,000
  // against 38,000 faults over 15 detections). The mapping pipeline does not show it (its
  // faults track its resident size), so the benchmark should not either.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);

  std::vector<Variant> variants;
  const KltOptions base;  // the product's defaults
  variants.emplace_back("default (11 px, 3 levels, 0.1 px steps, forward-backward 0.5 px)", base);
  for (double ncc : {0.9, 0.8}) {
    KltOptions o = base;
    o.max_forward_backward_px = 0;
    o.min_patch_correlation = ncc;
    variants.emplace_back("patch correlation >= " + std::to_string(ncc).substr(0, 3) + " instead", o);
  }
  {
    KltOptions o = base;
    o.max_forward_backward_px = 0;
    variants.emplace_back("no wrong-track test", o);
  }
  for (double eps : {0.03, 0.3}) {
    KltOptions o = base;
    o.epsilon_px = eps;
    variants.emplace_back("iterations stop below " + std::to_string(eps).substr(0, 4) + " px steps", o);
  }
  {
    KltOptions o = base;
    o.pyramid_levels = 2;
    variants.emplace_back("2 levels", o);
  }
  {
    KltOptions o = base;
    o.window_px = 13;
    variants.emplace_back("13 px window (before 2026-12-03)", o);
  }

  auto source = OpenFrameSource(argv[1], FrameSourceOptions{});
  const SiftExtractor sift;
  double decode_ms = 0, gray_ms = 0, sift_ms = 0;
  int frames = 0, detections = 0;
  std::size_t sift_features = 0;
  while (frames < max_frames) {
    auto start = Clock::now();
    std::optional<Frame> frame = source->Next();
    if (!frame) break;
    decode_ms += Ms(start);
    start = Clock::now();
    const cv::Mat gray = ToGray(frame->bgr);
    gray_ms += Ms(start);
    if (frames % detect_every == 0) {
      start = Clock::now();
      const Features features = sift.Extract(frame->bgr);
      sift_ms += Ms(start);
      sift_features += features.size();
      ++detections;
      for (Variant& v : variants) v.klt.SetReference(gray, features);
    } else {
      std::vector<Features> results;
      for (Variant& v : variants) {
        start = Clock::now();
        results.push_back(v.klt.Propagate(gray));
        v.ms += Ms(start);
        v.survivors += static_cast<double>(results.back().size());
      }
      // Position differences to the default variant for keypoints both still track (a
      // propagated keypoint keeps its detection-frame response, size and angle).
      std::map<std::tuple<float, float, float>, cv::Point2f> by_identity;
      for (const cv::KeyPoint& kp : results[0].keypoints) by_identity[{kp.response, kp.size, kp.angle}] = kp.pt;
      for (std::size_t k = 1; k < variants.size(); ++k) {
        for (const cv::KeyPoint& kp : results[k].keypoints) {
          const auto it = by_identity.find({kp.response, kp.size, kp.angle});
          if (it == by_identity.end()) continue;
          variants[k].position_error_sum += std::hypot(kp.pt.x - it->second.x, kp.pt.y - it->second.y);
          ++variants[k].compared;
        }
      }
    }
    ++frames;
  }
  const int propagated = frames - detections;
  std::printf("%d frames (%dx%d), SIFT on every %d-th (%d frames), one thread\n\n", frames,
              source->info().processing_size.width, source->info().processing_size.height, detect_every,
              detections);
  std::printf("| operation | ms per call | keypoints | mean offset to default (px) |\n|---|---|---|---|\n");
  std::printf("| decode | %.1f | | |\n", decode_ms / std::max(1, frames));
  std::printf("| BGR to grey | %.2f | | |\n", gray_ms / std::max(1, frames));
  std::printf("| SIFT detect + describe | %.1f | %.0f | |\n", sift_ms / std::max(1, detections),
              static_cast<double>(sift_features) / std::max(1, detections));
  for (const Variant& v : variants) {
    std::printf("| KLT: %s | %.1f | %.0f | %s |\n", v.name.c_str(), v.ms / std::max(1, propagated),
                v.survivors / std::max(1, propagated),
                v.compared ? std::to_string(v.position_error_sum / static_cast<double>(v.compared)).substr(0, 5).c_str()
                           : "-");
  }
  return 0;
}

}  // namespace
}  // namespace glam

int main(int argc, char** argv) {
  try {
    return glam::Run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
