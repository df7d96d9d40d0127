// Thread 2 of GLAM (paper, "Global Submap Alignment"): every completed submap is
//   1. quantised into visual words (vocabulary tree) and used to query the inverted-index
//      database for earlier submaps that saw the same ground (loop closures, re-localisation
//      after a tracking loss), then added to the database;
//   2. verified against its temporal neighbour (through the 10 % overlap hand-off) and
//      against the retrieved candidates by descriptor matching + Sim3 RANSAC;
//   3. added to the submap factor graph with its verified inlier correspondences, and the
//      graph is re-optimised (warm-started) — a loop edge pulls the drifted chain into place;
//   4. published as a new MapSnapshot revision.
//
// Submaps that cannot be verified against the main map are kept in "pending" components with
// their relative placements and edges, marked disconnected; when a later submap links a
// pending component to the main map, the whole component joins the graph. Memory stays
// bounded: the aligner keeps the visual words (inside the database), the last submap, and
// per submap only its metadata; candidates are read back from disk (submaps/<id>/) to verify.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <set>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/alignment/submap_database.h"
#include "engine/alignment/submap_graph.h"
#include "engine/alignment/submap_verifier.h"
#include "engine/alignment/vocabulary_tree.h"
#include "engine/core/cancellation.h"
#include "engine/map/map_snapshot.h"
#include "engine/map/submap.h"
#include "engine/alignment/world_leveling.h"

namespace glam {

struct AlignerOptions {
  // Temporal neighbours (overlap hand-off).
  VerificationOptions verification;
  // Retrieved candidates need more evidence than neighbours: a false loop edge bends the map.
  int min_retrieval_inliers = 30;
  // Database results verified per submap (best tf-idf scores first).
  int max_candidates = 3;
  // Candidates scoring below this fraction of the best retrieved score are not verified.
  double min_relative_score = 0.3;
  // A retrieved edge inside the main map is rejected when its scale disagrees with the current
  // estimate by more than this factor (a gross mismatch, not drift).
  double max_scale_disagreement = 1.5;
  // Temporal edges also get the frames both submaps posed (shared_frames.h): camera centre
  // and a point ahead per shared frame, beside the matched landmarks. false = the paper's
  // landmark-only edges.
  bool use_shared_frames = true;
  // A submap whose edges all reach the last `local_window` submaps of the map (the usual case:
  // its temporal neighbour) is optimised with only those submaps free
  // (SubmapGraph::OptimizeSubset); a loop closure or re-localisation farther back, or a
  // disconnected part joining, re-optimises the whole graph. 0 = always the whole graph (the
  // paper). Keeps thread 2's cost per submap flat on long flights.
  int local_window = 8;
  // The map is the part that holds the most video. While the main map (the first submap's
  // part, in the graph) has at most this many submaps, a disconnected part that poses more
  // frames takes its place: it enters the graph with its own edges, its first submap levelled
  // as the world frame, and the old main map becomes a disconnected part (re-joining when a
  // later submap links them). Why: a flight whose first submap is a short fragment (a gimbal
  // tilting down from the horizon at the start, measured: 59 frames, then tracking lost)
  // would otherwise export that fragment and leave the other 541 frames out as disconnected.
  // The main map's edges are kept for this (with their correspondences) only while it is
  // this small. 0 = the first submap's part stays the map (the paper's world frame).
  int max_demotable_submaps = 4;
  SubmapGraphOptions graph;
  LevelingOptions leveling;

  void Check() const;  // throws InputError
};

struct AlignmentEdge {
  std::uint32_t reference = 0;  // the earlier submap
  std::uint32_t query = 0;      // the submap being added
  bool temporal = false;        // overlap neighbour (else: retrieved by the vocabulary tree)
  double score = 0;             // database score (retrieved edges)
  int matches = 0;
  int inliers = 0;
  double inlier_rmse = 0;       // reference units
  Sim3 reference_from_query;
};

struct SubmapAlignmentTiming {
  std::uint32_t submap = 0;
  int candidates = 0;       // retrieved candidates verified
  int edges = 0;            // verified edges added
  double retrieval_s = 0;   // quantisation + query + insertion
  double verification_s = 0;
  double optimization_s = 0;
  double total_s = 0;
};

class SubmapAligner {
 public:
  // `submaps_root`: where completed submaps were persisted (ReadSubmap), for candidates.
  SubmapAligner(const VocabularyTree& vocabulary, const AlignerOptions& options,
                std::filesystem::path submaps_root, CancellationToken cancel = {});

