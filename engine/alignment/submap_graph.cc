#include "engine/alignment/submap_graph.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <utility>

#include <ceres/ceres.h>
#include <fmt/format.h>

#include "engine/alignment/sim3_manifold.h"
#include "engine/alignment/submap_graph_factors.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/core/options.h"

namespace glam {
namespace {

std::uint64_t Key(std::uint32_t submap, std::uint32_t landmark) {
  return (static_cast<std::uint64_t>(submap) << 32) | landmark;
}

class CancelCallback : public ceres::IterationCallback {
 public:
  explicit CancelCallback(CancellationToken cancel) : cancel_(std::move(cancel)) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return cancel_.IsCancelled() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  CancellationToken cancel_;
};

void SetLinearSolver(GraphLinearSolver solver, ceres::Solver::Options* options) {
  switch (solver) {
    case GraphLinearSolver::kIterativeSchur:
      options->linear_solver_type = ceres::ITERATIVE_SCHUR;
      options->preconditioner_type = ceres::SCHUR_JACOBI;
      return;
    case GraphLinearSolver::kCgnr:
      options->linear_solver_type = ceres::CGNR;
      options->preconditioner_type = ceres::JACOBI;
      return;
    case GraphLinearSolver::kSparseSchur:
      options->linear_solver_type = ceres::SPARSE_SCHUR;
      return;
    case GraphLinearSolver::kSparseNormalCholesky:
      options->linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
      return;
  }
}

}  // namespace

std::string_view ToString(GraphLinearSolver solver) {
  switch (solver) {
    case GraphLinearSolver::kIterativeSchur: return "iterative_schur";
    case GraphLinearSolver::kCgnr: return "cgnr";
    case GraphLinearSolver::kSparseSchur: return "sparse_schur";
    case GraphLinearSolver::kSparseNormalCholesky: return "sparse_normal_cholesky";
  }
  return "unknown";
}

GraphLinearSolver ParseGraphLinearSolver(std::string_view name) {
  for (GraphLinearSolver s :
       {GraphLinearSolver::kIterativeSchur, GraphLinearSolver::kCgnr,
        GraphLinearSolver::kSparseSchur, GraphLinearSolver::kSparseNormalCholesky}) {
    if (name == ToString(s)) return s;
  }
  throw InputError(fmt::format(
      "unknown graph linear solver '{}' (iterative_schur, cgnr, sparse_schur, "
      "sparse_normal_cholesky)",
      name));
}

void SubmapGraphOptions::Check() const {
  CheckInRange("SubmapGraphOptions.huber_delta", huber_delta, 1e-6, 1.0);
  CheckInRange("SubmapGraphOptions.scale_prior_weight", scale_prior_weight, 0.0, 1e6);
  CheckGreaterEqual("SubmapGraphOptions.max_iterations", max_iterations, 1);
  CheckInRange("SubmapGraphOptions.function_tolerance", function_tolerance, 1e-16, 0.1);
  CheckInRange("SubmapGraphOptions.num_threads", num_threads, 1, 256);
  const auto s = static_cast<int>(linear_solver);
  CheckInRange("SubmapGraphOptions.linear_solver", s, 0, 3);
}

struct SubmapGraph::SubmapNode {
  Sim3Parameters parameters{};
  double depth_in_submap_units = 1;
  double log_scale_at_insertion = 0;  // centre of its scale prior
};

struct SubmapGraph::Observation {
  std::uint32_t submap = 0;
  std::uint32_t landmark = 0;
  Eigen::Vector3d point_in_submap{0, 0, 0};
};

struct SubmapGraph::LandmarkNode {
  std::array<double, 3> position{};
  std::vector<Observation> observations;
};

SubmapGraph::SubmapGraph(const SubmapGraphOptions& options)
    : options_(options), manifold_(std::make_unique<Sim3Manifold>()) {
  options_.Check();
  loss_ = std::make_unique<ceres::HuberLoss>(options_.huber_delta);
  ceres::Problem::Options problem_options;
  // One manifold and one loss object serve every block; the graph owns them.
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  // Merging landmark nodes removes blocks.
  problem_options.enable_fast_removal = true;
  problem_ = std::make_unique<ceres::Problem>(problem_options);
}

SubmapGraph::~SubmapGraph() = default;

void SubmapGraph::AddSubmap(std::uint32_t id, const Sim3& world_from_submap_initial,
                            double depth_scale_in_submap_units) {
  GLAM_CHECK(!submaps_.contains(id), "submap {} added to the graph twice", id);
  GLAM_CHECK(std::isfinite(depth_scale_in_submap_units) && depth_scale_in_submap_units > 0,
             "submap {}: depth scale must be > 0, got {}", id, depth_scale_in_submap_units);
  auto node = std::make_unique<SubmapNode>();
  node->parameters = Sim3ToParameters(world_from_submap_initial);
  node->depth_in_submap_units = depth_scale_in_submap_units;
  node->log_scale_at_insertion = node->parameters[6];
  double* block = node->parameters.data();
  problem_->AddParameterBlock(block, kSim3AmbientSize, manifold_.get());
  if (submaps_.empty()) {
    gauge_ = id;
    problem_->SetParameterBlockConstant(block);  // gauge
  } else if (options_.scale_prior_weight > 0) {
    problem_->AddResidualBlock(
        new LogScalePriorFactor(node->log_scale_at_insertion, options_.scale_prior_weight), nullptr,
        block);
  }
  submaps_.emplace(id, std::move(node));
}

Eigen::Vector3d SubmapGraph::ObservedInWorld(const Observation& observation) const {
  return Sim3FromParameters(submaps_.at(observation.submap)->parameters.data()) *
         observation.point_in_submap;
}

void SubmapGraph::AddFactor(LandmarkNode& node, const Observation& observation) {
  SubmapNode& submap = *submaps_.at(observation.submap);
  problem_->AddResidualBlock(
      new SubmapPointFactor(observation.point_in_submap, submap.depth_in_submap_units), loss_.get(),
      submap.parameters.data(), node.position.data());
  ++num_observations_;
}

std::size_t SubmapGraph::NewLandmark(const Observation& a, const Observation& b) {
  auto node = std::make_unique<LandmarkNode>();
  Eigen::Map<Eigen::Vector3d> position(node->position.data());
  position = 0.5 * (ObservedInWorld(a) + ObservedInWorld(b));
  const std::size_t index = landmarks_.size();
  for (const Observation& o : {a, b}) {
    node->observations.push_back(o);
    AddFactor(*node, node->observations.back());
    landmark_of_[Key(o.submap, o.landmark)] = index;
  }
  landmarks_.push_back(std::move(node));
  ++num_landmarks_;
  return index;
}

void SubmapGraph::AddObservation(std::size_t landmark, const Observation& observation) {
  LandmarkNode& node = *landmarks_[landmark];
  // Running mean of the observations, so the node starts where all of them point.
  const double n = static_cast<double>(node.observations.size());
  Eigen::Map<Eigen::Vector3d> position(node.position.data());
  position = (n * position + ObservedInWorld(observation)) / (n + 1);
  node.observations.push_back(observation);
  AddFactor(node, node.observations.back());
  landmark_of_[Key(observation.submap, observation.landmark)] = landmark;
}

std::size_t SubmapGraph::Merge(std::size_t a, std::size_t b) {
  if (landmarks_[a]->observations.size() < landmarks_[b]->observations.size()) std::swap(a, b);
  LandmarkNode& keep = *landmarks_[a];
  std::unique_ptr<LandmarkNode> gone = std::move(landmarks_[b]);
  // Removing the block removes its factors too; they are re-created on the kept node.
  problem_->RemoveParameterBlock(gone->position.data());
  num_observations_ -= gone->observations.size();
  const double n_keep = static_cast<double>(keep.observations.size());
  const double n_gone = static_cast<double>(gone->observations.size());
  Eigen::Map<Eigen::Vector3d> position(keep.position.data());
  position = (n_keep * position + n_gone * Eigen::Map<Eigen::Vector3d>(gone->position.data())) /
             (n_keep + n_gone);
  for (Observation o : gone->observations) {
    keep.observations.push_back(o);
    AddFactor(keep, keep.observations.back());
    landmark_of_[Key(o.submap, o.landmark)] = a;
  }
  --num_landmarks_;
  return a;
}

void SubmapGraph::AddEdge(std::uint32_t submap_a, std::uint32_t submap_b,
                          std::span<const LandmarkMatch> inliers) {
  GLAM_CHECK(submap_a != submap_b, "graph edge from submap {} to itself", submap_a);
  GLAM_CHECK(submaps_.contains(submap_a) && submaps_.contains(submap_b),
             "graph edge {} - {} between submaps not in the graph", submap_a, submap_b);
  for (const LandmarkMatch& m : inliers) {
    const Observation a{submap_a, m.landmark_a, m.point_in_a};
    const Observation b{submap_b, m.landmark_b, m.point_in_b};
    const auto found_a = landmark_of_.find(Key(submap_a, m.landmark_a));
    const auto found_b = landmark_of_.find(Key(submap_b, m.landmark_b));
    const bool has_a = found_a != landmark_of_.end();
    const bool has_b = found_b != landmark_of_.end();
    if (!has_a && !has_b) {
      NewLandmark(a, b);
    } else if (has_a && !has_b) {
      AddObservation(found_a->second, b);
    } else if (!has_a && has_b) {
      AddObservation(found_b->second, a);
    } else if (found_a->second != found_b->second) {
      Merge(found_a->second, found_b->second);
    }
  }
  ++num_edges_;
}

GraphSolveSummary SubmapGraph::Optimize(CancellationToken cancel) {
  std::vector<double*> landmark_blocks, submap_blocks;
  for (const auto& node : landmarks_) {
    if (node) landmark_blocks.push_back(node->position.data());
  }
  for (const auto& [id, node] : submaps_) submap_blocks.push_back(node->parameters.data());
  return Solve(*problem_, landmark_blocks, submap_blocks, cancel);
}

GraphSolveSummary SubmapGraph::OptimizeSubset(const std::set<std::uint32_t>& free,
                                              CancellationToken cancel) {
  // A problem of its own with only the factors of the landmark nodes a free submap observes
  // (their other observers held), and the free submaps' scale priors: the same problem as
  // the whole graph with everything else held, without its size. Holding blocks in the
  // persistent problem instead (Ceres leaves all-constant residuals out of the reduced
  // problem) still cost every solve a pass over all residual blocks: on a 20,000-frame flight
  // the optimisation of a local window grew from 0.02 to 0.59 s per submap with the graph
  // (docs/benchmarks.md).
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem local(problem_options);
  std::vector<double*> landmark_blocks, submap_blocks;
  std::set<std::uint32_t> observers;
  for (const auto& node : landmarks_) {
    if (!node) continue;
    const bool seen_by_free = std::any_of(node->observations.begin(), node->observations.end(),
                                          [&](const Observation& o) { return free.contains(o.submap); });
    if (!seen_by_free) continue;
    for (const Observation& o : node->observations) {
      SubmapNode& submap = *submaps_.at(o.submap);
      local.AddResidualBlock(new SubmapPointFactor(o.point_in_submap, submap.depth_in_submap_units),
                             loss_.get(), submap.parameters.data(), node->position.data());
      observers.insert(o.submap);
    }
    landmark_blocks.push_back(node->position.data());
  }
  for (std::uint32_t id : observers) {
    SubmapNode& node = *submaps_.at(id);
    double* block = node.parameters.data();
    local.SetManifold(block, manifold_.get());
    submap_blocks.push_back(block);
    if (id == gauge_ || !free.contains(id)) {
      local.SetParameterBlockConstant(block);
    } else if (options_.scale_prior_weight > 0) {
      local.AddResidualBlock(new LogScalePriorFactor(node.log_scale_at_insertion, options_.scale_prior_weight),
                             nullptr, block);
    }
  }
  if (landmark_blocks.empty()) {  // nothing the free submaps observe: nothing to move
    GraphSolveSummary nothing;
    nothing.solver = options_.linear_solver;
    nothing.converged = nothing.usable = true;
    return nothing;
  }
  return Solve(local, landmark_blocks, submap_blocks, cancel);
}

GraphSolveSummary SubmapGraph::Solve(ceres::Problem& problem, const std::vector<double*>& landmark_blocks,
                                     const std::vector<double*>& submap_blocks,
                                     const CancellationToken& cancel) {
  const auto start = std::chrono::steady_clock::now();
  GraphSolveSummary summary;
  summary.solver = options_.linear_solver;

  ceres::Solver::Options solver_options;
  SetLinearSolver(options_.linear_solver, &solver_options);
  solver_options.max_num_iterations = options_.max_iterations;
  solver_options.function_tolerance = options_.function_tolerance;
  solver_options.num_threads = options_.num_threads;
  solver_options.logging_type = ceres::SILENT;
  if (solver_options.linear_solver_type == ceres::ITERATIVE_SCHUR ||
      solver_options.linear_solver_type == ceres::SPARSE_SCHUR) {
    // Eliminate landmarks first, then solve for the submaps (what the Schur solvers are for).
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (double* block : landmark_blocks) ordering->AddElementToGroup(block, 0);
    for (double* block : submap_blocks) ordering->AddElementToGroup(block, 1);
    if (ordering->GroupSize(0) > 0) solver_options.linear_solver_ordering = ordering;
  }
  CancelCallback cancel_callback(cancel);
  solver_options.callbacks.push_back(&cancel_callback);

  ceres::Solver::Summary ceres_summary;
  ceres::Solve(solver_options, &problem, &ceres_summary);
  // Ceres calls the callback from iteration 0 on, and an aborted solve leaves the parameter
  // blocks as they were before it: the graph stays consistent.
  cancel.ThrowIfCancelled();

  summary.iterations = static_cast<int>(ceres_summary.iterations.size());
  summary.initial_cost = ceres_summary.initial_cost;
  summary.final_cost = ceres_summary.final_cost;
  summary.converged = ceres_summary.termination_type == ceres::CONVERGENCE;
  summary.usable = summary.converged || (ceres_summary.termination_type == ceres::NO_CONVERGENCE &&
                                         std::isfinite(ceres_summary.final_cost));
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!summary.usable) {
    GLAM_LOG_WARN("submap graph solve failed: {}", ceres_summary.message);
  }
  GLAM_LOG_DEBUG("submap graph: {} of {} submaps, {} of {} landmarks, {} factors, {} ({}), {} iterations, "
                 "cost {:.4g} -> {:.4g}, {:.3f} s",
                 submap_blocks.size(), submaps_.size(), landmark_blocks.size(), num_landmarks_,
                 problem.NumResidualBlocks(),
                 ToString(options_.linear_solver), ceres_summary.message, summary.iterations,
                 summary.initial_cost, summary.final_cost, summary.seconds);
  return summary;
}

