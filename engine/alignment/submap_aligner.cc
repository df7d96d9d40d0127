#include "engine/alignment/submap_aligner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "engine/alignment/shared_frames.h"
#include "engine/core/logging.h"
#include "engine/core/options.h"
#include "engine/map/submap_io.h"

namespace glam {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

nlohmann::json MatrixRows(const Sim3& t) {
  const Eigen::Matrix4d m = t.matrix();
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  return rows;
}

}  // namespace

void AlignerOptions::Check() const {
  verification.Check();
  graph.Check();
  leveling.Check();
  CheckGreaterEqual("AlignerOptions.min_retrieval_inliers", min_retrieval_inliers, 3);
  CheckGreaterEqual("AlignerOptions.max_candidates", max_candidates, 0);
  CheckInRange("AlignerOptions.min_relative_score", min_relative_score, 0.0, 1.0);
  CheckGreater("AlignerOptions.max_scale_disagreement", max_scale_disagreement, 1.0);
  CheckGreaterEqual("AlignerOptions.local_window", local_window, 0);
  CheckGreaterEqual("AlignerOptions.max_demotable_submaps", max_demotable_submaps, 0);
}

SubmapAligner::SubmapAligner(const VocabularyTree& vocabulary, const AlignerOptions& options,
                             std::filesystem::path submaps_root, CancellationToken cancel)
    : vocabulary_(vocabulary),
      options_(options),
      submaps_root_(std::move(submaps_root)),
      cancel_(std::move(cancel)),
      database_(vocabulary),
      graph_(std::make_unique<SubmapGraph>(options.graph)),
      snapshot_(std::make_shared<MapSnapshot>()) {
  options_.Check();
}

void SubmapAligner::ContinueRevisionsAfter(std::int64_t revision) {
  GLAM_CHECK(nodes_.empty() && revision >= 0, "ContinueRevisionsAfter before the first Add");
  revision_ = revision;
}

void SubmapAligner::Add(const Submap& submap) {
  const auto start = Clock::now();
  cancel_.ThrowIfCancelled();
  GLAM_CHECK(!nodes_.contains(submap.id), "submap added twice");
  SubmapAlignmentTiming timing;
  timing.submap = submap.id;

  Node node;
  node.id = submap.id;
  node.first_frame = submap.first_frame;
  node.last_frame = submap.last_frame;
  node.frames = submap.frame_poses.size();
  node.depth_scale = SubmapDepthScale(submap);
  const bool first = nodes_.empty();
  nodes_[submap.id] = node;

  std::vector<VerifiedEdge> verified = VerifyCandidates(submap, &timing);
  const auto optimise_start = Clock::now();
  if (first) {
    const LevelingResult level = LevelSubmap(submap, options_.leveling);
    GLAM_LOG_INFO("world frame = submap {} levelled ({} ground-plane inliers of {} landmarks)",
                  submap.id, level.plane_inliers, submap.landmarks.size());
    AddToGraph(submap.id, level.world_from_submap);
  } else if (std::any_of(verified.begin(), verified.end(), [&](const VerifiedEdge& e) {
               return nodes_.at(e.edge.reference).component == 0;
             })) {
    touched_this_add_.clear();
    joined_this_add_ = false;
    PlaceInMain(submap, verified);
    const GraphSolveSummary summary = OptimizeAfterAdd();
    GLAM_LOG_DEBUG("graph after submap {}: {} submaps, {} landmarks, {} iterations, cost {:.4g} -> {:.4g}, {:.3f} s",
                   submap.id, graph_->num_submaps(), graph_->num_landmarks(), summary.iterations,
                   summary.initial_cost, summary.final_cost, summary.seconds);
  } else {
    PlacePending(submap, verified);
  }
  timing.optimization_s = Seconds(optimise_start);
  for (const VerifiedEdge& v : verified) {
    if (nodes_.at(v.edge.reference).component == nodes_.at(submap.id).component) ++timing.edges;
  }
  previous_ = submap;
  Publish();
  timing.total_s = Seconds(start);
  timings_.push_back(timing);
  GLAM_LOG_INFO("submap {} aligned{}: {} edges, {} candidates verified, {:.3f} s (revision {})",
                submap.id, nodes_.at(submap.id).component == 0 ? "" : " (disconnected)",
                timing.edges, timing.candidates, timing.total_s, revision_);
}

