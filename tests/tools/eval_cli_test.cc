// `glam eval` as a user runs it: output on success, and a clear message with a non-zero exit
// code (never a crash) for each kind of bad input.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "tests/tools/eval_test_world.h"

namespace glam::eval {
namespace {

using ::testing::HasSubstr;
using testing::TempDir;

constexpr double kFps = 10.0;

struct RunResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

std::string Slurp(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

RunResult RunGlam(const TempDir& scratch, const std::string& args) {
  const auto out = scratch / "stdout.txt", err = scratch / "stderr.txt";
  const std::string command = std::string("'") + GLAM_BIN + "' " + args + " >'" + out.string() +
                              "' 2>'" + err.string() + "'";
  const int status = std::system(command.c_str());
  RunResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.out = Slurp(out);
  r.err = Slurp(err);
  return r;
}

class EvalCli : public ::testing::Test {
 protected:
  void SetUp() override {
    gt_ = testing::MakeGroundTruthTrajectory(120, kFps);
    WriteTumTrajectory(gt_dir_ / "gt_trajectory.tum", gt_);
    testing::WriteSynthJson(gt_dir_.path(), kFps);
  }
  std::string Args() const {
    return "eval --gt '" + gt_dir_.path().string() + "' --result '" + result_dir_.path().string() +
           "'";
  }
  void WriteResult(const std::string& text) const {
    std::ofstream(result_dir_ / "trajectory.tum") << text;
  }

  std::vector<TimedPose> gt_;
  TempDir gt_dir_, result_dir_, scratch_;
};

TEST_F(EvalCli, PrintsSummaryAndWritesJson) {
  WriteTumTrajectory(result_dir_ / "trajectory.tum",
                     testing::TransformPoses(Sim3(2.0, SO3(), Eigen::Vector3d(1, 1, 1)), gt_));
  const auto json_path = scratch_ / "report.json";
  const RunResult r = RunGlam(scratch_, Args() + " --json '" + json_path.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("posed 100.0% (120/120)"));
  EXPECT_THAT(r.out, HasSubstr("ATE 0.000 m"));
  const nlohmann::json report = nlohmann::json::parse(Slurp(json_path));
  EXPECT_NEAR(report["alignment"]["scale"].get<double>(), 0.5, 1e-6);
  EXPECT_LT(report["trajectory"]["ate_rmse_m"].get<double>(), 1e-5);

  const RunResult as_json = RunGlam(scratch_, Args() + " --format json --no-scale");
  ASSERT_EQ(as_json.exit_code, 0) << as_json.err;
  const nlohmann::json stdout_report = nlohmann::json::parse(as_json.out);
  EXPECT_EQ(stdout_report["alignment"]["type"], "se3");
  EXPECT_GT(stdout_report["trajectory"]["ate_rmse_m"].get<double>(), 1.0);  // scale 2 kept
}

TEST_F(EvalCli, EvaluatesEachDisconnectedPartOnItsOwn) {
  // The map: the first 60 frames; parts/1: the next 50 in a frame of their own (another
  // scale and offset, which its own alignment removes); parts/2: two frames, too few.
  const std::vector<TimedPose> first(gt_.begin(), gt_.begin() + 60);
  const std::vector<TimedPose> second(gt_.begin() + 60, gt_.begin() + 110);
  WriteTumTrajectory(result_dir_ / "trajectory.tum", first);
  std::filesystem::create_directories(result_dir_ / "parts" / "1");
  std::filesystem::create_directories(result_dir_ / "parts" / "2");
  WriteTumTrajectory(result_dir_ / "parts" / "1" / "trajectory.tum",
                     testing::TransformPoses(Sim3(0.3, SO3::Exp(Eigen::Vector3d(0, 0, 1)), Eigen::Vector3d(5, 0, 0)),
                                             second));
  WriteTumTrajectory(result_dir_ / "parts" / "2" / "trajectory.tum", {gt_[115], gt_[116]});
  const RunResult r = RunGlam(scratch_, Args());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("posed 50.0% (60/120)"));
  EXPECT_THAT(r.out, HasSubstr("parts/1: posed 41.7% (50/120) | ATE 0.000 m"));
  EXPECT_THAT(r.out, HasSubstr("parts/2: not evaluated"));
  const RunResult as_json = RunGlam(scratch_, Args() + " --format json");
  ASSERT_EQ(as_json.exit_code, 0) << as_json.err;
  const nlohmann::json report = nlohmann::json::parse(as_json.out);
  ASSERT_EQ(report["parts"].size(), 2u);
  EXPECT_EQ(report["parts"][0]["directory"], "parts/1");
  EXPECT_NEAR(report["parts"][0]["alignment"]["scale"].get<double>(), 1.0 / 0.3, 1e-6);
  EXPECT_TRUE(report["parts"][1].contains("error"));
}

TEST_F(EvalCli, MissingTrajectoryFile) {
  const RunResult r = RunGlam(scratch_, Args());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("trajectory.tum"));
}

TEST_F(EvalCli, MissingGroundTruthDirectory) {
  const RunResult r = RunGlam(
      scratch_, "eval --gt /nonexistent/glam_gt --result '" + result_dir_.path().string() + "'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("/nonexistent/glam_gt"));
}

TEST_F(EvalCli, MalformedLineNamesTheLine) {
  WriteResult("# estimate\n0 0 0 0 0 0 0 1\n0.1 0 0 0 0 0 1\n");
  const RunResult r = RunGlam(scratch_, Args());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("trajectory.tum:3"));
}

TEST_F(EvalCli, EmptyTrajectory) {
  WriteResult("# nothing was localised\n");
  const RunResult r = RunGlam(scratch_, Args());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("no poses"));
}

TEST_F(EvalCli, NoOverlapInTime) {
  std::vector<TimedPose> late = gt_;
  for (TimedPose& p : late) p.timestamp += 500;
  WriteTumTrajectory(result_dir_ / "trajectory.tum", late);
  const RunResult r = RunGlam(scratch_, Args());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("overlap"));
}

TEST_F(EvalCli, FewerThanThreeMatchedPoses) {
  WriteTumTrajectory(result_dir_ / "trajectory.tum", {gt_[0], gt_[5]});
  const RunResult r = RunGlam(scratch_, Args());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("at least 3"));
}

TEST_F(EvalCli, RejectsABadPointCloud) {
  WriteTumTrajectory(result_dir_ / "trajectory.tum", gt_);
  testing::WriteHeightfieldByHand(gt_dir_.path(), {-60, -50}, 1.0, 121, 101,
                                  [](double, double) { return 0.0; });
  std::ofstream(result_dir_ / "points.ply") << "ply\nformat binary_big_endian 1.0\nend_header\n";
  const RunResult r = RunGlam(scratch_, Args());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("points.ply"));
}

}  // namespace
}  // namespace glam::eval
