#include "engine/submap/bundle_adjuster.h"

#include <random>

#include <gtest/gtest.h>

#include "engine/core/median.h"
#include "engine/core/similarity_alignment.h"

namespace glam {
namespace {

// A small aerial scene: ground with relief seen by a strip of oblique keyframes, observed
// exactly by a known camera. Tests perturb it and check that BA restores it.
struct Scene {
  Intrinsics intrinsics;
  std::vector<Keyframe> keyframes;
  std::vector<Landmark> landmarks;
};

Scene MakeScene(double true_focal, double pixel_noise, std::uint32_t seed, double k1 = -0.02) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> noise(0, pixel_noise);
  Scene s;
  s.intrinsics = {"radial", 640, 360, true_focal, true_focal, 319.5, 179.5, k1, 0.0};
  // Cameras at 100 m altitude moving east, tilted 25 deg forward and yawing a little, so the
  // focal length is observable (not a flat nadir scene).
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d centre(k * 12.0, 3.0 * std::sin(k), 100.0);
    const SO3 nadir(Eigen::Matrix3d((Eigen::Matrix3d() << 1, 0, 0, 0, -1, 0, 0, 0, -1).finished()));
    const SO3 world_from_cam = SO3::Exp(Eigen::Vector3d(0, 0, 0.05 * k)) *
                               SO3::Exp(Eigen::Vector3d(0, 0.4, 0)) * nadir;
    Keyframe kf;
    kf.frame_index = k * 10;
    kf.cam_from_submap = SE3(world_from_cam, centre).Inverse();
    kf.focal = true_focal;
    s.keyframes.push_back(kf);
  }
  const Camera camera(s.intrinsics);
  while (s.landmarks.size() < 400) {
    Landmark lm;
    const double x = 40 + 90 * u(rng), y = 70 * u(rng);
    lm.point_in_submap = Eigen::Vector3d(x, y, 15 * std::sin(x / 17) * std::cos(y / 23) + 5 * u(rng));
    for (std::uint32_t k = 0; k < s.keyframes.size(); ++k) {
      Eigen::Vector2d px;
      if (camera.Project(s.keyframes[k].cam_from_submap * lm.point_in_submap, &px) &&
          camera.InImage(px, 2)) {
        lm.observations.push_back({k, Eigen::Vector2f(float(px.x() + noise(rng)), float(px.y() + noise(rng)))});
      }
    }
    if (lm.observations.size() >= 3) s.landmarks.push_back(lm);
  }
  return s;
}

std::vector<Eigen::Vector3d> Centres(const std::vector<Keyframe>& kfs) {
  std::vector<Eigen::Vector3d> c;
  for (const Keyframe& kf : kfs) c.push_back(kf.cam_from_submap.Inverse().translation());
  return c;
}

// Moves every keyframe but the first (the gauge) and every landmark at random: translations
// and points by ~`metres` per axis, rotations by ~`radians` per axis.
void Perturb(Scene* s, std::uint32_t seed, double metres, double radians) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, 1);
  for (std::size_t k = 1; k < s->keyframes.size(); ++k) {
    Vector6d d;
    d << metres * n(rng), metres * n(rng), metres * n(rng), radians * n(rng), radians * n(rng), radians * n(rng);
    s->keyframes[k].cam_from_submap = SE3::Exp(d) * s->keyframes[k].cam_from_submap;
  }
  for (Landmark& lm : s->landmarks) lm.point_in_submap += Eigen::Vector3d(n(rng), n(rng), n(rng)) * metres;
}

TEST(BundleAdjuster, RestoresPerturbedSceneUpToGauge) {
  const Scene truth = MakeScene(500, 0.3, 1);
  Scene est = truth;
  Perturb(&est, 2, 0.5, 0.005);

  BundleAdjustmentOptions options;
  options.refine_focal = false;
  options.max_iterations = 50;
  const auto summary = BundleAdjust(est.intrinsics, est.keyframes, est.landmarks, options);
  EXPECT_GT(summary.initial_rms_pixels, 3.0);
  EXPECT_LT(summary.final_rms_pixels, 0.45);  // noise is 0.3 px per axis
  // First keyframe is the gauge: untouched.
  EXPECT_TRUE(est.keyframes[0].cam_from_submap.matrix().isApprox(truth.keyframes[0].cam_from_submap.matrix(), 1e-12));
  const auto aligned = AlignSimilarity(Centres(est.keyframes), Centres(truth.keyframes));
  // Perturbation was ~0.9 m RMS; 0.3 px of noise is ~0.06 m at this range.
  EXPECT_LT(aligned.rmse, 0.1);  // metres, at 100 m altitude
}

