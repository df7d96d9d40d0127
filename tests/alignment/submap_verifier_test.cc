// Verification must recover the similarity between two submaps from their shared landmarks,
// even with a large fraction of wrong descriptor matches (repeated texture in aerial footage),
// and must reject pairs that share nothing.
#include "engine/alignment/submap_verifier.h"

#include <random>

#include <gtest/gtest.h>

namespace glam {
namespace {

Descriptor RandomDescriptor(std::mt19937& rng) {
  std::uniform_int_distribution<int> byte(0, 255);
  Descriptor d;
  for (auto& v : d) v = static_cast<std::uint8_t>(byte(rng));
  return d;
}

Descriptor Perturb(Descriptor d, std::mt19937& rng) {
  std::uniform_int_distribution<int> delta(-6, 6);
  for (auto& v : d) v = static_cast<std::uint8_t>(std::clamp(v + delta(rng), 0, 255));
  return d;
}

Keyframe KeyframeAbove(const Eigen::Vector3d& centre) {
  Keyframe kf;
  // Camera looking straight down (z forward = -z world): rotation by pi about x.
  const SO3 cam_from_submap_rot = SO3::Exp(Eigen::Vector3d(M_PI, 0, 0));
  kf.cam_from_submap = SE3(cam_from_submap_rot, -(cam_from_submap_rot * centre));
  return kf;
}

struct SyntheticPair {
  Submap previous;
  Submap next;
  Sim3 prev_from_new;
};

// Ground points at z in [-2, 2] under cameras at height 100 (previous submap units); the
// next submap sees the last part of the same ground in its own frame (prev_from_new^-1).
SyntheticPair MakePair(double wrong_fraction, unsigned seed, int shared = 200,
                       double noise_per_axis = 0.1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_per_axis);  // height is 100
  SyntheticPair pair;
  pair.prev_from_new = Sim3(2.5, SO3::Exp(Eigen::Vector3d(0.2, -0.3, 1.1)), Eigen::Vector3d(40, -7, 3));
  const Sim3 new_from_prev = pair.prev_from_new.Inverse();
  pair.previous.id = 0;
  pair.next.id = 1;
  for (int i = 0; i < 5; ++i) pair.previous.keyframes.push_back(KeyframeAbove({i * 20.0, 0, 100}));
  for (int i = 0; i < 5; ++i) {
    pair.next.keyframes.push_back(KeyframeAbove({0, 0, 0}));
    pair.next.keyframes.back().cam_from_submap =
        SE3(pair.next.keyframes.back().cam_from_submap.rotation(), Eigen::Vector3d::Zero());
  }
  const int own = 300;
  for (int i = 0; i < own + shared; ++i) {
    Landmark lm;
    lm.id = static_cast<std::uint32_t>(i);
    lm.point_in_submap = {u(rng) * 120 - 20, u(rng) * 100 - 50, u(rng) * 4 - 2};
    lm.descriptor = RandomDescriptor(rng);
    pair.previous.landmarks.push_back(lm);
  }
  // Shared landmarks: the previous submap's last `shared`, seen again with noise in the new frame.
  std::vector<Eigen::Vector3d> shared_points;
  for (int i = own; i < own + shared; ++i) shared_points.push_back(pair.previous.landmarks[i].point_in_submap);
  // Wrong matches: the first wrong_fraction of them get another shared point's position.
  const int wrong = static_cast<int>(wrong_fraction * shared);
  std::shuffle(shared_points.begin(), shared_points.begin() + wrong, rng);
  for (int k = 0; k < shared; ++k) {
    const Landmark& source = pair.previous.landmarks[static_cast<std::size_t>(own + k)];
    Landmark lm;
    lm.id = static_cast<std::uint32_t>(k);
    const Eigen::Vector3d noisy = shared_points[static_cast<std::size_t>(k)] +
                                  Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    lm.point_in_submap = new_from_prev * noisy;
    lm.descriptor = Perturb(source.descriptor, rng);
    pair.next.landmarks.push_back(lm);
  }
  for (int k = 0; k < 150; ++k) {  // the next submap's own new ground
    Landmark lm;
    lm.id = static_cast<std::uint32_t>(shared + k);
    lm.point_in_submap = new_from_prev * Eigen::Vector3d(100 + u(rng) * 80, u(rng) * 100 - 50, 0);
    lm.descriptor = RandomDescriptor(rng);
    pair.next.landmarks.push_back(lm);
  }
  // Keyframes of the next submap above its part of the ground (for its scale; not needed for
  // linking, which uses the previous submap's scale).
  for (int i = 0; i < 5; ++i) {
    const Eigen::Vector3d centre_prev(100 + i * 20.0, 0, 100);
    pair.next.keyframes[static_cast<std::size_t>(i)] = KeyframeAbove(new_from_prev * centre_prev);
  }
  return pair;
}

TEST(SubmapVerifier, DepthScaleIsTheFlyingHeight) {
  const SyntheticPair pair = MakePair(0.0, 3);
  // Ground spreads 50 units sideways of the flight line: nearest-camera distances are
  // sqrt(100^2 + d^2) with a median a little above the height.
  EXPECT_GE(SubmapDepthScale(pair.previous), 100.0);
  EXPECT_LE(SubmapDepthScale(pair.previous), 115.0);
}

TEST(SubmapVerifier, RecoversKnownSim3With30PercentWrongMatches) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const SyntheticPair pair = MakePair(0.3, seed);
    const PairVerification result = VerifySubmapPair(pair.previous, pair.next);
    ASSERT_TRUE(result.verified) << "seed " << seed;
    EXPECT_GE(result.matches, 190);
    // 140 correct matches; a wrong one may land within the threshold by chance.
    EXPECT_GE(result.inliers, 130);
    EXPECT_LE(result.inliers, 150);
    const Sim3& est = result.reference_from_query;
    EXPECT_NEAR(est.scale() / pair.prev_from_new.scale(), 1.0, 2e-3);
    const double angle = (est.rotation() * pair.prev_from_new.rotation().Inverse()).Log().norm();
    EXPECT_LT(angle, 2e-3);
    // Compare where both put a point of the next submap's ground.
    const Eigen::Vector3d probe = pair.prev_from_new.Inverse() * Eigen::Vector3d(60, 10, 0);
    EXPECT_LT((est * probe - pair.prev_from_new * probe).norm(), 0.1);
  }
}

