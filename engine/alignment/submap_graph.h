// The submap factor graph of the paper ("Global Submap Alignment", "Submap pose-graph"):
//   * one Sim3 node per submap (world_from_submap), on the Sim3 manifold (left updates);
//   * one R^3 node per landmark matched in at least two submaps. A node is keyed by every
//     (submap id, landmark id) that observes it, so a landmark matched by several edges is ONE
//     node; when a match joins two existing nodes they are merged (union by size);
//   * per observation the factor (s_i R_i x_ij + t_i - X_j) / d_i with Huber loss;
//   * per submap the scale prior ||lambda (sigma_i - sigma_i0)||^2.
//
// Deviations from the paper, and why:
//   * Each residual is divided by the submap's CURRENT depth scale in world units,
//     s_i * d_i (d_i = median landmark depth in the submap's own units): r = (y - X) / (s_i d_i).
//     Monocular submaps have arbitrary units; normalised, submaps of any scale weigh the same
//     and huber_delta is a fraction of the viewing depth. The normalisation follows the
//     current scale rather than the scale at insertion because a fixed world-unit divisor
//     makes shrinking attractive: every outlier's robust cost is proportional to world
//     distances, so scaling all non-gauge submaps down lowers it while only the edges touching
//     the fixed submap object. Measured on the 5-submap test strip with 20 % gross outliers,
//     started AT the truth: fixed divisor -> the chain collapsed by 21 % in scale; current
//     scale -> 3.5 %. With it the whole cost is invariant under a global Sim3 (the gauge test
//     checks this), which is exactly what the paper's prior was added to make up for.
//   * The scale prior acts on the change of log-scale since insertion, not on sigma itself:
//     submaps come in at arbitrary scales (first submap's units = world units), and a prior
//     towards s = 1 would drag every submap towards the first one's units. The gauge (first
//     submap fixed, all 7 DoF) already rules out the collapse to zero scale; here the prior
//     only keeps weakly linked submaps from wandering in scale.
//
// The ceres::Problem lives as long as the graph: AddSubmap/AddEdge add blocks incrementally
// and Optimize warm-starts from the current values (the aligner re-optimises after every new
// verified edge). Not thread-safe; owned by thread 2.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <span>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "engine/alignment/landmark_match.h"
#include "engine/core/cancellation.h"
#include "engine/core/sim3.h"

namespace ceres {
class Problem;
class LossFunction;
}  // namespace ceres

namespace glam {

class Sim3Manifold;

// Sparse linear solvers for the Levenberg-Marquardt steps. The paper used preconditioned
// conjugate gradients (g2o); the benchmark (bench/submap_graph_bench.cc, docs/benchmarks.md)
// compares them on growing synthetic graphs.
enum class GraphLinearSolver {
  kIterativeSchur,        // ITERATIVE_SCHUR + SCHUR_JACOBI (PCG on the reduced camera system)
  kCgnr,                  // CGNR + JACOBI (PCG on the normal equations)
  kSparseSchur,           // SPARSE_SCHUR (SuiteSparse Cholesky of the Schur complement)
  kSparseNormalCholesky,  // SPARSE_NORMAL_CHOLESKY (SuiteSparse Cholesky of J^T J)
};
std::string_view ToString(GraphLinearSolver solver);
// Accepts the names ToString produces ("iterative_schur", ...); throws InputError otherwise.
GraphLinearSolver ParseGraphLinearSolver(std::string_view name);

struct SubmapGraphOptions {
  // Huber threshold on the normalised residual, i.e. as a fraction of the submap's viewing
  // depth. Verified inliers sit within 2 % of depth (VerificationOptions'
  // inlier_threshold_fraction) and good submaps agree to a few tenths of a percent; 1 % keeps
  // those quadratic while correspondences near the RANSAC threshold already count linearly.
  // Measured (tests/alignment/submap_graph_test.cc): the drift loop is equally good at 0.005,
  // 0.01 and 0.02 (loop ATE 0.71 / 0.68 / 0.68 m); with 20 % gross outliers the remaining
  // scale bias grows with delta (1.8 / 3.5 / 7.7 %), with 1 % noise it shrinks slightly.
  double huber_delta = 0.01;
  // lambda of the scale prior ||lambda (sigma_i - sigma_i0)||^2. Its only job is to keep a
  // weakly linked submap's scale from wandering; it also resists the scale corrections a
  // loop closure must make. Drift test (16 submaps, 1 % scale + 0.5 deg drift per submap,
  // chain ATE 7.75 m): loop ATE 0.65 m at lambda 0, 0.68 m at 0.1, 1.05 m at 0.3, 2.7 m at 1
  // (no longer the 3x). 0.1 keeps 95 % of the correction.
  double scale_prior_weight = 0.1;
  // Fastest in bench/submap_graph_bench.cc (add + optimise one submap at N = 200 submaps,
  // 112k landmarks, CPU time): SPARSE_SCHUR 1.4 s, SPARSE_NORMAL_CHOLESKY 2.8 s (and 1.8x the
  // memory), ITERATIVE_SCHUR 5.5 s, CGNR did not converge in 50 iterations (159 s).
  GraphLinearSolver linear_solver = GraphLinearSolver::kSparseSchur;
  int max_iterations = 50;
  double function_tolerance = 1e-6;
  // Thread 1 (submap creation) runs on the other core.
  int num_threads = 1;