std::vector<SubmapAligner::VerifiedEdge> SubmapAligner::VerifyCandidates(
    const Submap& submap, SubmapAlignmentTiming* timing) {
  std::vector<VerifiedEdge> out;
  auto record = [&](const Submap& reference, PairVerification v, bool temporal, double score) {
    if (!v.verified) return;
    AlignmentEdge edge;
    edge.reference = reference.id;
    edge.query = submap.id;
    edge.temporal = temporal;
    edge.score = score;
    edge.matches = v.matches;
    edge.inliers = v.inliers;
    edge.inlier_rmse = v.inlier_rmse;
    edge.reference_from_query = v.reference_from_query;
    out.push_back({edge, std::move(v.inlier_pairs)});
  };

  // Temporal neighbour: the new submap started inside the previous one's last frames.
  const bool temporal = previous_ && submap.first_frame <= previous_->last_frame;
  auto verify_start = Clock::now();
  if (temporal) {
    PairVerification v = VerifySubmapPair(*previous_, submap, options_.verification);
    if (v.verified && options_.use_shared_frames) {
      const std::vector<LandmarkMatch> frames = SharedFrameMatches(*previous_, submap, v.reference_from_query);
      v.inlier_pairs.insert(v.inlier_pairs.end(), frames.begin(), frames.end());
    }
    record(*previous_, std::move(v), true, 0);
  }
  timing->verification_s += Seconds(verify_start);

  // Retrieval: tf-idf ranked earlier submaps that share visual words.
  const auto retrieval_start = Clock::now();
  std::vector<Descriptor> descriptors;
  descriptors.reserve(submap.landmarks.size());
  for (const Landmark& lm : submap.landmarks) descriptors.push_back(lm.descriptor);
  const std::vector<std::uint32_t> words = vocabulary_.Quantize(descriptors);
  const std::uint32_t neighbour = temporal ? previous_->id : submap.id;
  const std::vector<DatabaseMatch> ranked = database_.Query(
      words, options_.max_candidates, [&](std::uint32_t id) { return id == neighbour; });
  database_.Add(submap.id, words);
  timing->retrieval_s = Seconds(retrieval_start);

  verify_start = Clock::now();
  VerificationOptions strict = options_.verification;
  strict.min_inliers = std::max(strict.min_inliers, options_.min_retrieval_inliers);
  const double best = ranked.empty() ? 0.0 : ranked.front().score;
  for (const DatabaseMatch& candidate : ranked) {
    cancel_.ThrowIfCancelled();
    if (candidate.score < options_.min_relative_score * best) break;
    ++timing->candidates;
    if (previous_ && candidate.submap_id == previous_->id) {
      record(*previous_, VerifySubmapPair(*previous_, submap, strict), false, candidate.score);
    } else {
      const Submap reference = ReadSubmap(submaps_root_, candidate.submap_id);
      record(reference, VerifySubmapPair(reference, submap, strict), false, candidate.score);
    }
  }
  timing->verification_s += Seconds(verify_start);
  return out;
}

void SubmapAligner::PlaceInMain(const Submap& submap, const std::vector<VerifiedEdge>& verified) {
  // Primary edge: the temporal one when it reaches the main map, else the best supported.
  const VerifiedEdge* primary = nullptr;
  for (const VerifiedEdge& v : verified) {
    if (nodes_.at(v.edge.reference).component != 0) continue;
    const bool better = primary == nullptr || (v.edge.temporal && !primary->edge.temporal) ||
                        (v.edge.temporal == primary->edge.temporal && v.edge.inliers > primary->edge.inliers);
    if (better) primary = &v;
  }
  GLAM_CHECK(primary != nullptr, "PlaceInMain needs an edge to the main map");
  const Sim3 world_from_submap =
      CurrentWorldFromSubmap(primary->edge.reference) * primary->edge.reference_from_query;
  AddToGraph(submap.id, world_from_submap);

  // Edges to pending components are added once those components have joined the map.
  std::set<int> joining;
  std::vector<const VerifiedEdge*> deferred;
  for (const VerifiedEdge& v : verified) {
    const int component = nodes_.at(v.edge.reference).component;
    if (component != 0) {
      joining.insert(component);
      deferred.push_back(&v);
      continue;
    }
    if (&v != primary) {
      // Drift changes scale slowly; a retrieved edge that disagrees grossly is a false match.
      const Sim3 implied = CurrentWorldFromSubmap(v.edge.reference) * v.edge.reference_from_query;
      const double ratio = implied.scale() / world_from_submap.scale();
      if (ratio > options_.max_scale_disagreement || ratio < 1.0 / options_.max_scale_disagreement) {
        GLAM_LOG_WARN("edge {} -> {} rejected: its scale disagrees with the map by {:.2f}x",
                      v.edge.reference, submap.id, ratio);
        continue;
      }
    }
    AddEdgeToGraph(v);
  }
  for (int component : joining) {
    // Place the pending component through its best edge to the new submap, then add it.
    const VerifiedEdge* link = nullptr;
    for (const VerifiedEdge* v : deferred) {
      if (nodes_.at(v->edge.reference).component != component) continue;
      if (link == nullptr || v->edge.inliers > link->edge.inliers) link = v;
    }
    const PendingComponent& pending = pending_.at(component);
    const Sim3 world_from_reference = world_from_submap * link->edge.reference_from_query.Inverse();
    const Sim3 world_from_component =
        world_from_reference * pending.component_from_submap.at(link->edge.reference).Inverse();
    GLAM_LOG_INFO("{} disconnected submaps joined the map", pending.component_from_submap.size());
    JoinMain(component, world_from_component);
  }
  for (const VerifiedEdge* v : deferred) AddEdgeToGraph(*v);
}

