// SubmapGraph against ground truth: synthetic submaps over a synthetic terrain, each a Sim3
// copy (arbitrary scale, orientation, origin) of the part of the world it saw.
#include "engine/alignment/submap_graph.h"

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <numbers>
#include <random>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "engine/core/error.h"
#include "engine/core/similarity_alignment.h"

namespace glam {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;
constexpr double kAltitude = 80.0;  // metres above the terrain: the submaps' viewing depth

double TerrainHeight(double x, double y) {
  return 6.0 * std::sin(x / 35.0) * std::cos(y / 28.0) + 2.0 * std::sin(x / 9.0 + y / 13.0);
}

Eigen::Vector3d TerrainPoint(double x, double y) { return {x, y, TerrainHeight(x, y)}; }

// A submap frame over `position` (metres): arbitrary orientation (monocular frames are the
// first camera's, up to a random rotation here), scale `scale` = world units per submap unit.
Sim3 SubmapFrame(const Eigen::Vector3d& position, double scale, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  return Sim3(scale, SO3::Exp(axis * std::abs(u(rng)) * 3.0), position);
}

double RandomScale(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(std::log(0.3), std::log(3.0));
  return std::exp(u(rng));
}

// A point of the world as submap `g` stores it, with isotropic noise of `noise` x depth.
Eigen::Vector3d Observe(const Sim3& world_from_submap, const Eigen::Vector3d& X, double noise,
                        std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, noise * kAltitude);
  const Eigen::Vector3d noisy = X + Eigen::Vector3d(n(rng), n(rng), n(rng));
  return world_from_submap.Inverse() * noisy;
}

double DepthScale(const Sim3& world_from_submap) { return kAltitude / world_from_submap.scale(); }

double RotationErrorDeg(const Sim3& a, const Sim3& b) {
  return (a.rotation() * b.rotation().Inverse()).Log().norm() / kDegree;
}

Sim3 Perturb(const Sim3& g, double angle, double log_scale, double translation,
             std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vector7d xi;
  xi << translation * u(rng), translation * u(rng), translation * u(rng), angle * u(rng),
      angle * u(rng), angle * u(rng), log_scale * u(rng);
  return Sim3::Exp(xi) * g;
}

// Five submaps along a strip; consecutive ones share ~100 landmarks, plus two longer edges.
struct Scenario {
  std::vector<Sim3> truth;
  struct Edge {
    std::uint32_t a, b;
    std::vector<LandmarkMatch> matches;
  };
  std::vector<Edge> edges;
};

Scenario StripScenario(double noise, double outlier_fraction, unsigned seed) {
  std::mt19937 rng(seed);
  Scenario s;
  const int n = 5;
  for (int i = 0; i < n; ++i) {
    s.truth.push_back(SubmapFrame(Eigen::Vector3d(60.0 * i + 50, 50, kAltitude), RandomScale(rng), rng));
  }
  // Submap i sees x in [60 i, 60 i + 100]: consecutive submaps overlap over 40 m, i and i+2
  // not at all; (0, 2) and (1, 3) are linked through a separate patch both "revisited".
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  auto make_edge = [&](std::uint32_t a, std::uint32_t b, double x0, double x1, int count) {
    Scenario::Edge e{a, b, {}};
    std::vector<Eigen::Vector3d> world;
    for (int k = 0; k < count; ++k) world.push_back(TerrainPoint(x0 + (x1 - x0) * u01(rng), 100 * u01(rng)));
    for (int k = 0; k < count; ++k) {
      LandmarkMatch m;
      m.landmark_a = 100000 * b + static_cast<std::uint32_t>(s.edges.size() * 1000 + k);
      m.landmark_b = 100000 * a + static_cast<std::uint32_t>(s.edges.size() * 1000 + k);
      m.point_in_a = Observe(s.truth[a], world[k], noise, rng);
      Eigen::Vector3d X_b = world[k];
      if (u01(rng) < outlier_fraction) {
        // Gross outlier: matched to another ground point 20-60 m away.
        const double angle = 2 * std::numbers::pi * u01(rng);
        const double distance = 20.0 + 40.0 * u01(rng);
        X_b = TerrainPoint(X_b.x() + distance * std::cos(angle), X_b.y() + distance * std::sin(angle));
      }
      m.point_in_b = Observe(s.truth[b], X_b, noise, rng);
      e.matches.push_back(m);
    }
    s.edges.push_back(std::move(e));
  };
  for (int i = 0; i + 1 < n; ++i) make_edge(i, i + 1, 60.0 * (i + 1), 60.0 * i + 100, 100);
  make_edge(0, 2, 100, 120, 40);
  make_edge(1, 3, 160, 180, 40);
  return s;
}