// The acceptance bound: landmarks with 1 % noise (RMS error 1 % of the flying height)
// and half of the correspondences wrong still give the similarity within 0.1 degrees and
// 0.1 % scale.
TEST(SubmapVerifier, OnePercentNoiseAndHalfWrongMatchesWithinTenthDegreeAndTenthPercent) {
  const double per_axis = 1.0 / std::sqrt(3.0);  // RMS norm 1 = 1 % of the height 100
  for (unsigned seed : {4u, 5u}) {
    const SyntheticPair pair = MakePair(0.5, seed, 2000, per_axis);
    const PairVerification result = VerifySubmapPair(pair.previous, pair.next);
    ASSERT_TRUE(result.verified) << "seed " << seed;
    EXPECT_GE(result.inliers, 900);
    const Sim3& est = result.reference_from_query;
    EXPECT_LT(std::abs(est.scale() / pair.prev_from_new.scale() - 1.0), 1e-3) << "seed " << seed;
    const double angle_deg =
        (est.rotation() * pair.prev_from_new.rotation().Inverse()).Log().norm() * 180.0 / M_PI;
    EXPECT_LT(angle_deg, 0.1) << "seed " << seed;
    // Inlier pairs name landmarks of the right submaps and carry their positions.
    ASSERT_EQ(result.inlier_pairs.size(), static_cast<std::size_t>(result.inliers));
    for (const LandmarkMatch& p : result.inlier_pairs) {
      ASSERT_LT(p.landmark_b, pair.next.landmarks.size());
      EXPECT_EQ(pair.next.landmarks[p.landmark_b].point_in_submap, p.point_in_b);
    }
  }
}

