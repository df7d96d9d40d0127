#include "engine/map/submap_io.h"

#include <string_view>

#include <fmt/format.h>

#include "engine/core/binary_io.h"

namespace glam {
namespace {

constexpr std::string_view kMagic(kSubmapMagic, 8);
constexpr char kFileName[] = "submap.bin";
// Sanity bounds that reject corrupt counts before allocating.
constexpr std::uint32_t kMaxKeyframes = 1u << 16;
constexpr std::uint32_t kMaxLandmarks = 1u << 24;
constexpr std::uint32_t kMaxObservations = 1u << 16;
constexpr std::uint32_t kMaxFrames = 1u << 24;

void WritePose(BinaryWriter& w, const SE3& pose) {
  const Eigen::Quaterniond& q = pose.rotation().quaternion();
  const double values[7] = {q.w(), q.x(), q.y(), q.z(), pose.translation().x(),
                            pose.translation().y(), pose.translation().z()};
  w.WriteArray(values, 7);
}

SE3 ReadPose(BinaryReader& r) {
  double v[7];
  r.ReadArray(v, 7);
  Eigen::Quaterniond q(v[0], v[1], v[2], v[3]);
  if (!(std::abs(q.norm() - 1.0) < 1e-6)) throw InputError("submap file holds a non-unit rotation");
  return SE3(SO3(q), Eigen::Vector3d(v[4], v[5], v[6]));
}

void WriteIntrinsics(BinaryWriter& w, const Intrinsics& in) {
  w.WriteString(in.model);
  w.Write<std::int32_t>(in.width);
  w.Write<std::int32_t>(in.height);
  const double values[6] = {in.fx, in.fy, in.cx, in.cy, in.k1, in.k2};
  w.WriteArray(values, 6);
}

Intrinsics ReadIntrinsics(BinaryReader& r) {
  Intrinsics in;
  in.model = r.ReadString();
  in.width = r.Read<std::int32_t>();
  in.height = r.Read<std::int32_t>();
  double v[6];
  r.ReadArray(v, 6);
  in.fx = v[0], in.fy = v[1], in.cx = v[2], in.cy = v[3], in.k1 = v[4], in.k2 = v[5];
  return in;
}

}  // namespace

std::filesystem::path SubmapDirectory(const std::filesystem::path& submaps_root, std::uint32_t id) {
  return submaps_root / fmt::format("{:06d}", id);
}

void WriteSubmap(const Submap& submap, const std::filesystem::path& submaps_root) {
  const auto dir = SubmapDirectory(submaps_root, submap.id);
  std::filesystem::create_directories(dir);
  BinaryWriter w(dir / kFileName, kMagic, kSubmapFormatVersion);
  w.Write<std::uint32_t>(submap.id);
  w.Write<std::int64_t>(submap.first_frame);
  w.Write<std::int64_t>(submap.last_frame);
  WriteIntrinsics(w, submap.intrinsics);

  w.Write<std::uint32_t>(static_cast<std::uint32_t>(submap.keyframes.size()));
  for (const Keyframe& kf : submap.keyframes) {
    w.Write<std::int64_t>(kf.frame_index);
    WritePose(w, kf.cam_from_submap);
    w.Write<double>(kf.focal);
  }

  w.Write<std::uint32_t>(static_cast<std::uint32_t>(submap.landmarks.size()));
  for (const Landmark& lm : submap.landmarks) {
    w.Write<std::uint32_t>(lm.id);
    w.WriteArray(lm.point_in_submap.data(), 3);
    w.WriteArray(lm.color.data(), lm.color.size());
    w.WriteArray(lm.descriptor.data(), lm.descriptor.size());
    w.Write<std::uint32_t>(static_cast<std::uint32_t>(lm.observations.size()));
    for (const Observation& obs : lm.observations) {
      w.Write<std::uint32_t>(obs.keyframe);
      w.WriteArray(obs.pixel.data(), 2);
    }
  }

  w.Write<std::uint32_t>(static_cast<std::uint32_t>(submap.frame_poses.size()));
  for (const FramePose& fp : submap.frame_poses) {
    w.Write<std::int64_t>(fp.frame_index);
    w.Write<double>(fp.timestamp_s);
    WritePose(w, fp.cam_from_submap);
    w.Write<std::uint32_t>(fp.pnp_inliers);
  }

  w.Write<SubmapStats>(submap.stats);
  w.Finish();
}

Submap ReadSubmap(const std::filesystem::path& submaps_root, std::uint32_t id) {
  BinaryReader r(SubmapDirectory(submaps_root, id) / kFileName, kMagic, kSubmapFormatVersion);
  Submap submap;
  submap.id = r.Read<std::uint32_t>();
  if (submap.id != id) {
    throw InputError(fmt::format("submap file of id {} holds submap {}", id, submap.id));
  }
  submap.first_frame = r.Read<std::int64_t>();
  submap.last_frame = r.Read<std::int64_t>();
  submap.intrinsics = ReadIntrinsics(r);

  submap.keyframes.resize(r.ReadCount(kMaxKeyframes));
  for (Keyframe& kf : submap.keyframes) {
    kf.frame_index = r.Read<std::int64_t>();
    kf.cam_from_submap = ReadPose(r);
    kf.focal = r.Read<double>();
  }

  submap.landmarks.resize(r.ReadCount(kMaxLandmarks));
  for (Landmark& lm : submap.landmarks) {
    lm.id = r.Read<std::uint32_t>();
    r.ReadArray(lm.point_in_submap.data(), 3);
    r.ReadArray(lm.color.data(), lm.color.size());
    r.ReadArray(lm.descriptor.data(), lm.descriptor.size());
    lm.observations.resize(r.ReadCount(kMaxObservations));
    for (Observation& obs : lm.observations) {
      obs.keyframe = r.Read<std::uint32_t>();
      if (obs.keyframe >= submap.keyframes.size()) {
        throw InputError(fmt::format("submap {} is corrupt: observation of keyframe {} of {}", id,
                                     obs.keyframe, submap.keyframes.size()));
      }
      r.ReadArray(obs.pixel.data(), 2);
    }
  }

  submap.frame_poses.resize(r.ReadCount(kMaxFrames));
  for (FramePose& fp : submap.frame_poses) {
    fp.frame_index = r.Read<std::int64_t>();
    fp.timestamp_s = r.Read<double>();
    fp.cam_from_submap = ReadPose(r);
    fp.pnp_inliers = r.Read<std::uint32_t>();
  }
  submap.stats = r.Read<SubmapStats>();
  return submap;
}

}  // namespace glam
