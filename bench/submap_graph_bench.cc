// How the submap factor graph scales (issue 5, "Speed and scale"): time to add one submap
// (with its temporal edge and, after the first lap, a loop edge) and re-optimise, warm
// started, when the graph already holds N - 1 submaps, for each sparse linear solver Ceres
// offers for this structure. Synthetic chain: the drone circles the same ground, 25 submaps
// per lap, ~300 matched landmarks per edge, 0.3 % noise and a small drift (0.2 % scale,
// 0.1 deg per submap) in the temporal edges so that the loop edges have work to do.
//
// Every (solver, N) runs in a forked child so its peak RSS is its own. Prints a Markdown
// table (docs/benchmarks.md).
// Usage: glam_bench_submap_graph [max_submaps=200 [solver ...]]   (default: all four solvers)
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <random>
#include <set>
#include <vector>

#include "engine/alignment/submap_graph.h"
#include "engine/core/similarity_alignment.h"

namespace glam {
namespace {

constexpr int kPerLap = 25;
constexpr int kMatchesPerEdge = 300;
constexpr double kAltitude = 80.0;
constexpr double kSpacing = 60.0;  // metres between consecutive submaps

struct Edge {
  std::uint32_t a = 0, b = 0;
  std::vector<LandmarkMatch> matches;
};

struct Chain {
  std::vector<Sim3> truth;
  std::vector<Sim3> initial;  // chained from the measured temporal edges
  std::vector<std::vector<Edge>> edges_of;  // edges arriving with submap i
};

Eigen::Vector3d Ground(double x, double y) {
  return {x, y, 6.0 * std::sin(x / 35.0) * std::cos(y / 28.0) + 2.0 * std::sin(x / 9.0 + y / 13.0)};
}

Sim3 MeasuredAFromB(const Edge& e) {
  std::vector<Eigen::Vector3d> in_a, in_b;
  for (const LandmarkMatch& m : e.matches) {
    in_a.push_back(m.point_in_a);
    in_b.push_back(m.point_in_b);
  }
  return AlignSimilarity(in_b, in_a).target_from_source;
}

Chain MakeChain(int n) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.003 * kAltitude);
  const double radius = kPerLap * kSpacing / (2 * std::numbers::pi);
  const double step = 2 * std::numbers::pi / kPerLap;
  Chain c;
  for (int i = 0; i < n; ++i) {
    const double angle = step * i;
    const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    c.truth.emplace_back(std::exp(std::log(3.0) * u(rng)), SO3::Exp(axis * 3.0 * std::abs(u(rng))),
                         Eigen::Vector3d(radius * std::cos(angle), radius * std::sin(angle), kAltitude));
  }
  auto observe = [&](const Sim3& g, const Eigen::Vector3d& X) {
    return g.Inverse() * (X + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
  };
  auto make_edge = [&](int a, int b, double centre_angle, bool drifted) {
    Edge e{static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(b), {}};
    Sim3 drift;
    if (drifted) {
      const Eigen::Vector3d up = c.truth[b].rotation().Inverse() * Eigen::Vector3d::UnitZ();
      drift = Sim3(1.002, SO3::Exp(up * 0.1 * std::numbers::pi / 180), Eigen::Vector3d::Zero());
    }
    for (int k = 0; k < kMatchesPerEdge; ++k) {
      const double angle = centre_angle + 0.2 * step * u(rng);
      const double r = radius + 40.0 * u(rng);
      const Eigen::Vector3d X = Ground(r * std::cos(angle), r * std::sin(angle));
      LandmarkMatch m;
      m.landmark_a = static_cast<std::uint32_t>(b * 2 * kMatchesPerEdge + (drifted ? 0 : kMatchesPerEdge) + k);
      m.landmark_b = static_cast<std::uint32_t>(a * 2 * kMatchesPerEdge + (drifted ? 0 : kMatchesPerEdge) + k);
      m.point_in_a = observe(c.truth[a], X);
      m.point_in_b = drift.Inverse() * observe(c.truth[b], X);
      e.matches.push_back(m);
    }
    return e;
  };
  c.edges_of.resize(n);
  c.initial.push_back(c.truth[0]);
  for (int i = 1; i < n; ++i) {
    c.edges_of[i].push_back(make_edge(i - 1, i, step * (i - 0.5), true));
    c.initial.push_back(c.initial[i - 1] * MeasuredAFromB(c.edges_of[i].front()));
    if (i >= kPerLap) c.edges_of[i].push_back(make_edge(i - kPerLap, i, step * i, false));
  }
  return c;
}

double DepthUnits(const Sim3& world_from_submap) { return kAltitude / world_from_submap.scale(); }

void AddSubmapAndEdges(const Chain& c, int i, SubmapGraph* graph, bool temporal_only = false) {
  // Placed like the aligner does: from the current estimate of the temporal neighbour.
  const Sim3 initial = i == 0 ? c.initial[0]
                              : graph->world_from_submap(i - 1) * c.initial[i - 1].Inverse() *
                                    c.initial[i];
  graph->AddSubmap(static_cast<std::uint32_t>(i), initial, DepthUnits(c.truth[i]));
  for (const Edge& e : c.edges_of[i]) {
    if (temporal_only && e.b != e.a + 1) continue;
    graph->AddEdge(e.a, e.b, e.matches);
  }
}

// How the N-th submap is added: as the chain has it (temporal + loop edge), or with only its
// temporal edge, solved over the whole graph or over the aligner's local window
// (AlignerOptions::local_window, SubmapGraph::OptimizeSubset).
enum class Mode { kChain, kTemporalWhole, kTemporalWindow };
constexpr int kWindow = 8;

struct Result {
  double seconds = 0;        // add + optimise of the N-th submap, wall clock
  double cpu_seconds = 0;    // the same, CPU time of this process (robust to a loaded machine)
  double warm_seconds = 0;   // building and optimising the first N - 1 (not timed per se)
  int iterations = 0;
  bool usable = false;
  long landmarks = 0;
  long residuals = 0;
  long peak_rss_kb = 0;
  long baseline_rss_kb = 0;
};

double CpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

long PeakRssKb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss;
}