void SubmapAligner::PlacePending(const Submap& submap, const std::vector<VerifiedEdge>& verified) {
  if (verified.empty()) {
    // Nothing verified: a new pending component, displayed where the previous submap is.
    const int component = next_component_++;
    PendingComponent pending;
    pending.world_from_component = previous_ ? CurrentWorldFromSubmap(previous_->id) : Sim3();
    pending.component_from_submap[submap.id] = Sim3();
    pending_[component] = std::move(pending);
    nodes_.at(submap.id).component = component;
    GLAM_LOG_WARN("submap {} could not be linked to the map: kept as disconnected (component {})",
                  submap.id, component);
    PromoteIfLarger(component);
    return;
  }
  // Join the pending component of the best edge; merge any other pending component it links.
  const VerifiedEdge* primary = &*std::max_element(
      verified.begin(), verified.end(),
      [](const VerifiedEdge& a, const VerifiedEdge& b) { return a.edge.inliers < b.edge.inliers; });
  const int target = nodes_.at(primary->edge.reference).component;
  PendingComponent& into = pending_.at(target);
  const Sim3 component_from_submap =
      into.component_from_submap.at(primary->edge.reference) * primary->edge.reference_from_query;
  into.component_from_submap[submap.id] = component_from_submap;
  nodes_.at(submap.id).component = target;
  for (const VerifiedEdge& v : verified) {
    const int component = nodes_.at(v.edge.reference).component;
    if (component != target) {
      PendingComponent other = std::move(pending_.at(component));
      pending_.erase(component);
      const Sim3 target_from_reference = component_from_submap * v.edge.reference_from_query.Inverse();
      const Sim3 target_from_other =
          target_from_reference * other.component_from_submap.at(v.edge.reference).Inverse();
      for (const auto& [id, other_from_submap] : other.component_from_submap) {
        into.component_from_submap[id] = target_from_other * other_from_submap;
        nodes_.at(id).component = target;
      }
      for (VerifiedEdge& e : other.edges) into.edges.push_back(std::move(e));
    }
    into.edges.push_back(v);
  }
  PromoteIfLarger(target);
}

std::size_t SubmapAligner::FramesOf(int component) const {
  std::size_t frames = 0;
  for (const auto& [id, node] : nodes_) {
    if (node.component == component) frames += node.frames;
  }
  return frames;
}

void SubmapAligner::PromoteIfLarger(int component) {
  if (graph_order_.size() > static_cast<std::size_t>(options_.max_demotable_submaps)) return;
  const std::size_t frames = FramesOf(component);
  const std::size_t main_frames = FramesOf(0);
  if (frames <= main_frames) return;
  // The promoted part's first submap, levelled, becomes the world frame.
  const PendingComponent& promoted = pending_.at(component);
  const std::size_t promoted_submaps = promoted.component_from_submap.size();
  const std::uint32_t first = promoted.component_from_submap.begin()->first;
  const Sim3 world_from_component =
      LevelPart(ReadSubmap(submaps_root_, first), promoted.component_from_submap.at(first), options_.leveling);

  // The old main map becomes a disconnected part, displayed where it was (in the old world
  // frame: world_from_component stays the identity).
  PendingComponent demoted;
  for (std::uint32_t id : graph_order_) demoted.component_from_submap[id] = graph_->world_from_submap(id);
  demoted.edges = std::move(main_edges_);
  const int demoted_component = next_component_++;
  for (const auto& [id, unused] : demoted.component_from_submap) nodes_.at(id).component = demoted_component;
  pending_[demoted_component] = std::move(demoted);

  // The promoted part joins a new, empty graph.
  graph_ = std::make_unique<SubmapGraph>(options_.graph);
  graph_order_.clear();
  main_edges_.clear();
  edges_.clear();
  JoinMain(component, world_from_component);
  graph_->Optimize(cancel_);
  GLAM_LOG_WARN("{} disconnected submaps pose {} frames, the map {}: they become the map (world frame = "
                "submap {} levelled), the previous map is kept as disconnected (component {})",
                promoted_submaps, frames, main_frames, first, demoted_component);
}

void SubmapAligner::JoinMain(int component, const Sim3& world_from_component) {
  PendingComponent pending = std::move(pending_.at(component));
  pending_.erase(component);
  for (const auto& [id, component_from_submap] : pending.component_from_submap) {
    AddToGraph(id, world_from_component * component_from_submap);
  }
  for (const VerifiedEdge& edge : pending.edges) AddEdgeToGraph(edge);
  joined_this_add_ = true;
}

