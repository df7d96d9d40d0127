// Where an interrupted mapping run continues (MappingOptions::resume). Rewritten atomically
// after every completed submap as `checkpoint.json` in the run's out_dir, next to the
// persisted submaps it refers to: the next submap id, the first input frame the open submap
// needs (the start of the 10 % overlap, or the frame after a tracking loss) and the focal
// estimate so far. Everything before that frame lives in submaps/<id>/ already, so a server
// killed mid-job loses at most the work on one open submap.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace glam {

struct ResumeCheckpoint {
  std::uint32_t next_submap_id = 0;
  std::int64_t resume_frame = 0;  // input frame index (FrameSource::SeekTo)
  double focal = 0;               // processing pixels
  // The focal was held at its initial value (SubmapOptions::focal_profile_step): the resumed
  // run keeps it fixed too, so the submaps before and after agree on it.
  bool focal_held = false;
  // Radial distortion estimate so far (the given k1 when it is not estimated), and whether it
  // was held at the initial value (SubmapOptions::k1_profile_min_rms_increase): kept so.
  double k1 = 0;
  bool k1_held = false;
  // Rolling-shutter readout the run estimated (ms; SubmapOptions::estimate_readout), unset when
  // not estimated: the resumed run corrects its keypoints with it instead of deciding again.
  std::optional<double> readout_ms;
  // What the checkpoint belongs to: a different input or processing size cannot resume.
  std::string input;
  int processing_width = 0;
  int processing_height = 0;
  // The run's id (tile URIs carry it; see BuildTileset): a resumed run keeps it. Empty in
  // checkpoints written before it existed.
  std::string run_id;
  // Photo folders: how many photos the EXIF capture order moved (MappingReport). Frame indices
  // are places in that order, so a run whose order differs (--name-order now, or a checkpoint
  // of a version that mapped photos in name order: absent = 0) cannot resume from it.
  std::int64_t photos_reordered_by_time = 0;
};

inline constexpr char kCheckpointFile[] = "checkpoint.json";

// Atomic (temporary file + rename). Throws EnvironmentError.
void WriteCheckpoint(const std::filesystem::path& out_dir, const ResumeCheckpoint& checkpoint);

// nullopt when there is none; InputError when it exists but cannot be parsed.
std::optional<ResumeCheckpoint> ReadCheckpoint(const std::filesystem::path& out_dir);

}  // namespace glam