void AddScenario(const Scenario& s, const std::vector<Sim3>& initial, SubmapGraph* graph) {
  for (std::size_t i = 0; i < initial.size(); ++i) {
    graph->AddSubmap(static_cast<std::uint32_t>(i), initial[i], DepthScale(s.truth[i]));
  }
  for (const Scenario::Edge& e : s.edges) graph->AddEdge(e.a, e.b, e.matches);
}

// Submap i placed from the current estimate of its neighbour (the aligner's pattern), with
// the edges that arrive with it.
void AddNextSubmap(const Scenario& s, const std::vector<Sim3>& initial, std::uint32_t i, SubmapGraph* graph) {
  graph->AddSubmap(i, i == 0 ? initial[0] : graph->world_from_submap(i - 1) * initial[i - 1].Inverse() * initial[i],
                   DepthScale(s.truth[i]));
  for (const Scenario::Edge& e : s.edges) {
    if (std::max(e.a, e.b) == i) graph->AddEdge(e.a, e.b, e.matches);
  }
}

struct PoseErrors {
  double rotation_deg = 0;
  double scale = 0;        // relative
  double translation = 0;  // fraction of depth
};

// Worst error over submaps of graph estimates against truth mapped through `gauge`.
PoseErrors MaxErrors(const SubmapGraph& graph, const std::vector<Sim3>& truth, const Sim3& gauge = {}) {
  PoseErrors e;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const Sim3 expected = gauge * truth[i];
    const Sim3 got = graph.world_from_submap(static_cast<std::uint32_t>(i));
    e.rotation_deg = std::max(e.rotation_deg, RotationErrorDeg(got, expected));
    e.scale = std::max(e.scale, std::abs(got.scale() / expected.scale() - 1));
    e.translation = std::max(e.translation, (got.translation() - expected.translation()).norm() /
                                                (kAltitude * gauge.scale()));
  }
  return e;
}

std::vector<Sim3> PerturbedInitial(const std::vector<Sim3>& truth, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<Sim3> initial = {truth[0]};
  for (std::size_t i = 1; i < truth.size(); ++i) {
    initial.push_back(Perturb(truth[i], 5 * kDegree, 0.1, 10.0, rng));
  }
  return initial;
}

TEST(SubmapGraph, RecoversKnownConfigurationExactlyWithoutNoise) {
  // Scales 0.3 .. 3, start 5 deg / 10 % / 10 m off. Without the scale prior (which by design
  // pulls towards the scale each submap was inserted with) the optimum is the truth.
  const Scenario s = StripScenario(0.0, 0.0, 21);
  SubmapGraph graph(SubmapGraphOptions{.scale_prior_weight = 0});
  AddScenario(s, PerturbedInitial(s.truth, 22), &graph);
  ASSERT_GT(MaxErrors(graph, s.truth).rotation_deg, 1.0);
  const GraphSolveSummary summary = graph.Optimize();
  EXPECT_TRUE(summary.converged);
  const PoseErrors after = MaxErrors(graph, s.truth);
  EXPECT_LT(after.rotation_deg, 1e-6);
  EXPECT_LT(after.scale, 1e-8);
  EXPECT_LT(after.translation, 1e-8);
}