void SubmapAligner::AddToGraph(std::uint32_t id, const Sim3& world_from_submap) {
  Node& node = nodes_.at(id);
  node.component = 0;
  graph_->AddSubmap(id, world_from_submap, node.depth_scale);
  graph_order_.push_back(id);
  if (graph_order_.size() > static_cast<std::size_t>(options_.max_demotable_submaps)) {
    main_edges_.clear();
    main_edges_.shrink_to_fit();
  }
}

void SubmapAligner::AddEdgeToGraph(const VerifiedEdge& edge) {
  graph_->AddEdge(edge.edge.reference, edge.edge.query, edge.pairs);
  edges_.push_back(edge.edge);
  if (graph_order_.size() <= static_cast<std::size_t>(options_.max_demotable_submaps)) main_edges_.push_back(edge);
  touched_this_add_.insert(edge.edge.reference);
  touched_this_add_.insert(edge.edge.query);
}

GraphSolveSummary SubmapAligner::OptimizeAfterAdd() {
  const auto window = static_cast<std::size_t>(options_.local_window);
  if (window == 0 || joined_this_add_ || graph_order_.size() <= window) return graph_->Optimize(cancel_);
  const std::set<std::uint32_t> recent(graph_order_.end() - static_cast<std::ptrdiff_t>(window), graph_order_.end());
  for (std::uint32_t id : touched_this_add_) {
    if (!recent.contains(id)) return graph_->Optimize(cancel_);  // a loop closure: all of it
  }
  return graph_->OptimizeSubset(recent, cancel_);
}

Sim3 SubmapAligner::CurrentWorldFromSubmap(std::uint32_t id) const {
  const Node& node = nodes_.at(id);
  if (node.component == 0) return graph_->world_from_submap(id);
  const PendingComponent& pending = pending_.at(node.component);
  return pending.world_from_component * pending.component_from_submap.at(id);
}

void SubmapAligner::Publish() {
  auto snapshot = std::make_shared<MapSnapshot>();
  snapshot->revision = ++revision_;
  snapshot->submaps.reserve(nodes_.size());
  for (const auto& [id, node] : nodes_) {
    SubmapPlacement placement;
    placement.id = id;
    placement.world_from_submap = CurrentWorldFromSubmap(id);
    placement.disconnected = node.component != 0;
    placement.first_frame = node.first_frame;
    placement.last_frame = node.last_frame;
    placement.part = node.component;
    placement.part_from_submap = node.component == 0
                                     ? placement.world_from_submap
                                     : pending_.at(node.component).component_from_submap.at(id);
    snapshot->submaps.push_back(placement);
  }
  std::lock_guard lock(snapshot_mutex_);
  snapshot_ = std::move(snapshot);
}

std::shared_ptr<const MapSnapshot> SubmapAligner::snapshot() const {
  std::lock_guard lock(snapshot_mutex_);
  return snapshot_;
}

nlohmann::json SubmapAligner::GraphJson() const {
  const std::shared_ptr<const MapSnapshot> snap = snapshot();
  nlohmann::json nodes = nlohmann::json::array();
  for (const SubmapPlacement& p : snap->submaps) {
    const Node& node = nodes_.at(p.id);
    nodes.push_back({{"id", p.id},
                     {"world_from_submap", MatrixRows(p.world_from_submap)},
                     {"first_frame", node.first_frame},
                     {"last_frame", node.last_frame},
                     {"frames", node.frames},
                     {"depth_scale", node.depth_scale},
                     {"disconnected", p.disconnected}});
  }
  nlohmann::json edges = nlohmann::json::array();
  for (const AlignmentEdge& e : edges_) {
    edges.push_back({{"from", e.reference},
                     {"to", e.query},
                     {"kind", e.temporal ? "temporal" : "retrieved"},
                     {"score", e.score},
                     {"matches", e.matches},
                     {"inliers", e.inliers},
                     {"inlier_rmse", e.inlier_rmse},
                     {"from_from_to", MatrixRows(e.reference_from_query)}});
  }
  return {{"revision", snap->revision},
          {"graph_landmarks", graph_->num_landmarks()},
          {"nodes", nodes},
          {"edges", edges}};
}

std::vector<std::vector<LandmarkKey>> SubmapAligner::LandmarkGroups() const {
  std::vector<std::vector<LandmarkKey>> groups;
  for (const auto& members : graph_->LandmarkMembers()) {
    std::vector<LandmarkKey> group;
    for (const auto& [submap, landmark] : members) {
      if (landmark < kSharedFrameIdBase) group.push_back({submap, landmark});
    }
    if (group.size() >= 2) groups.push_back(std::move(group));
  }
  return groups;
}

}  // namespace glam