TEST(SubmapVerifier, UnrelatedSubmapsAreRejected) {
  SyntheticPair pair = MakePair(0.0, 5);
  std::mt19937 rng(11);
  for (Landmark& lm : pair.next.landmarks) lm.descriptor = RandomDescriptor(rng);
  const PairVerification result = VerifySubmapPair(pair.previous, pair.next);
  EXPECT_FALSE(result.verified);
}

// rotation_sigma_deg predicts the rotation error: over many noisy pairs its RMS matches the
// RMS of the true rotation error (a 3D angle, so up to ~sqrt(3) x the weakest axis' sigma),
// and it scales with the noise. Pairs it rates worse than max_rotation_sigma_deg are rejected.
// (inlier_rmse is the RMS of 3D residual norms; read as the per-axis noise, the sigma came out
// sqrt(3) too large: ratio 0.81.)
TEST(SubmapVerifier, RotationSigmaPredictsTheRotationError) {
  VerificationOptions no_check;
  no_check.max_rotation_sigma_deg = 0;
  // For the rejection check: an inlier threshold that keeps 3x the noise, with and without
  // the default sigma limit.
  VerificationOptions loose;
  loose.inlier_threshold_fraction = 0.1;
  VerificationOptions loose_no_check = loose;
  loose_no_check.max_rotation_sigma_deg = 0;
  double sum_angle2 = 0, sum_sigma2 = 0, sum_sigma_half_noise = 0, sum_sigma = 0;
  int n = 0, rejected = 0;
  for (unsigned seed = 1; seed <= 40; ++seed) {
    const SyntheticPair pair = MakePair(0.0, seed, 40, 0.6);
    const PairVerification result = VerifySubmapPair(pair.previous, pair.next, no_check);
    ASSERT_TRUE(result.verified) << "seed " << seed;
    const double angle_deg =
        (result.reference_from_query.rotation() * pair.prev_from_new.rotation().Inverse()).Log().norm() *
        180.0 / M_PI;
    sum_angle2 += angle_deg * angle_deg;
    sum_sigma2 += result.rotation_sigma_deg * result.rotation_sigma_deg;
    sum_sigma += result.rotation_sigma_deg;
    const PairVerification half = VerifySubmapPair(pair.previous, MakePair(0.0, seed, 40, 0.3).next, no_check);
    ASSERT_TRUE(half.verified);
    sum_sigma_half_noise += half.rotation_sigma_deg;
    ++n;

    // The check rejects exactly the pairs rated worse than its limit (3x the noise puts some
    // seeds on either side of the default 0.6 deg).
    const SyntheticPair noisy = MakePair(0.0, seed, 40, 1.9);
    const PairVerification rated = VerifySubmapPair(noisy.previous, noisy.next, loose_no_check);
    const PairVerification checked = VerifySubmapPair(noisy.previous, noisy.next, loose);
    ASSERT_TRUE(rated.verified) << "seed " << seed;
    EXPECT_EQ(checked.verified, rated.rotation_sigma_deg <= loose.max_rotation_sigma_deg)
        << "seed " << seed << ": sigma " << rated.rotation_sigma_deg;
    rejected += checked.verified ? 0 : 1;
  }
  const double ratio = std::sqrt(sum_angle2 / sum_sigma2);
  std::printf("rms angle / rms sigma = %.3f, rms sigma %.3f deg, half noise sigma ratio %.3f\n", ratio,
              std::sqrt(sum_sigma2 / n), sum_sigma_half_noise / sum_sigma);
  EXPECT_GT(ratio, 1.0);
  EXPECT_LT(ratio, 2.0);
  EXPECT_NEAR(sum_sigma_half_noise / sum_sigma, 0.5, 0.1);
  std::printf("%d of %d noisier pairs rejected\n", rejected, n);
  EXPECT_GT(rejected, 0);
  EXPECT_LT(rejected, n);
}

}  // namespace
}  // namespace glam