TEST(SubmapGraph, RecoversKnownConfigurationFromPerturbedStart) {
  // 1 % of depth noise per landmark and observation, default options.
  const Scenario s = StripScenario(0.01, 0.0, 21);
  SubmapGraph graph;
  AddScenario(s, PerturbedInitial(s.truth, 22), &graph);
  const GraphSolveSummary summary = graph.Optimize();
  EXPECT_TRUE(summary.usable);
  EXPECT_LT(summary.final_cost, 0.1 * summary.initial_cost);
  // The noise alone limits this chain to ~0.8 deg / 0.3 % / 2.5 % of depth at its far end
  // (the same graph started AT the truth ends there too): reached from 5 deg / 10 % off.
  SubmapGraph from_truth;
  AddScenario(s, s.truth, &from_truth);
  from_truth.Optimize();
  const PoseErrors optimum = MaxErrors(from_truth, s.truth);
  const PoseErrors after = MaxErrors(graph, s.truth);
  std::printf("1 %% noise: %.3f deg, scale %.4f, translation %.4f of depth (from truth: %.3f, %.4f, %.4f)\n",
              after.rotation_deg, after.scale, after.translation, optimum.rotation_deg,
              optimum.scale, optimum.translation);
  EXPECT_LT(after.rotation_deg, 1.2);
  EXPECT_LT(after.scale, 0.005);
  EXPECT_LT(after.translation, 0.035);
  EXPECT_LT(after.rotation_deg, optimum.rotation_deg + 0.05);
  EXPECT_LT(after.translation, optimum.translation + 0.002);

  // Landmark nodes land on the ground they came from.
  int near = 0;
  const std::vector<GraphLandmark> landmarks = graph.Landmarks();
  EXPECT_EQ(landmarks.size(), graph.num_landmarks());
  for (const GraphLandmark& l : landmarks) {
    const Eigen::Vector3d& p = l.position_in_world;
    if (std::abs(p.z() - TerrainHeight(p.x(), p.y())) < 0.03 * kAltitude) ++near;
  }
  EXPECT_GT(near, 0.95 * static_cast<double>(landmarks.size()));
}

TEST(SubmapGraph, IncrementalWarmStartReachesTheBatchOptimum) {
  // Submaps and edges arrive one at a time, each placed from the current estimate of its
  // neighbour and optimised after every step (the aligner's pattern), with the ceres::Problem
  // kept between steps. The end result is the optimum of a batch solve of the same data.
  const Scenario s = StripScenario(0.005, 0.0, 31);
  const std::vector<Sim3> initial = PerturbedInitial(s.truth, 32);
  SubmapGraph graph;
  for (std::uint32_t i = 0; i < s.truth.size(); ++i) {
    AddNextSubmap(s, initial, i, &graph);
    EXPECT_TRUE(graph.Optimize().usable);
  }
  EXPECT_EQ(graph.num_submaps(), 5u);
  EXPECT_EQ(graph.num_edges(), s.edges.size());

  SubmapGraph batch;
  AddScenario(s, initial, &batch);
  batch.Optimize();
  EXPECT_EQ(graph.num_landmarks(), batch.num_landmarks());
  EXPECT_EQ(graph.num_residuals(), batch.num_residuals());
  for (std::uint32_t i = 0; i < s.truth.size(); ++i) {
    const Sim3 a = graph.world_from_submap(i), b = batch.world_from_submap(i);
    // Equal up to the scale prior's anchors (insertion scales differ by < 1 %).
    EXPECT_LT(RotationErrorDeg(a, b), 0.01) << i;
    EXPECT_LT(std::abs(a.scale() / b.scale() - 1), 1e-3) << i;
    EXPECT_LT((a.translation() - b.translation()).norm(), 1e-3 * kAltitude) << i;
  }
  const PoseErrors after = MaxErrors(graph, s.truth);
  EXPECT_LT(after.rotation_deg, 1.0);
  EXPECT_LT(after.translation, 0.03);
}

TEST(SubmapGraph, SubsetSolveHoldsTheRestAndReleasesItAfterwards) {
  const Scenario s = StripScenario(0.005, 0.0, 41);
  const std::vector<Sim3> initial = PerturbedInitial(s.truth, 42);
  SubmapGraph graph;
  AddScenario(s, initial, &graph);
  const GraphSolveSummary local = graph.OptimizeSubset({3, 4});
  EXPECT_TRUE(local.usable);
  EXPECT_LT(local.final_cost, local.initial_cost);
  for (std::uint32_t i : {1u, 2u}) {
    EXPECT_EQ((graph.world_from_submap(i).matrix() - initial[i].matrix()).norm(), 0.0) << "held submap " << i;
  }
  for (std::uint32_t i : {3u, 4u}) {
    EXPECT_GT((graph.world_from_submap(i).matrix() - initial[i].matrix()).norm(), 1e-3) << "free submap " << i;
  }
  // Everything is free again for the next solve, which reaches the truth.
  EXPECT_TRUE(graph.Optimize().usable);
  EXPECT_GT((graph.world_from_submap(1).matrix() - initial[1].matrix()).norm(), 1e-3);
  const PoseErrors after = MaxErrors(graph, s.truth);
  EXPECT_LT(after.rotation_deg, 1.0);
  EXPECT_LT(after.translation, 0.03);
}

