// Inverted index over visual words: which completed submaps contain which words. It turns the
// search for submaps that see the same ground (loop closures, re-visits after a cut) from a
// comparison of every pair of submaps into a walk over the posting lists of the query's words
// (Nistér & Stewénius 2006), so a query costs what the query's words are shared, not what the
// map holds.
//
// Scoring: each bag of words becomes a vector with entries tf_w * idf_w, normalised to unit L1
// norm; the score of a query q against a submap d is 1 - |q - d|_1 / 2, which for L1-normalised
// non-negative vectors equals sum_w min(q_w, d_w) over the words both contain. It lies in
// [0, 1], is 1 for identical bags and 0 when nothing is shared, and needs only the shared
// words. The idf weights are fixed by the vocabulary at training time, so stored vectors never
// change when submaps are added.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <unordered_map>
#include <vector>

namespace glam {

class VocabularyTree;

struct DatabaseMatch {
  std::uint32_t submap_id = 0;
  double score = 0;  // in [0, 1], 1 = the same bag of words
};

// What one query touched (a test hook for the "no quadratic cost" property, and for logs).
struct DatabaseQueryStats {
  std::size_t query_words = 0;       // distinct words with non-zero weight in the query
  std::size_t postings_visited = 0;  // entries of the query words' posting lists
  std::size_t submaps_scored = 0;    // submaps sharing at least one word with the query
};

class SubmapDatabase {
 public:
  // Every word weighs 1 (plain term frequency); for tests and for callers without a vocabulary.
  SubmapDatabase() = default;
  // tf-idf with the vocabulary's idf weights (copied: no lifetime coupling).
  explicit SubmapDatabase(const VocabularyTree& vocabulary);
  explicit SubmapDatabase(std::vector<float> idf);

  // Adds a submap by the word ids of its landmark descriptors; repeated ids count as term
  // frequency. Each id may be added once (a second Add of the same id is a programmer error).
  void Add(std::uint32_t submap_id, std::span<const std::uint32_t> words);

  // Submaps sharing words with `words`, best first (ties: lower id first), at most
  // `max_results` of them (0 = none, negative = all). Submaps for which `exclude` returns true
  // are skipped (e.g. the query's own temporal neighbour). Submaps sharing no word are never
  // visited and never returned.
  std::vector<DatabaseMatch> Query(std::span<const std::uint32_t> words, int max_results,
                                   const std::function<bool(std::uint32_t)>& exclude = {},
                                   DatabaseQueryStats* stats = nullptr) const;

  std::size_t size() const { return submap_ids_.size(); }
  bool contains(std::uint32_t submap_id) const { return slot_of_id_.contains(submap_id); }
  // Heap bytes held by the index (posting lists, id tables), for benchmarks.
  std::size_t MemoryBytes() const;

 private:
  struct Posting {
    std::uint32_t slot;  // index into submap_ids_
    float weight;        // L1-normalised tf-idf of the word in that submap
  };
  struct WeightedWord {
    std::uint32_t word;
    float weight;
  };
  // Sorted distinct words with their L1-normalised tf-idf weights (zero-weight words dropped).
  std::vector<WeightedWord> Weigh(std::span<const std::uint32_t> words) const;
  float idf(std::uint32_t word) const;

  std::vector<float> idf_;  // empty = every word weighs 1
  std::vector<std::vector<Posting>> postings_;  // by word id
  std::vector<std::uint32_t> submap_ids_;       // by slot
  std::unordered_map<std::uint32_t, std::uint32_t> slot_of_id_;
};

}  // namespace glam