// Local adjustment: only the last keyframes and the landmarks they see move, held in place by
// the older keyframes that see those landmarks too, which also fix the gauge (no alignment
// needed to compare with the truth).
TEST(BundleAdjuster, LocalAdjustmentMovesOnlyTheLastKeyframesAndTheirLandmarks) {
  const Scene truth = MakeScene(500, 0.3, 11);
  Scene est = truth;
  std::mt19937 rng(12);
  std::normal_distribution<double> n(0, 1);
  constexpr std::size_t kWindow = 3;
  const std::size_t first_free = est.keyframes.size() - kWindow;
  for (std::size_t k = first_free; k < est.keyframes.size(); ++k) {
    Vector6d d;
    d << 0.5 * n(rng), 0.5 * n(rng), 0.5 * n(rng), 0.005 * n(rng), 0.005 * n(rng), 0.005 * n(rng);
    est.keyframes[k].cam_from_submap = SE3::Exp(d) * est.keyframes[k].cam_from_submap;
  }
  std::size_t outside = 0;
  for (Landmark& lm : est.landmarks) {
    bool seen = false;
    for (const Observation& obs : lm.observations) seen = seen || obs.keyframe >= first_free;
    if (seen) {
      lm.point_in_submap += 0.3 * Eigen::Vector3d(n(rng), n(rng), n(rng));
    } else {
      ++outside;
    }
  }
  ASSERT_GT(outside, 20u);
  const Scene before = est;
  BundleAdjustmentOptions options;
  options.refine_focal = false;
  options.refine_k1 = false;
  options.max_iterations = 50;
  options.local_keyframes = static_cast<int>(kWindow);
  const auto summary = BundleAdjust(est.intrinsics, est.keyframes, est.landmarks, options);
  EXPECT_GT(summary.initial_rms_pixels, 2.0);  // over all landmarks, most unperturbed
  EXPECT_LT(summary.final_rms_pixels, 0.45);  // noise is 0.3 px per axis
  for (std::size_t k = 0; k < first_free; ++k) {
    EXPECT_EQ(est.keyframes[k].cam_from_submap.matrix(), before.keyframes[k].cam_from_submap.matrix()) << k;
  }
  for (std::size_t i = 0; i < est.landmarks.size(); ++i) {
    bool seen = false;
    for (const Observation& obs : est.landmarks[i].observations) seen = seen || obs.keyframe >= first_free;
    if (!seen) {
      EXPECT_EQ(est.landmarks[i].point_in_submap, before.landmarks[i].point_in_submap) << i;
    }
  }
  const std::vector<Eigen::Vector3d> centres = Centres(est.keyframes);
  const std::vector<Eigen::Vector3d> true_centres = Centres(truth.keyframes);
  for (std::size_t k = first_free; k < centres.size(); ++k) {
    // Perturbed by ~0.9 m; back within the noise's reach, in the held keyframes' gauge.
    EXPECT_LT((centres[k] - true_centres[k]).norm(), 0.1) << k;
  }

  // Held keyframes that see too few of the window's landmarks cannot anchor it: the whole
  // submap is adjusted instead (every keyframe after the first moves).
  Scene whole = before;
  options.local_min_anchor_observations = 100000;
  BundleAdjust(whole.intrinsics, whole.keyframes, whole.landmarks, options);
  EXPECT_EQ(whole.keyframes[0].cam_from_submap.matrix(), before.keyframes[0].cam_from_submap.matrix());
  EXPECT_NE(whole.keyframes[2].cam_from_submap.matrix(), before.keyframes[2].cam_from_submap.matrix());
}