TEST(SubmapGraph, WindowedIncrementalSolvesOfAChainMatchTheBatchOptimum) {
  // The aligner's local window: each new submap of a chain (temporal edges only) is solved
  // with only the last two submaps free. On a chain the older submaps' optimum hardly moves,
  // so the result must match one batch solve of all of it.
  Scenario s = StripScenario(0.005, 0.0, 51);
  std::erase_if(s.edges, [](const Scenario::Edge& e) { return e.b != e.a + 1; });
  const std::vector<Sim3> initial = PerturbedInitial(s.truth, 52);
  SubmapGraph graph;
  for (std::uint32_t i = 0; i < s.truth.size(); ++i) {
    AddNextSubmap(s, initial, i, &graph);
    const std::set<std::uint32_t> window = i == 0 ? std::set<std::uint32_t>{0} : std::set<std::uint32_t>{i - 1, i};
    EXPECT_TRUE(graph.OptimizeSubset(window).usable);
  }
  SubmapGraph batch;
  AddScenario(s, initial, &batch);
  batch.Optimize();
  for (std::uint32_t i = 0; i < s.truth.size(); ++i) {
    const Sim3 a = graph.world_from_submap(i), b = batch.world_from_submap(i);
    EXPECT_LT(RotationErrorDeg(a, b), 0.02) << i;
    EXPECT_LT(std::abs(a.scale() / b.scale() - 1), 2e-3) << i;
    EXPECT_LT((a.translation() - b.translation()).norm(), 2e-3 * kAltitude) << i;
  }
}

TEST(SubmapGraph, HuberKeepsGrossOutliersFromPullingTheSolution) {
  // 20 % of every edge's correspondences are wrong by 20-60 m (25-75 % of the depth).
  const Scenario s = StripScenario(0.003, 0.2, 41);
  const std::vector<Sim3> initial = PerturbedInitial(s.truth, 42);
  SubmapGraph robust;
  AddScenario(s, initial, &robust);
  robust.Optimize();
  const PoseErrors e = MaxErrors(robust, s.truth);

  // The same data with Huber's threshold at the whole depth (least squares for these
  // outliers) is pulled visibly: the outliers are what the robust loss is removing.
  SubmapGraphOptions options;
  options.huber_delta = 1.0;
  SubmapGraph least_squares(options);
  AddScenario(s, initial, &least_squares);
  least_squares.Optimize();
  const PoseErrors l2 = MaxErrors(least_squares, s.truth);
  // Huber bounds every outlier's pull (to delta) but does not reject it, so with 20 % gross
  // outliers a bias of ~1 % scale per edge remains along this 4-edge chain; least squares is
  // dragged 10x further. (Gross outliers are RANSAC's job; Huber is the second line.)
  EXPECT_LT(e.rotation_deg, 0.5);
  EXPECT_LT(e.scale, 0.06);
  EXPECT_LT(e.translation, 0.1);
  EXPECT_GT(l2.rotation_deg, 8 * e.rotation_deg);
  EXPECT_GT(l2.scale, 8 * e.scale);
  EXPECT_GT(l2.translation, 8 * e.translation);
}