  // One alignment step for a completed, already persisted submap. Not thread-safe: call from
  // one thread (thread 2); snapshot() may be called concurrently from any thread.
  void Add(const Submap& submap);

  std::shared_ptr<const MapSnapshot> snapshot() const;

  // Revisions must only grow for a job's readers (SSE clients, cached tilesets), also across a
  // resumed run that re-adds its persisted submaps: the next snapshot gets `revision` + 1.
  // Only before the first Add.
  void ContinueRevisionsAfter(std::int64_t revision);

  // For reports, after the last Add.
  const std::vector<AlignmentEdge>& edges() const { return edges_; }
  const std::vector<SubmapAlignmentTiming>& timings() const { return timings_; }
  std::size_t graph_landmarks() const { return graph_->num_landmarks(); }
  // The main map's ground points matched across submaps, each as its members (the frames'
  // pseudo-landmarks of shared_frames.h left out): the tracks global_refinement.h joins.
  std::vector<std::vector<LandmarkKey>> LandmarkGroups() const;
  // graph.json: nodes (placement, frames, disconnected), edges (kind, score, inliers, Sim3).
  nlohmann::json GraphJson() const;

 private:
  struct Node {
    std::uint32_t id = 0;
    std::int64_t first_frame = 0;
    std::int64_t last_frame = 0;
    std::size_t frames = 0;
    double depth_scale = 1;
    int component = 0;  // 0 = main map (in the graph), else a pending component
  };
  struct VerifiedEdge {
    AlignmentEdge edge;
    std::vector<LandmarkMatch> pairs;
  };
  struct PendingComponent {
    Sim3 world_from_component;  // display placement only
    std::map<std::uint32_t, Sim3> component_from_submap;
    std::vector<VerifiedEdge> edges;  // internal edges, replayed into the graph on joining
  };

  std::vector<VerifiedEdge> VerifyCandidates(const Submap& submap, SubmapAlignmentTiming* timing);
  void PlaceInMain(const Submap& submap, const std::vector<VerifiedEdge>& verified);
  void PlacePending(const Submap& submap, const std::vector<VerifiedEdge>& verified);
  // Moves pending `component` (its submaps, placed by world_from_component, and its internal
  // edges) into the graph: when a submap links it to the map, and by PromoteIfLarger.
  void JoinMain(int component, const Sim3& world_from_component);
  // max_demotable_submaps: swaps `component` with the main map if it poses more frames.
  void PromoteIfLarger(int component);
  std::size_t FramesOf(int component) const;
  void AddToGraph(std::uint32_t id, const Sim3& world_from_submap);
  void AddEdgeToGraph(const VerifiedEdge& edge);
  // Whole graph or the local window, by what the current Add() changed (see local_window).
  GraphSolveSummary OptimizeAfterAdd();
  Sim3 CurrentWorldFromSubmap(std::uint32_t id) const;
  void Publish();

  const VocabularyTree& vocabulary_;
  AlignerOptions options_;
  std::filesystem::path submaps_root_;
  CancellationToken cancel_;
  SubmapDatabase database_;
  std::unique_ptr<SubmapGraph> graph_;  // the main map (replaced when a larger part is promoted)
  std::map<std::uint32_t, Node> nodes_;
  std::map<int, PendingComponent> pending_;
  int next_component_ = 1;
  std::optional<Submap> previous_;  // the temporal neighbour of the next submap
  std::vector<AlignmentEdge> edges_;
  std::vector<std::uint32_t> graph_order_;     // submaps in the order they joined the graph
  // The main map's edges with their correspondences while it may still be demoted
  // (max_demotable_submaps); cleared and no longer kept once it has grown past that.
  std::vector<VerifiedEdge> main_edges_;
  std::set<std::uint32_t> touched_this_add_;   // submaps an edge added by this Add() links
  bool joined_this_add_ = false;               // a pending component joined in this Add()
  std::vector<SubmapAlignmentTiming> timings_;
  std::int64_t revision_ = 0;
  mutable std::mutex snapshot_mutex_;
  std::shared_ptr<const MapSnapshot> snapshot_;
};

}  // namespace glam
