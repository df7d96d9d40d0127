#include "engine/alignment/submap_database.h"

#include <algorithm>

#include "engine/alignment/vocabulary_tree.h"
#include "engine/core/error.h"

namespace glam {

SubmapDatabase::SubmapDatabase(const VocabularyTree& vocabulary) : SubmapDatabase(vocabulary.idf_weights()) {}

SubmapDatabase::SubmapDatabase(std::vector<float> idf) : idf_(std::move(idf)) {
  postings_.resize(idf_.size());
}

float SubmapDatabase::idf(std::uint32_t word) const {
  if (idf_.empty()) return 1.0f;
  GLAM_CHECK(word < idf_.size(), "word {} outside the vocabulary ({} words)", word, idf_.size());
  return idf_[word];
}

std::vector<SubmapDatabase::WeightedWord> SubmapDatabase::Weigh(std::span<const std::uint32_t> words) const {
  std::vector<std::uint32_t> sorted(words.begin(), words.end());
  std::sort(sorted.begin(), sorted.end());
  std::vector<WeightedWord> out;
  double total = 0;
  for (std::size_t i = 0; i < sorted.size();) {
    std::size_t j = i;
    while (j < sorted.size() && sorted[j] == sorted[i]) ++j;
    const float weight = static_cast<float>(j - i) * idf(sorted[i]);
    if (weight > 0) {
      out.push_back({sorted[i], weight});
      total += weight;
    }
    i = j;
  }
  for (WeightedWord& w : out) w.weight = static_cast<float>(w.weight / total);
  return out;
}

void SubmapDatabase::Add(std::uint32_t submap_id, std::span<const std::uint32_t> words) {
  const auto slot = static_cast<std::uint32_t>(submap_ids_.size());
  const bool inserted = slot_of_id_.emplace(submap_id, slot).second;
  GLAM_CHECK(inserted, "submap {} added to the database twice", submap_id);
  submap_ids_.push_back(submap_id);
  for (const WeightedWord& w : Weigh(words)) {
    if (w.word >= postings_.size()) postings_.resize(w.word + 1);  // only without a vocabulary
    postings_[w.word].push_back({slot, w.weight});
  }
}

std::vector<DatabaseMatch> SubmapDatabase::Query(std::span<const std::uint32_t> words, int max_results,
                                                 const std::function<bool(std::uint32_t)>& exclude,
                                                 DatabaseQueryStats* stats) const {
  DatabaseQueryStats local;
  const std::vector<WeightedWord> query = Weigh(words);
  local.query_words = query.size();
  // Accumulate sum_w min(q_w, d_w) over the posting lists of the query's words only. The
  // accumulator is indexed by slot (one float per submap, zeroed, never scanned); `touched`
  // lists the submaps that share a word.
  std::vector<float> score(max_results == 0 ? 0 : submap_ids_.size(), 0.0f);
  std::vector<std::uint32_t> touched;
  if (max_results != 0) {
    for (const WeightedWord& q : query) {
      if (q.word >= postings_.size()) continue;
      for (const Posting& p : postings_[q.word]) {
        if (score[p.slot] == 0.0f) touched.push_back(p.slot);
        score[p.slot] += std::min(q.weight, p.weight);
      }
      local.postings_visited += postings_[q.word].size();
    }
  }
  local.submaps_scored = touched.size();

  std::vector<DatabaseMatch> matches;
  matches.reserve(touched.size());
  for (std::uint32_t slot : touched) {
    const std::uint32_t id = submap_ids_[slot];
    if (exclude && exclude(id)) continue;
    matches.push_back({id, std::min(1.0, static_cast<double>(score[slot]))});
  }
  auto better = [](const DatabaseMatch& a, const DatabaseMatch& b) {
    return a.score != b.score ? a.score > b.score : a.submap_id < b.submap_id;
  };
  const std::size_t keep = max_results < 0 ? matches.size()
                                           : std::min(matches.size(), static_cast<std::size_t>(max_results));
  std::partial_sort(matches.begin(), matches.begin() + static_cast<std::ptrdiff_t>(keep), matches.end(), better);
  matches.resize(keep);
  if (stats != nullptr) *stats = local;
  return matches;
}

std::size_t SubmapDatabase::MemoryBytes() const {
  std::size_t bytes = idf_.capacity() * sizeof(float) + postings_.capacity() * sizeof(std::vector<Posting>) +
                      submap_ids_.capacity() * sizeof(std::uint32_t);
  for (const auto& list : postings_) bytes += list.capacity() * sizeof(Posting);
  // unordered_map: one node (key, value, next pointer, cached hash) per entry plus the buckets.
  bytes += slot_of_id_.size() * (2 * sizeof(std::uint32_t) + 2 * sizeof(void*)) +
           slot_of_id_.bucket_count() * sizeof(void*);
  return bytes;
}

}  // namespace glam