TEST(SubmapGraph, FirstSubmapIsTheGauge) {
  // The whole start is offset from the truth by a Sim3, the first submap exactly, the others
  // also perturbed: the first must not move, and the others must land on the truth mapped
  // through the same offset (7 DoF gauge).
  const Scenario s = StripScenario(0.003, 0.0, 51);
  std::vector<Sim3> initial = PerturbedInitial(s.truth, 52);
  const Sim3 offset(1.7, SO3::Exp(Eigen::Vector3d(0.1, -0.3, 0.6)), Eigen::Vector3d(40, -20, 5));
  for (Sim3& g : initial) g = offset * g;
  SubmapGraph graph;
  AddScenario(s, initial, &graph);
  graph.Optimize();
  const Sim3 first = graph.world_from_submap(0);
  EXPECT_EQ(first.scale(), initial[0].scale());
  EXPECT_EQ(first.translation(), initial[0].translation());
  EXPECT_LT(RotationErrorDeg(first, initial[0]), 1e-9);
  // The cost is invariant under a global Sim3 (residuals are in each submap's own depth
  // units, the prior acts on changes of log-scale), so the solution is the offset image of
  // the solution of the un-offset problem.
  SubmapGraph plain;
  std::vector<Sim3> plain_initial = PerturbedInitial(s.truth, 52);
  AddScenario(s, plain_initial, &plain);
  plain.Optimize();
  std::vector<Sim3> plain_solution;
  for (std::uint32_t i = 0; i < s.truth.size(); ++i) plain_solution.push_back(plain.world_from_submap(i));
  const PoseErrors equivariance = MaxErrors(graph, plain_solution, offset);
  // (Up to the solver's function tolerance; the noise-level errors are ~100x larger.)
  EXPECT_LT(equivariance.rotation_deg, 0.01);
  EXPECT_LT(equivariance.scale, 1e-4);
  EXPECT_LT(equivariance.translation, 1e-4);
  const PoseErrors e = MaxErrors(graph, s.truth, offset);
  EXPECT_LT(e.rotation_deg, 1.0);
  EXPECT_LT(e.translation, 0.03);
}

TEST(SubmapGraph, LandmarkMatchedByManyEdgesIsOneNode) {
  SubmapGraph graph;
  for (std::uint32_t i = 0; i < 4; ++i) graph.AddSubmap(i, Sim3(), 10.0);
  const Eigen::Vector3d p(1, 2, 3);
  auto match = [&](std::uint32_t la, std::uint32_t lb) { return LandmarkMatch{la, lb, p, p}; };
  // Landmark 7 of submap 0 = 8 of 1 = 9 of 2: three edges, one node, three observations.
  const std::vector<LandmarkMatch> e01 = {match(7, 8)}, e12 = {match(8, 9)}, e02 = {match(7, 9)};
  graph.AddEdge(0, 1, e01);
  graph.AddEdge(1, 2, e12);
  graph.AddEdge(0, 2, e02);
  EXPECT_EQ(graph.num_landmarks(), 1u);
  EXPECT_EQ(graph.num_residuals(), 3u);
  // The same edge again adds nothing.
  graph.AddEdge(0, 1, e01);
  EXPECT_EQ(graph.num_residuals(), 3u);

  // Two separate nodes (submaps 2-3 and 0-1) joined by a later match are merged.
  const std::vector<LandmarkMatch> e23 = {match(20, 30)}, e01b = {match(1, 11)};
  graph.AddEdge(2, 3, e23);
  graph.AddEdge(0, 1, e01b);
  EXPECT_EQ(graph.num_landmarks(), 3u);
  const std::vector<LandmarkMatch> e13 = {match(11, 30)};
  graph.AddEdge(1, 3, e13);
  EXPECT_EQ(graph.num_landmarks(), 2u);
  EXPECT_EQ(graph.num_residuals(), 7u);
  std::vector<std::size_t> sizes;
  for (const GraphLandmark& l : graph.Landmarks()) sizes.push_back(l.observations);
  std::sort(sizes.begin(), sizes.end());
  EXPECT_EQ(sizes, (std::vector<std::size_t>{3, 4}));
  EXPECT_EQ(graph.num_edges(), 7u);
  // The merged graph still solves (all observations agree: cost goes to zero).
  const GraphSolveSummary summary = graph.Optimize();
  EXPECT_TRUE(summary.usable);
  EXPECT_LT(summary.final_cost, 1e-12);
}

TEST(SubmapGraph, NewLandmarkStartsAtTheMeanOfItsObservations) {
  SubmapGraph graph;
  const Sim3 a(2.0, SO3(), Eigen::Vector3d(10, 0, 0));
  const Sim3 b(0.5, SO3::Exp(Eigen::Vector3d(0, 0, 0.5)), Eigen::Vector3d(0, 5, 0));
  graph.AddSubmap(0, a, 10.0);
  graph.AddSubmap(1, b, 10.0);
  const Eigen::Vector3d X1(3, 4, 5), X2(3, 4, 7);
  const std::vector<LandmarkMatch> m = {{1, 2, a.Inverse() * X1, b.Inverse() * X2}};
  graph.AddEdge(0, 1, m);
  const std::vector<GraphLandmark> l = graph.Landmarks();
  ASSERT_EQ(l.size(), 1u);
  EXPECT_LT((l[0].position_in_world - Eigen::Vector3d(3, 4, 6)).norm(), 1e-12);
}