  void Check() const;  // throws InputError
};

struct GraphSolveSummary {
  int iterations = 0;
  double initial_cost = 0;
  double final_cost = 0;
  double seconds = 0;
  bool converged = false;  // Ceres reported CONVERGENCE
  bool usable = false;     // converged, or stopped at max_iterations with a finite cost
  GraphLinearSolver solver = GraphLinearSolver::kSparseSchur;
};

struct GraphLandmark {
  std::uint32_t submap = 0;    // the first observation's (submap, landmark) key
  std::uint32_t landmark = 0;
  std::size_t observations = 0;
  Eigen::Vector3d position_in_world{0, 0, 0};
};

class SubmapGraph {
 public:
  explicit SubmapGraph(const SubmapGraphOptions& options = {});
  ~SubmapGraph();
  SubmapGraph(const SubmapGraph&) = delete;
  SubmapGraph& operator=(const SubmapGraph&) = delete;

  // The first submap added is the gauge: it stays fixed. depth_scale: median landmark depth
  // in the submap's own units (> 0). Aborts (GLAM_CHECK) if the id was already added.
  void AddSubmap(std::uint32_t id, const Sim3& world_from_submap_initial,
                 double depth_scale_in_submap_units);
  // Inlier correspondences between two added submaps (a != b). New landmark nodes start at
  // the mean of their observations mapped with the current submap estimates. Repeated
  // observations (same submap and landmark) are counted once.
  void AddEdge(std::uint32_t submap_a, std::uint32_t submap_b,
               std::span<const LandmarkMatch> inliers);

  // Levenberg-Marquardt from the current values. Throws glam::Cancelled if `cancel` fires
  // (the solver is aborted through an IterationCallback and the values stay as before).
  GraphSolveSummary Optimize(CancellationToken cancel = {});
  // The same, with only the submaps in `free` (and the landmark nodes they observe) varying;
  // every other submap and landmark node is held for this solve. The aligner uses it when a
  // new submap only links to its recent neighbours: the rest of the graph's optimum hardly
  // moves then, and the cost of a solve stops growing with the flight (docs/algorithm.md).
  GraphSolveSummary OptimizeSubset(const std::set<std::uint32_t>& free, CancellationToken cancel = {});

  Sim3 world_from_submap(std::uint32_t id) const;  // aborts on an unknown id
  bool HasSubmap(std::uint32_t id) const;
  std::vector<std::uint32_t> submap_ids() const;  // ascending
  std::vector<GraphLandmark> Landmarks() const;
  // Every landmark node's members, (submap id, landmark id) each: the ground points matched
  // across submaps (global_refinement.h joins their tracks).
  std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> LandmarkMembers() const;

  std::size_t num_submaps() const { return submaps_.size(); }
  std::size_t num_landmarks() const { return num_landmarks_; }
  std::size_t num_residuals() const { return num_observations_; }  // point factors
  std::size_t num_edges() const { return num_edges_; }
  const SubmapGraphOptions& options() const { return options_; }

 private:
  struct SubmapNode;
  struct LandmarkNode;
  struct Observation;

  std::size_t NewLandmark(const Observation& a, const Observation& b);
  void AddObservation(std::size_t landmark, const Observation& observation);
  std::size_t Merge(std::size_t a, std::size_t b);
  void AddFactor(LandmarkNode& node, const Observation& observation);
  Eigen::Vector3d ObservedInWorld(const Observation& observation) const;
  // Solves `problem` (the persistent one, or a subset's) with landmarks eliminated first.
  GraphSolveSummary Solve(ceres::Problem& problem, const std::vector<double*>& landmark_blocks,
                          const std::vector<double*>& submap_blocks, const CancellationToken& cancel);

  SubmapGraphOptions options_;
  std::unique_ptr<Sim3Manifold> manifold_;
  std::unique_ptr<ceres::LossFunction> loss_;
  std::unique_ptr<ceres::Problem> problem_;
  std::map<std::uint32_t, std::unique_ptr<SubmapNode>> submaps_;
  std::vector<std::unique_ptr<LandmarkNode>> landmarks_;  // null after a merge
  std::unordered_map<std::uint64_t, std::size_t> landmark_of_;  // (submap, landmark) -> node
  std::size_t num_landmarks_ = 0;
  std::size_t num_observations_ = 0;
  std::size_t num_edges_ = 0;
  std::uint32_t gauge_ = 0;  // the first submap added; always held
};

}  // namespace glam