TEST(BundleAdjuster, DenseAndSparseSchurReachTheSameSolution) {
  // The solver is chosen by keyframe count for speed only: both must give the same answer.
  const Scene truth = MakeScene(500, 0.3, 5);
  Scene start = truth;
  Perturb(&start, 6, 0.3, 0.003);
  for (std::size_t k = 1; k < start.keyframes.size(); ++k) start.keyframes[k].focal = 530;
  Scene dense = start, sparse = start;
  BundleAdjustmentOptions options;
  options.max_iterations = 50;
  options.dense_schur_max_keyframes = 100;
  const auto dense_summary = BundleAdjust(dense.intrinsics, dense.keyframes, dense.landmarks, options);
  options.dense_schur_max_keyframes = 0;
  const auto sparse_summary = BundleAdjust(sparse.intrinsics, sparse.keyframes, sparse.landmarks, options);
  EXPECT_LT(dense_summary.final_rms_pixels, 0.45);
  EXPECT_NEAR(dense_summary.final_rms_pixels, sparse_summary.final_rms_pixels, 1e-6);
  EXPECT_NEAR(dense.keyframes[3].focal, sparse.keyframes[3].focal, 1e-3);
  EXPECT_NEAR(dense_summary.k1, sparse_summary.k1, 1e-6);
  const std::vector<Eigen::Vector3d> dense_centres = Centres(dense.keyframes);
  const std::vector<Eigen::Vector3d> sparse_centres = Centres(sparse.keyframes);
  for (std::size_t k = 0; k < dense_centres.size(); ++k) {
    EXPECT_LT((dense_centres[k] - sparse_centres[k]).norm(), 1e-4) << "keyframe " << k;  // metres, at 100 m altitude
  }
}

TEST(BundleAdjuster, EstimatesFocalFromTenPercentWrongStart) {
  const double true_focal = 520;
  const Scene truth = MakeScene(true_focal, 0.2, 3);
  for (const bool shared : {false, true}) {
    SCOPED_TRACE(shared ? "one focal for all keyframes" : "one focal per keyframe");
    Scene est = truth;
    for (Keyframe& kf : est.keyframes) kf.focal = true_focal * 1.1;
    BundleAdjustmentOptions options;
    options.focal_prior_weight = 0.1;  // weak: the data should decide
    options.max_iterations = 100;
    options.share_focal = shared;
    BundleAdjust(est.intrinsics, est.keyframes, est.landmarks, options);
    std::vector<double> focals;
    for (const Keyframe& kf : est.keyframes) focals.push_back(kf.focal);
    EXPECT_NEAR(UpperMedian(focals), true_focal, 0.01 * true_focal);
    if (shared) {
      for (const Keyframe& kf : est.keyframes) EXPECT_EQ(kf.focal, est.keyframes[0].focal);
    }
  }
}

TEST(BundleAdjuster, EstimatesASharedK1FromAPinholeStart) {
  // A barrel lens (k1 = -0.12: 13 px at the frame corner) adjusted as if distortion-free at
  // first; the focal is free as well, so k1 must be told apart from it.
  const double true_k1 = -0.12;
  const Scene truth = MakeScene(520, 0.2, 8, true_k1);
  Scene est = truth;
  est.intrinsics.k1 = 0.0;
  BundleAdjustmentOptions options;
  options.k1_prior_weight = 0.0;
  options.max_iterations = 100;
  const auto summary = BundleAdjust(est.intrinsics, est.keyframes, est.landmarks, options);
  EXPECT_NEAR(summary.k1, true_k1, 0.005);
  EXPECT_NEAR(est.keyframes[0].focal, 520, 0.01 * 520);
  EXPECT_LT(summary.final_rms_pixels, 0.3);  // noise 0.2 px per axis
  EXPECT_GT(summary.initial_rms_pixels, 2.0);

  // Not refined: k1 stays the camera's, and the fit is worse although poses, points and the
  // focal absorb much of the distortion (measured 0.37 against 0.24 px).
  Scene fixed = truth;
  fixed.intrinsics.k1 = 0.0;
  options.refine_k1 = false;
  const auto held = BundleAdjust(fixed.intrinsics, fixed.keyframes, fixed.landmarks, options);
  EXPECT_EQ(held.k1, 0.0);
  EXPECT_GT(held.final_rms_pixels, 1.3 * summary.final_rms_pixels);

  // A prior that decides keeps k1 at the camera's value.
  Scene anchored = truth;
  anchored.intrinsics.k1 = 0.0;
  options.refine_k1 = true;
  options.k1_prior_weight = 1e7;
  EXPECT_NEAR(BundleAdjust(anchored.intrinsics, anchored.keyframes, anchored.landmarks, options).k1, 0.0, 1e-4);
}

