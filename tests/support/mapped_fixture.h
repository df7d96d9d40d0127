// One end-to-end run of a synthetic fixture, as `glam map` then `glam eval` do it: the pipeline
// tests that compare a default against a control configuration on the same clip all map into a
// scratch directory, score the result against the fixture's ground truth, read a few things the
// run wrote and delete the directory again. This does that once, so each test states only its
// configurations and its bounds.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "engine/pipeline/mapping_options.h"
#include "engine/pipeline/mapping_report.h"
#include "tools/eval/evaluation.h"

namespace glam::test_support {

struct MappedFixture {
  MappingReport report;                        // as RunMapping returned it (report.json)
  eval::EvaluationResult result;               // the map against the fixture's truth
  std::vector<eval::EvaluationResult> parts;   // parts/<n>/, in the order of report.parts
};

// Maps `clip`/video.mp4 with `options` into a scratch directory named after `name` (with the
// fixture's intrinsics.json when `calibrated`, else as a user without intrinsics does),
// evaluates the map and every disconnected part against the fixture, prints one summary line
// per result (ctest's log keeps the measured numbers the tests' comments quote), calls
// `inspect` with the output directory for anything else the test reads from it (submaps,
// graph.json), then removes the directory.
MappedFixture MapFixture(const std::filesystem::path& clip, MappingOptions options, bool calibrated,
                         const std::string& name,
                         const std::function<void(const std::filesystem::path& out)>& inspect = {});

}  // namespace glam::test_support