Sim3 SubmapGraph::world_from_submap(std::uint32_t id) const {
  const auto it = submaps_.find(id);
  GLAM_CHECK(it != submaps_.end(), "submap {} is not in the graph", id);
  return Sim3FromParameters(it->second->parameters.data());
}

bool SubmapGraph::HasSubmap(std::uint32_t id) const { return submaps_.contains(id); }

std::vector<std::uint32_t> SubmapGraph::submap_ids() const {
  std::vector<std::uint32_t> ids;
  ids.reserve(submaps_.size());
  for (const auto& [id, node] : submaps_) ids.push_back(id);
  return ids;
}

std::vector<GraphLandmark> SubmapGraph::Landmarks() const {
  std::vector<GraphLandmark> out;
  out.reserve(num_landmarks_);
  for (const auto& node : landmarks_) {
    if (!node) continue;
    GraphLandmark l;
    l.submap = node->observations.front().submap;
    l.landmark = node->observations.front().landmark;
    l.observations = node->observations.size();
    l.position_in_world = Eigen::Map<const Eigen::Vector3d>(node->position.data());
    out.push_back(l);
  }
  return out;
}

std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> SubmapGraph::LandmarkMembers() const {
  std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> out;
  out.reserve(num_landmarks_);
  for (const auto& node : landmarks_) {
    if (!node) continue;
    auto& members = out.emplace_back();
    for (const Observation& o : node->observations) members.emplace_back(o.submap, o.landmark);
  }
  return out;
}

}  // namespace glam