TEST(BundleAdjuster, FocalPriorIsCentredWhereTheOptionsSay) {
  // Exact data at the true focal and a prior so strong that it decides: without a centre the
  // focals stay at their own (true) values; with one, they move to it.
  const double true_focal = 520;
  const Scene truth = MakeScene(true_focal, 0.0, 6);
  for (const bool shared : {false, true}) {
    SCOPED_TRACE(shared ? "shared" : "per keyframe");
    BundleAdjustmentOptions options;
    options.focal_prior_weight = 1e7;
    options.share_focal = shared;
    Scene own = truth;
    BundleAdjust(own.intrinsics, own.keyframes, own.landmarks, options);
    for (const Keyframe& kf : own.keyframes) EXPECT_NEAR(kf.focal, true_focal, 1e-3 * true_focal);
    options.focal_prior_px = 1.05 * true_focal;
    Scene centred = truth;
    BundleAdjust(centred.intrinsics, centred.keyframes, centred.landmarks, options);
    for (const Keyframe& kf : centred.keyframes) EXPECT_NEAR(kf.focal, 1.05 * true_focal, 1e-3 * true_focal);
  }
}

TEST(BundleAdjuster, FixedFocalsStayEachKeyframesOwnEvenWhenShared) {
  Scene s = MakeScene(520, 0.2, 7);
  for (std::size_t k = 0; k < s.keyframes.size(); ++k) s.keyframes[k].focal = 520 + k;
  BundleAdjustmentOptions options;
  options.refine_focal = false;
  options.share_focal = true;
  BundleAdjust(s.intrinsics, s.keyframes, s.landmarks, options);
  for (std::size_t k = 0; k < s.keyframes.size(); ++k) EXPECT_EQ(s.keyframes[k].focal, 520.0 + k);
}

TEST(BundleAdjuster, CancelledTokenThrows) {
  Scene s = MakeScene(500, 0.3, 4);
  CancellationToken cancel;
  cancel.Cancel();
  EXPECT_THROW(BundleAdjust(s.intrinsics, s.keyframes, s.landmarks, {}, cancel), Cancelled);
}

TEST(BundleAdjuster, RejectsBadOptions) {
  Scene s = MakeScene(500, 0.3, 5);
  BundleAdjustmentOptions options;
  options.huber_pixels = -1;
  EXPECT_THROW(BundleAdjust(s.intrinsics, s.keyframes, s.landmarks, options), InputError);
  options = {};
  options.focal_prior_px = -1;
  EXPECT_THROW(BundleAdjust(s.intrinsics, s.keyframes, s.landmarks, options), InputError);
  options = {};
  options.k1_prior_weight = -1;
  EXPECT_THROW(BundleAdjust(s.intrinsics, s.keyframes, s.landmarks, options), InputError);
  options = {};
  options.local_keyframes = -1;
  EXPECT_THROW(BundleAdjust(s.intrinsics, s.keyframes, s.landmarks, options), InputError);
  options = {};
  options.dense_schur_max_keyframes = -1;
  EXPECT_THROW(BundleAdjust(s.intrinsics, s.keyframes, s.landmarks, options), InputError);
}

TEST(BundleAdjuster, ReprojectionErrorIsZeroForExactObservation) {
  const Scene s = MakeScene(500, 0.0, 6);
  const Landmark& lm = s.landmarks.front();
  for (const Observation& obs : lm.observations) {
    EXPECT_LT(ReprojectionError(s.intrinsics, s.keyframes[obs.keyframe], lm.point_in_submap, obs.pixel), 1e-3);
  }
  // One pixel off along x is one pixel of error.
  Eigen::Vector2f shifted = lm.observations[0].pixel + Eigen::Vector2f(1, 0);
  EXPECT_NEAR(ReprojectionError(s.intrinsics, s.keyframes[lm.observations[0].keyframe], lm.point_in_submap, shifted), 1.0, 1e-3);
}

}  // namespace
}  // namespace glam