Result Run(const Chain& chain, GraphLinearSolver solver, int n, Mode mode) {
  using Clock = std::chrono::steady_clock;
  Result r;
  r.baseline_rss_kb = PeakRssKb();
  SubmapGraphOptions options;
  options.linear_solver = solver;
  SubmapGraph graph(options);
  const auto warm_start = Clock::now();
  for (int i = 0; i + 1 < n; ++i) AddSubmapAndEdges(chain, i, &graph);
  graph.Optimize();
  r.warm_seconds = std::chrono::duration<double>(Clock::now() - warm_start).count();

  const auto start = Clock::now();
  const double cpu_start = CpuSeconds();
  AddSubmapAndEdges(chain, n - 1, &graph, mode != Mode::kChain);
  std::set<std::uint32_t> window;
  for (int i = std::max(0, n - kWindow); i < n; ++i) window.insert(static_cast<std::uint32_t>(i));
  const GraphSolveSummary summary = mode == Mode::kTemporalWindow ? graph.OptimizeSubset(window) : graph.Optimize();
  r.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  r.cpu_seconds = CpuSeconds() - cpu_start;
  r.iterations = summary.iterations;
  r.usable = summary.usable;
  r.landmarks = static_cast<long>(graph.num_landmarks());
  r.residuals = static_cast<long>(graph.num_residuals());
  r.peak_rss_kb = PeakRssKb();
  return r;
}

// Runs `Run` in a child process so that every row's peak RSS is its own.
bool RunIsolated(const Chain& chain, GraphLinearSolver solver, int n, Mode mode, Result* out) {
  int fds[2];
  if (pipe(fds) != 0) return false;
  std::fflush(stdout);
  const pid_t pid = fork();
  if (pid < 0) return false;
  if (pid == 0) {
    close(fds[0]);
    const Result r = Run(chain, solver, n, mode);
    const ssize_t written = write(fds[1], &r, sizeof(r));
    _exit(written == static_cast<ssize_t>(sizeof(r)) ? 0 : 1);
  }
  close(fds[1]);
  const ssize_t got = read(fds[0], out, sizeof(*out));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  return got == static_cast<ssize_t>(sizeof(*out)) && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

}  // namespace
}  // namespace glam

int main(int argc, char** argv) {
  using namespace glam;
  const int max_submaps = argc > 1 ? std::atoi(argv[1]) : 200;
  if (max_submaps < 2) {
    std::fprintf(stderr, "usage: %s [max_submaps >= 2]\n", argv[0]);
    return 2;
  }
  const Chain chain = MakeChain(max_submaps);
  std::vector<int> sizes;
  for (int n : {10, 50, 100, 200}) {
    if (n <= max_submaps) sizes.push_back(n);
  }
  std::printf("submap graph: %d submaps per lap, %d matches per edge, loop edges from submap %d on\n\n",
              kPerLap, kMatchesPerEdge, kPerLap);
  std::printf("| solver | N | landmarks | point factors | iterations | add + optimise, CPU (s) | wall (s) | build + optimise N-1, wall (s) | peak RSS (MB) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  std::vector<GraphLinearSolver> solvers;
  for (int i = 2; i < argc; ++i) solvers.push_back(ParseGraphLinearSolver(argv[i]));
  if (solvers.empty()) {
    solvers = {GraphLinearSolver::kIterativeSchur, GraphLinearSolver::kCgnr,
               GraphLinearSolver::kSparseSchur, GraphLinearSolver::kSparseNormalCholesky};
  }
  for (GraphLinearSolver solver : solvers) {
    for (int n : sizes) {
      Result r;
      if (!RunIsolated(chain, solver, n, Mode::kChain, &r)) {
        std::printf("| %s | %d | failed | | | | | | |\n", std::string(ToString(solver)).c_str(), n);
        continue;
      }
      std::printf("| %s | %d | %ld | %ld | %d%s | %.3f | %.3f | %.2f | %.1f |\n",
                  std::string(ToString(solver)).c_str(), n, r.landmarks, r.residuals,
                  r.iterations, r.usable ? "" : " (not usable)", r.cpu_seconds, r.seconds,
                  r.warm_seconds,
                  static_cast<double>(r.peak_rss_kb) / 1024.0);
      std::fflush(stdout);
    }
  }
  // The aligner's usual case on a long flight: the new submap links only to its temporal
  // neighbour. Whole-graph solve against the local window (default solver).
  std::printf("\nN-th submap with only its temporal edge (sparse_schur): whole graph vs local window of %d\n\n", kWindow);
  std::printf("| solve | N | iterations | add + optimise, CPU (s) | wall (s) |\n|---|---|---|---|---|\n");
  for (int n : sizes) {
    for (Mode mode : {Mode::kTemporalWhole, Mode::kTemporalWindow}) {
      Result r;
      const char* name = mode == Mode::kTemporalWhole ? "whole graph" : "local window";
      if (!RunIsolated(chain, GraphLinearSolver::kSparseSchur, n, mode, &r)) {
        std::printf("| %s | %d | failed | | |\n", name, n);
        continue;
      }
      std::printf("| %s | %d | %d%s | %.3f | %.3f |\n", name, n, r.iterations, r.usable ? "" : " (not usable)",
                  r.cpu_seconds, r.seconds);
      std::fflush(stdout);
    }
  }
  return 0;
}