TEST(SubmapGraph, CancelledSolveLeavesValuesUnchanged) {
  const Scenario s = StripScenario(0.003, 0.0, 61);
  const std::vector<Sim3> initial = PerturbedInitial(s.truth, 62);
  SubmapGraph graph;
  AddScenario(s, initial, &graph);
  std::vector<Sim3> before;
  for (std::uint32_t i = 0; i < initial.size(); ++i) before.push_back(graph.world_from_submap(i));
  CancellationToken cancel;
  cancel.Cancel();
  // The solver runs, the callback aborts it at iteration 0, Optimize reports the cancel.
  EXPECT_THROW(graph.Optimize(cancel), Cancelled);
  for (std::uint32_t i = 0; i < initial.size(); ++i) {
    EXPECT_EQ(graph.world_from_submap(i).translation(), before[i].translation());
    EXPECT_EQ(graph.world_from_submap(i).scale(), before[i].scale());
  }
  // A later, uncancelled solve still works from there: same answer as a graph that was
  // never cancelled.
  EXPECT_TRUE(graph.Optimize().usable);
  SubmapGraph reference;
  AddScenario(s, initial, &reference);
  reference.Optimize();
  for (std::uint32_t i = 0; i < initial.size(); ++i) {
    EXPECT_LT((graph.world_from_submap(i).translation() - reference.world_from_submap(i).translation()).norm(), 1e-6);
  }
}

// The acceptance scenario: a loop of submaps over terrain with drift injected where
// monocular drift lives, in the relative measurements between consecutive submaps. Each
// submap is exact where it hands over to the next (its end overlap) but its start overlap
// is seen through one step of drift E = (1 % scale, 0.5 deg about the vertical) about its
// own origin, so every temporal edge measures prev_from_next * E and the chain composes the
// drift. The loop edge (last <-> first) sees both submaps where they are exact: it measures
// the true relative placement, which disagrees with the chain by 15 steps of drift.
struct DriftLoop {
  std::vector<Sim3> truth;
  std::vector<Scenario::Edge> chain_edges;  // i -> i+1
  Scenario::Edge loop_edge;                 // last -> first
};

DriftLoop MakeDriftLoop(int submaps, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const double radius = 150.0;
  const double step = 2 * std::numbers::pi / submaps;
  DriftLoop d;
  for (int i = 0; i < submaps; ++i) {
    const Eigen::Vector3d position(radius * std::cos(i * step), radius * std::sin(i * step),
                                   kAltitude);
    d.truth.push_back(SubmapFrame(position, RandomScale(rng), rng));
  }
  const double noise = 0.002;  // of depth, per coordinate and observation
  auto make_edge = [&](int a, int b, bool drifted) {
    Scenario::Edge e{static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b), {}};
    // The two submaps' overlap: a sector around the midpoint of their centres.
    const double centre = (a + 0.5) * step;
    Sim3 drift;  // identity for the loop edge
    if (drifted) {
      const Eigen::Vector3d up_in_b = d.truth[b].rotation().Inverse() * Eigen::Vector3d::UnitZ();
      drift = Sim3(1.01, SO3::Exp(up_in_b * 0.5 * kDegree), Eigen::Vector3d::Zero());
    }
    for (int k = 0; k < 120; ++k) {
      const double angle = centre + (u01(rng) - 0.5) * 0.4 * step;
      const double r = radius + (u01(rng) - 0.5) * 80.0;
      const Eigen::Vector3d X = TerrainPoint(r * std::cos(angle), r * std::sin(angle));
      LandmarkMatch m;
      m.landmark_a = 1000 * b + k;  // ids of the overlap with b in a
      m.landmark_b = 1000 * a + k;
      m.point_in_a = Observe(d.truth[a], X, noise, rng);
      m.point_in_b = drift.Inverse() * Observe(d.truth[b], X, noise, rng);
      e.matches.push_back(m);
    }
    return e;
  };
  for (int i = 0; i + 1 < submaps; ++i) d.chain_edges.push_back(make_edge(i, i + 1, true));
  d.loop_edge = make_edge(submaps - 1, 0, false);
  return d;
}

