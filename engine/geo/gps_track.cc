#include "engine/geo/gps_track.h"

#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>

#include <fmt/format.h>

#include "engine/core/error.h"

namespace glam {
namespace {

const std::regex kTime(R"((\d+):(\d+):(\d+)[,.](\d+)\s*-->)");
const std::regex kLatitude(R"(\[\s*latitude\s*:\s*(-?[0-9.]+)\s*\])", std::regex::icase);
const std::regex kLongitude(R"(\[\s*longt?itude\s*:\s*(-?[0-9.]+)\s*\])", std::regex::icase);
const std::regex kAbsAltitude(R"(abs_alt\s*:\s*(-?[0-9.]+))", std::regex::icase);
const std::regex kRelAltitude(R"(rel_alt\s*:\s*(-?[0-9.]+))", std::regex::icase);
const std::regex kAltitude(R"(\[\s*altitude\s*:\s*(-?[0-9.]+)\s*\])", std::regex::icase);
const std::regex kGpsTuple(R"(GPS\s*\(\s*(-?[0-9.]+)\s*,\s*(-?[0-9.]+)\s*,\s*(-?[0-9.]+)\s*\))", std::regex::icase);

std::optional<double> Find(const std::string& text, const std::regex& re) {
  std::smatch m;
  if (!std::regex_search(text, m, re)) return std::nullopt;
  try {
    return std::stod(m[1].str());
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// One subtitle entry (its lines joined): the sample, if it carries a position.
std::optional<GpsSample> ParseEntry(const std::string& entry) {
  std::smatch t;
  if (!std::regex_search(entry, t, kTime)) return std::nullopt;
  GpsSample s;
  const std::string fraction = t[4].str();
  s.time_s = std::stod(t[1].str()) * 3600 + std::stod(t[2].str()) * 60 + std::stod(t[3].str()) +
             std::stod(fraction) / std::pow(10.0, static_cast<double>(fraction.size()));
  std::smatch g;
  if (std::regex_search(entry, g, kGpsTuple)) {
    s.position.longitude_deg = std::stod(g[1].str());
    s.position.latitude_deg = std::stod(g[2].str());
    s.position.altitude_m = std::stod(g[3].str());
  } else {
    const std::optional<double> lat = Find(entry, kLatitude), lon = Find(entry, kLongitude);
    if (!lat || !lon) return std::nullopt;
    s.position.latitude_deg = *lat;
    s.position.longitude_deg = *lon;
    std::optional<double> alt = Find(entry, kAbsAltitude);
    if (!alt) alt = Find(entry, kAltitude);
    if (!alt) alt = Find(entry, kRelAltitude);
    s.position.altitude_m = alt.value_or(0.0);
  }
  const Geodetic& p = s.position;
  if ((p.latitude_deg == 0 && p.longitude_deg == 0) || std::abs(p.latitude_deg) > 90 ||
      std::abs(p.longitude_deg) > 180) {
    return std::nullopt;  // no fix, or not a position
  }
  return s;
}

}  // namespace

std::vector<GpsSample> ParseDjiSrt(const std::string& text) {
  std::vector<GpsSample> samples;
  std::istringstream in(text);
  std::string line, entry;
  auto flush = [&] {
    if (const std::optional<GpsSample> s = ParseEntry(entry)) samples.push_back(*s);
    entry.clear();
  };
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) {
      flush();
    } else {
      entry += line;
      entry += '\n';
    }
  }
  flush();
  if (samples.empty()) {
    throw InputError(
        "no GPS positions found: expected DJI subtitle telemetry (.SRT) with entries like "
        "\"00:00:00,000 --> 00:00:00,033\" and \"[latitude: 47.1] [longitude: 8.5] [abs_alt: 420.0]\" "
        "or \"GPS(8.5,47.1,420)\"");
  }
  return samples;
}

std::vector<GpsSample> ReadGpsTrack(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("cannot read GPS track {}", path.string()));
  std::ostringstream text;
  text << in.rdbuf();
  try {
    return ParseDjiSrt(text.str());
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", path.string(), e.what()));
  }
}

std::optional<std::filesystem::path> FindGpsSidecar(const std::filesystem::path& video) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(video, ec)) return std::nullopt;
  for (const char* extension : {".SRT", ".srt"}) {
    std::filesystem::path candidate = video;
    candidate.replace_extension(extension);
    if (std::filesystem::is_regular_file(candidate, ec)) return candidate;
  }
  return std::nullopt;
}

}  // namespace glam
