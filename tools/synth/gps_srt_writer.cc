#include "tools/synth/gps_srt_writer.h"

#include <cmath>
#include <random>

#include <fmt/format.h>

namespace glam::synth {
namespace {

// SubRip time "HH:MM:SS,mmm".
std::string SrtTime(double seconds) {
  const auto ms = static_cast<std::int64_t>(std::llround(seconds * 1000));
  return fmt::format("{:02}:{:02}:{:02},{:03}", ms / 3600000, ms / 60000 % 60, ms / 1000 % 60, ms % 1000);
}

}  // namespace

std::string DjiSrtFromTrajectory(const std::vector<TimedPose>& truth, double noise_m, std::uint64_t seed,
                                 const Geodetic& origin) {
  const EnuFrame frame(origin);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_m > 0 ? noise_m : 1.0);
  std::string srt;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    Eigen::Vector3d enu = truth[i].world_from_cam.translation();
    const Eigen::Vector3d n(noise(rng), noise(rng), noise(rng));
    if (i > 0 && noise_m > 0) enu += n;
    const Geodetic g = frame.GeodeticFromEnu(enu);
    const double next = i + 1 < truth.size() ? truth[i + 1].timestamp : truth[i].timestamp + 1.0 / 30;
    srt += fmt::format(
        "{}\n{} --> {}\n<font size=\"28\">FrameCnt: {}, DiffTime: {:.0f}ms\n"
        "[latitude: {:.7f}] [longitude: {:.7f}] [rel_alt: {:.3f} abs_alt: {:.3f}] </font>\n\n",
        i + 1, SrtTime(truth[i].timestamp), SrtTime(next), i + 1, (next - truth[i].timestamp) * 1000,
        g.latitude_deg, g.longitude_deg, g.altitude_m - origin.altitude_m, g.altitude_m);
  }
  return srt;
}

}  // namespace glam::synth
