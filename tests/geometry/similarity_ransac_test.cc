#include <random>

#include <gtest/gtest.h>

#include "engine/geometry/similarity_ransac.h"
#include "tests/geometry/synthetic_scene.h"

namespace glam {
namespace {

using testing::RotationErrorDeg;

struct Sim3Data {
  Sim3 target_from_source;
  std::vector<PointCorrespondence> data;
  std::vector<bool> is_outlier;
  double sigma = 0;
};

// Source points in a 20 m cube; noise sigma = noise_fraction x RMS radius of the target cloud.
Sim3Data MakeData(double scale, int n, double outlier_ratio, double noise_fraction, uint32_t seed) {
  std::mt19937 rng(seed);
  Sim3Data d;
  d.target_from_source = Sim3(scale, SO3::Exp(Eigen::Vector3d(0.3, -0.5, 0.8)), Eigen::Vector3d(12, -7, 3));
  std::uniform_real_distribution<double> u(-10, 10), coin(0, 1);
  const double rms_radius = scale * 10.0;  // sqrt(3 * 100 / 3) for a uniform 20 m cube
  d.sigma = noise_fraction * rms_radius;
  std::normal_distribution<double> gauss(0.0, d.sigma);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d s(u(rng), u(rng), u(rng));
    Eigen::Vector3d t = d.target_from_source * s + Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng));
    const bool outlier = coin(rng) < outlier_ratio;
    if (outlier) t = d.target_from_source * Eigen::Vector3d(u(rng), u(rng), u(rng));
    d.data.push_back({s, t});
    d.is_outlier.push_back(outlier);
  }
  return d;
}

TEST(SimilarityRansac, RecoversSim3WithNoiseAndHalfOutliers) {
  const Sim3Data d = MakeData(2.5, 1000, 0.5, 0.01, 1);
  RansacOptions options;
  options.inlier_threshold = 4.0 * d.sigma;  // |3D noise| has mean ~1.6 sigma
  const auto r = EstimateSimilarity(d.data, options);
  ASSERT_TRUE(r.success);
  EXPECT_LT(RotationErrorDeg(r.model.rotation(), d.target_from_source.rotation()), 0.1);
  EXPECT_LT(std::abs(r.model.scale() / d.target_from_source.scale() - 1.0), 1e-3);
  EXPECT_LT((r.model.translation() - d.target_from_source.translation()).norm(), 3 * d.sigma);
  int missed = 0, wrong = 0;
  for (size_t i = 0; i < d.data.size(); ++i) {
    const double true_error = (d.data[i].target - d.target_from_source * d.data[i].source).norm();
    if (!d.is_outlier[i]) missed += r.inlier_mask[i] ? 0 : 1;
    if (true_error > 5.0 * d.sigma) wrong += r.inlier_mask[i] ? 1 : 0;
  }
  EXPECT_LE(missed, 5);  // noise beyond 4 sigma in 3D is rare (~0.1 %)
  EXPECT_EQ(wrong, 0);
}

TEST(SimilarityRansac, ExactDataAndRigidMode) {
  const Sim3Data d = MakeData(1.0, 50, 0.0, 0.0, 2);
  RansacOptions options;
  options.inlier_threshold = 1e-6;
  const auto sim = EstimateSimilarity(d.data, options);
  ASSERT_TRUE(sim.success);
  EXPECT_EQ(sim.iterations, 1);
  EXPECT_NEAR(sim.model.scale(), 1.0, 1e-9);
  const auto rigid = EstimateSimilarity(d.data, options, /*estimate_scale=*/false);
  ASSERT_TRUE(rigid.success);
  EXPECT_DOUBLE_EQ(rigid.model.scale(), 1.0);
  EXPECT_LT(RotationErrorDeg(rigid.model.rotation(), d.target_from_source.rotation()), 1e-6);
}

TEST(SimilarityRansac, CollinearSamplesAreDegenerate) {
  std::vector<PointCorrespondence> line;
  for (int i = 0; i < 20; ++i) line.push_back({Eigen::Vector3d(i, 2 * i, 0), Eigen::Vector3d(i, 2 * i, 1)});
  EXPECT_TRUE(SimilarityEstimator().Fit(std::span<const PointCorrespondence>(line).first(3)).empty());
  EXPECT_FALSE(EstimateSimilarity(line, RansacOptions{}).success);
}

}  // namespace
}  // namespace glam
