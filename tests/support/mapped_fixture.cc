#include "tests/support/mapped_fixture.h"

#include <iostream>

#include "engine/core/intrinsics_io.h"
#include "engine/pipeline/mapping_job.h"
#include "tests/support/temp_dir.h"

namespace glam::test_support {

namespace fs = std::filesystem;

MappedFixture MapFixture(const fs::path& clip, MappingOptions options, bool calibrated, const std::string& name,
                         const std::function<void(const fs::path& out)>& inspect) {
  if (calibrated) UseCalibration(&options, ReadIntrinsicsJson(clip / "intrinsics.json"));
  const fs::path out = testing::FreshTempDir(clip.filename().string() + "_" + name);
  MappedFixture run;
  run.report = RunMapping(clip / "video.mp4", out, options);
  run.result = eval::EvaluateDirectories(clip, out, {});
  std::cout << name << ": focal " << run.report.focal << " px, k1 " << run.report.k1 << ", "
            << run.report.moving_landmarks_removed << " moving landmarks removed, " << eval::Summary(run.result)
            << "\n";
  for (const PartExport& part : run.report.parts) {
    const std::string directory = "parts/" + std::to_string(part.number);
    run.parts.push_back(eval::EvaluateDirectories(clip, out / directory, {}));
    std::cout << name << ", " << directory << ": " << eval::Summary(run.parts.back()) << "\n";
  }
  if (inspect) inspect(out);
  fs::remove_all(out);
  return run;
}

}  // namespace glam::test_support