// ATE of the submap positions (origins) after Sim3 alignment to the truth.
double PositionAte(const SubmapGraph& graph, const std::vector<Sim3>& truth) {
  std::vector<Eigen::Vector3d> estimated, expected;
  for (std::uint32_t i = 0; i < truth.size(); ++i) {
    estimated.push_back(graph.world_from_submap(i).translation());
    expected.push_back(truth[i].translation());
  }
  return AlignSimilarity(estimated, expected).rmse;
}

Sim3 MeasuredAFromB(const Scenario::Edge& e) {
  std::vector<Eigen::Vector3d> in_a, in_b;
  for (const LandmarkMatch& m : e.matches) {
    in_a.push_back(m.point_in_a);
    in_b.push_back(m.point_in_b);
  }
  return AlignSimilarity(in_b, in_a).target_from_source;
}

struct DriftResult {
  double chain_ate = 0;
  double loop_ate = 0;
};

DriftResult RunDriftLoop(const DriftLoop& d, const SubmapGraphOptions& options) {
  // As the aligner does it: each submap is placed by its temporal edge's Sim3 and the graph
  // re-optimised; then the loop edge arrives.
  SubmapGraph graph(options);
  graph.AddSubmap(0, d.truth[0], DepthScale(d.truth[0]));
  for (const Scenario::Edge& e : d.chain_edges) {
    graph.AddSubmap(e.b, graph.world_from_submap(e.a) * MeasuredAFromB(e), DepthScale(d.truth[e.b]));
    graph.AddEdge(e.a, e.b, e.matches);
    EXPECT_TRUE(graph.Optimize().usable);
  }
  DriftResult r;
  r.chain_ate = PositionAte(graph, d.truth);
  graph.AddEdge(d.loop_edge.a, d.loop_edge.b, d.loop_edge.matches);
  EXPECT_TRUE(graph.Optimize().usable);
  r.loop_ate = PositionAte(graph, d.truth);
  return r;
}

TEST(SubmapGraph, LoopEdgeCutsInjectedDriftAtLeastThreeTimes) {
  const DriftLoop d = MakeDriftLoop(16, 71);
  const DriftResult r = RunDriftLoop(d, SubmapGraphOptions{});
  const double path = 2 * std::numbers::pi * 150.0;
  std::printf("drift loop: ATE chain %.3f m (%.2f %% of path), with loop edge %.3f m (%.3f %%), %.1fx\n",
              r.chain_ate, 100 * r.chain_ate / path, r.loop_ate, 100 * r.loop_ate / path,
              r.chain_ate / r.loop_ate);
  // The drift is really there: the chain alone is off by more than 0.5 % of the path.
  EXPECT_GT(r.chain_ate, 0.005 * path);
  EXPECT_GT(r.chain_ate, 3 * r.loop_ate);
}

TEST(SubmapGraphOptions, CheckRejectsNonsense) {
  EXPECT_NO_THROW(SubmapGraphOptions{}.Check());
  auto rejects = [](auto mutate) {
    SubmapGraphOptions o;
    mutate(o);
    EXPECT_THROW(o.Check(), InputError);
  };
  rejects([](SubmapGraphOptions& o) { o.huber_delta = 0; });
  rejects([](SubmapGraphOptions& o) { o.huber_delta = -0.01; });
  rejects([](SubmapGraphOptions& o) { o.scale_prior_weight = -1; });
  rejects([](SubmapGraphOptions& o) { o.max_iterations = 0; });
  rejects([](SubmapGraphOptions& o) { o.function_tolerance = 0; });
  rejects([](SubmapGraphOptions& o) { o.num_threads = 0; });
  EXPECT_THROW(SubmapGraph(SubmapGraphOptions{.huber_delta = -1}), InputError);
  for (GraphLinearSolver solver :
       {GraphLinearSolver::kIterativeSchur, GraphLinearSolver::kCgnr,
        GraphLinearSolver::kSparseSchur, GraphLinearSolver::kSparseNormalCholesky}) {
    EXPECT_EQ(ParseGraphLinearSolver(ToString(solver)), solver);
  }
  EXPECT_THROW(ParseGraphLinearSolver("dense_qr"), InputError);
}

}  // namespace
}  // namespace glam
