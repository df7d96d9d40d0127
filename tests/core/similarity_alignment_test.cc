// AlignSimilarity recovers known transforms from noisy correspondences.
#include "engine/core/similarity_alignment.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "engine/core/error.h"

namespace glam {
namespace {

struct Data {
  std::vector<Eigen::Vector3d> source, target;
};

Data MakeData(const Sim3& target_from_source, int n, double noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  std::normal_distribution<double> g(0.0, noise);
  Data d;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), 0.3 * u(rng));
    d.source.push_back(p);
    d.target.push_back(target_from_source * p + Eigen::Vector3d(g(rng), g(rng), g(rng)));
  }
  return d;
}

double RotationAngle(const SO3& a, const SO3& b) { return (a.Inverse() * b).Log().norm(); }

TEST(SimilarityAlignmentTest, RecoversExactSim3) {
  const Sim3 truth(2.5, SO3::Exp(Eigen::Vector3d(0.3, -1.1, 2.0)), Eigen::Vector3d(5, -3, 12));
  const Data d = MakeData(truth, 50, 0.0, 41);
  const SimilarityAlignmentResult r = AlignSimilarity(d.source, d.target);
  EXPECT_NEAR(r.target_from_source.scale(), 2.5, 1e-12);
  EXPECT_LT(RotationAngle(r.target_from_source.rotation(), truth.rotation()), 1e-12);
  EXPECT_LT((r.target_from_source.translation() - truth.translation()).norm(), 1e-10);
  EXPECT_LT(r.rmse, 1e-10);
}

TEST(SimilarityAlignmentTest, RecoversSim3FromNoisyPoints) {
  const Sim3 truth(0.4, SO3::Exp(Eigen::Vector3d(-2.0, 0.5, 0.7)), Eigen::Vector3d(-1, 8, 3));
  const double noise = 0.02;
  const Data d = MakeData(truth, 400, noise, 42);
  const SimilarityAlignmentResult r = AlignSimilarity(d.source, d.target);
  EXPECT_NEAR(r.target_from_source.scale(), 0.4, 1e-3);
  EXPECT_LT(RotationAngle(r.target_from_source.rotation(), truth.rotation()), 1e-3);
  EXPECT_LT((r.target_from_source.translation() - truth.translation()).norm(), 1e-2);
  // Isotropic noise of sigma per axis leaves an rmse of about sigma * sqrt(3).
  EXPECT_NEAR(r.rmse, noise * std::sqrt(3.0), 0.15 * noise * std::sqrt(3.0));
}

TEST(SimilarityAlignmentTest, RigidAlignmentKeepsUnitScale) {
  const Sim3 rigid(1.0, SO3::Exp(Eigen::Vector3d(0.1, 0.2, -2.9)), Eigen::Vector3d(4, 4, -2));
  const double noise = 0.01;
  const Data d = MakeData(rigid, 300, noise, 43);
  const SimilarityAlignmentResult r = AlignSimilarity(d.source, d.target, false);
  EXPECT_EQ(r.target_from_source.scale(), 1.0);
  EXPECT_LT(RotationAngle(r.target_from_source.rotation(), rigid.rotation()), 1e-3);
  EXPECT_LT((r.target_from_source.translation() - rigid.translation()).norm(), 1e-2);
  EXPECT_NEAR(r.rmse, noise * std::sqrt(3.0), 0.15 * noise * std::sqrt(3.0));

  // Data that really has scale 3: a rigid fit cannot explain it, a similarity fit can.
  const Data scaled =
      MakeData(Sim3(3.0, rigid.rotation(), rigid.translation()), 300, noise, 44);
  const SimilarityAlignmentResult rigid_fit = AlignSimilarity(scaled.source, scaled.target, false);
  const SimilarityAlignmentResult sim_fit = AlignSimilarity(scaled.source, scaled.target, true);
  EXPECT_EQ(rigid_fit.target_from_source.scale(), 1.0);
  EXPECT_GT(rigid_fit.rmse, 1.0);
  EXPECT_NEAR(sim_fit.target_from_source.scale(), 3.0, 1e-3);
  EXPECT_LT(sim_fit.rmse, 2 * noise * std::sqrt(3.0));
}

TEST(SimilarityAlignmentTest, MinimalThreePoints) {
  const Sim3 truth(1.7, SO3::Exp(Eigen::Vector3d(1.0, 1.0, 0.0)), Eigen::Vector3d(0, 1, 2));
  const Data d = MakeData(truth, 3, 0.0, 45);
  const SimilarityAlignmentResult r = AlignSimilarity(d.source, d.target);
  EXPECT_LT((r.target_from_source.matrix() - truth.matrix()).norm(), 1e-10);
}

TEST(SimilarityAlignmentTest, RejectsBadInput) {
  const Data d = MakeData(Sim3(), 10, 0.0, 46);
  std::vector<Eigen::Vector3d> shorter = d.target;
  shorter.pop_back();
  EXPECT_THROW(AlignSimilarity(d.source, shorter), InputError);
  const std::vector<Eigen::Vector3d> two(d.source.begin(), d.source.begin() + 2);
  EXPECT_THROW(AlignSimilarity(two, two), InputError);
  std::vector<Eigen::Vector3d> line;
  for (int i = 0; i < 10; ++i) line.push_back(Eigen::Vector3d(1, 2, 3) * i);
  EXPECT_THROW(AlignSimilarity(line, d.target), InputError);
  const std::vector<Eigen::Vector3d> same(10, Eigen::Vector3d(1, 1, 1));
  EXPECT_THROW(AlignSimilarity(same, d.target), InputError);
  EXPECT_THROW(AlignSimilarity(d.source, same), InputError);
  std::vector<Eigen::Vector3d> nan = d.target;
  nan[3].x() = std::nan("");
  EXPECT_THROW(AlignSimilarity(d.source, nan), InputError);
}

}  // namespace
}  // namespace glam
