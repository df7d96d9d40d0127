#include "engine/alignment/vocabulary_tree.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <numeric>
#include <random>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>

#include "engine/alignment/default_vocabulary.h"
#include "engine/core/binary_io.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/core/options.h"

namespace glam {
namespace {

constexpr std::string_view kMagic("GLAMVOCT", 8);
// Sanity bounds that reject corrupt counts before allocating.
constexpr std::uint32_t kMaxNodes = 1u << 24;
constexpr int kMaxBranching = 255;
constexpr int kMaxDepth = 16;

inline std::uint32_t SquaredDistance(const std::uint8_t* a, const std::uint8_t* b) {
  std::uint32_t sum = 0;
  for (int i = 0; i < kDescriptorSize; ++i) {
    const int d = static_cast<int>(a[i]) - static_cast<int>(b[i]);
    sum += static_cast<std::uint32_t>(d * d);
  }
  return sum;
}

// k-means of `members` (rows of `data`) into k float centres with k-means++ seeding. OpenCV's
// kmeans draws from the calling thread's cv::theRNG(); it is seeded per node (so the tree
// depends only on the seed and the data) and restored afterwards.
cv::Mat KMeansCentres(const std::vector<Descriptor>& data, const std::vector<std::uint32_t>& members,
                      int k, int iterations, std::uint64_t seed) {
  cv::Mat samples(static_cast<int>(members.size()), kDescriptorSize, CV_32F);
  for (int r = 0; r < samples.rows; ++r) {
    const Descriptor& d = data[members[r]];
    float* row = samples.ptr<float>(r);
    for (int c = 0; c < kDescriptorSize; ++c) row[c] = d[c];
  }
  cv::RNG& rng = cv::theRNG();
  const cv::RNG saved = rng;
  rng = cv::RNG(seed | 1u);
  cv::Mat labels;
  cv::Mat centres;
  cv::kmeans(samples, k, labels,
             cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, iterations, 0.5), 1,
             cv::KMEANS_PP_CENTERS, centres);
  rng = saved;
  return centres;
}

std::uint64_t MixSeed(std::uint64_t seed, std::uint64_t node) {
  // splitmix64 finaliser: different nodes get unrelated k-means++ draws.
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ull * (node + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

}  // namespace

void VocabularyTreeOptions::Check() const {
  CheckInRange("VocabularyTreeOptions.branching", branching, 2, 64);
  CheckInRange("VocabularyTreeOptions.depth", depth, 1, 8);
  if (std::pow(static_cast<double>(branching), depth) > 1 << 22) {
    throw InputError(fmt::format(
        "VocabularyTreeOptions: branching^depth = {}^{} words is too many (at most 4194304)", branching, depth));
  }
  CheckInRange("VocabularyTreeOptions.kmeans_iterations", kmeans_iterations, 1, 1000);
  CheckGreaterEqual("VocabularyTreeOptions.max_training_descriptors", max_training_descriptors, branching);
}

VocabularyTree VocabularyTree::Train(const std::vector<std::vector<Descriptor>>& documents,
                                     const VocabularyTreeOptions& options) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };

  std::size_t total = 0;
  for (const auto& doc : documents) total += doc.size();
  if (total < static_cast<std::size_t>(options.branching)) {
    throw InputError(fmt::format("vocabulary training needs at least {} descriptors, got {}",
                                 options.branching, total));
  }

  // Deterministic subset for clustering (partial Fisher-Yates over all descriptor positions).
  std::vector<Descriptor> data;
  {
    std::vector<const Descriptor*> all;
    all.reserve(total);
    for (const auto& doc : documents) {
      for (const Descriptor& d : doc) all.push_back(&d);
    }
    const std::size_t n = std::min(total, static_cast<std::size_t>(options.max_training_descriptors));
    if (n < total) {
      std::mt19937_64 rng(options.seed);
      for (std::size_t i = 0; i < n; ++i) {
        std::uniform_int_distribution<std::size_t> pick(i, total - 1);
        std::swap(all[i], all[pick(rng)]);
      }
    }
    data.reserve(n);
    for (std::size_t i = 0; i < n; ++i) data.push_back(*all[i]);
  }
  GLAM_LOG_INFO("vocabulary: clustering {} of {} descriptors from {} documents (branching {}, depth {})",
                data.size(), total, documents.size(), options.branching, options.depth);

  VocabularyTree tree;
  tree.branching_ = options.branching;
  tree.depth_ = options.depth;
  tree.kmeans_iterations_ = options.kmeans_iterations;
  tree.seed_ = options.seed;
  tree.training_documents_ = documents.size();
  tree.training_descriptors_ = data.size();
  tree.children_begin_.push_back(0);
  tree.children_count_.push_back(0);
  tree.centres_.assign(kDescriptorSize, 0);  // the root's centre is never compared

  struct Pending {
    std::uint32_t node;
    std::vector<std::uint32_t> members;
  };
  std::vector<Pending> level_nodes(1);
  level_nodes[0].node = 0;
  level_nodes[0].members.resize(data.size());
  std::iota(level_nodes[0].members.begin(), level_nodes[0].members.end(), 0u);

  const int k = options.branching;
  for (int level = 0; level < options.depth && !level_nodes.empty(); ++level) {
    std::vector<Pending> next;
    for (Pending& p : level_nodes) {
      // A node with no more descriptors than children cannot be split meaningfully: leaf.
      if (p.members.size() <= static_cast<std::size_t>(k)) continue;
      const cv::Mat centres = KMeansCentres(data, p.members, k, options.kmeans_iterations,
                                            MixSeed(options.seed, p.node));
      std::vector<std::uint8_t> rounded(static_cast<std::size_t>(k) * kDescriptorSize);
      for (int c = 0; c < k; ++c) {
        for (int j = 0; j < kDescriptorSize; ++j) {
          rounded[c * kDescriptorSize + j] =
              static_cast<std::uint8_t>(std::clamp(std::lround(centres.at<float>(c, j)), 0L, 255L));
        }
      }
      // Partition with the rounded centres, exactly as Quantize() will descend.
      std::vector<std::vector<std::uint32_t>> groups(k);
      for (std::uint32_t m : p.members) {
        int best = 0;
        std::uint32_t best_d = SquaredDistance(data[m].data(), rounded.data());
        for (int c = 1; c < k; ++c) {
          const std::uint32_t d = SquaredDistance(data[m].data(), &rounded[c * kDescriptorSize]);
          if (d < best_d) best_d = d, best = c;
        }
        groups[best].push_back(m);
      }
      const int non_empty = static_cast<int>(
          std::count_if(groups.begin(), groups.end(), [](const auto& g) { return !g.empty(); }));
      if (non_empty < 2) continue;  // identical descriptors: nothing to split
      tree.children_begin_[p.node] = static_cast<std::uint32_t>(tree.children_count_.size());
      tree.children_count_[p.node] = static_cast<std::uint32_t>(non_empty);
      for (int c = 0; c < k; ++c) {
        if (groups[c].empty()) continue;
        const auto id = static_cast<std::uint32_t>(tree.children_count_.size());
        tree.children_begin_.push_back(0);
        tree.children_count_.push_back(0);
        tree.centres_.insert(tree.centres_.end(), rounded.begin() + c * kDescriptorSize,
                             rounded.begin() + (c + 1) * kDescriptorSize);
        next.push_back({id, std::move(groups[c])});
      }
    }
    level_nodes = std::move(next);
    GLAM_LOG_INFO("vocabulary: level {} done, {} nodes so far ({:.1f} s)", level + 1,
                  tree.children_count_.size(), elapsed());
  }
  const std::uint32_t num_words = tree.ComputeWordsOfNodes();

  // idf over all training documents (not only the clustering subset).
  std::vector<std::uint32_t> containing(num_words, 0);
  for (const auto& doc : documents) {
    std::vector<std::uint32_t> words = tree.Quantize(doc);
    std::sort(words.begin(), words.end());
    words.erase(std::unique(words.begin(), words.end()), words.end());
    for (std::uint32_t w : words) ++containing[w];
  }
  const double n_docs = static_cast<double>(documents.size());
  tree.idf_.resize(containing.size());
  for (std::size_t w = 0; w < containing.size(); ++w) {
    tree.idf_[w] = static_cast<float>(std::log(n_docs / std::max<std::uint32_t>(1, containing[w])));
  }
  GLAM_LOG_INFO("vocabulary: {} words, {} nodes, trained in {:.1f} s", tree.num_words(), tree.num_nodes(),
                elapsed());
  return tree;
}

std::uint32_t VocabularyTree::ComputeWordsOfNodes() {
  word_of_node_.assign(children_count_.size(), 0);
  std::uint32_t words = 0;
  for (std::size_t i = 0; i < children_count_.size(); ++i) {
    if (children_count_[i] == 0) word_of_node_[i] = words++;
  }
  return words;
}

std::uint32_t VocabularyTree::Quantize(const Descriptor& descriptor) const {
  GLAM_CHECK(!children_count_.empty(), "Quantize on an empty vocabulary");
  std::uint32_t node = 0;
  while (children_count_[node] != 0) {
    const std::uint32_t begin = children_begin_[node];
    const std::uint32_t end = begin + children_count_[node];
    std::uint32_t best = begin;
    std::uint32_t best_d = SquaredDistance(descriptor.data(), centre(begin));
    for (std::uint32_t c = begin + 1; c < end; ++c) {
      const std::uint32_t d = SquaredDistance(descriptor.data(), centre(c));
      if (d < best_d) best_d = d, best = c;
    }
    node = best;
  }
  return word_of_node_[node];
}

std::vector<std::uint32_t> VocabularyTree::Quantize(std::span<const Descriptor> descriptors) const {
  std::vector<std::uint32_t> words(descriptors.size());
  auto run = [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) words[i] = Quantize(descriptors[i]);
  };
  // Small batches (one submap) stay on the calling thread; training batches use all cores.
  constexpr std::size_t kParallelFrom = 20000;
  if (descriptors.size() >= kParallelFrom) {
    cv::parallel_for_(cv::Range(0, static_cast<int>(descriptors.size())), run, 16);
  } else {
    run(cv::Range(0, static_cast<int>(descriptors.size())));
  }
  return words;
}

void VocabularyTree::Save(const std::filesystem::path& path) const {
  GLAM_CHECK(!children_count_.empty(), "Save of an empty vocabulary");
  BinaryWriter w(path, kMagic, kFormatVersion);
  w.Write<std::uint32_t>(static_cast<std::uint32_t>(branching_));
  w.Write<std::uint32_t>(static_cast<std::uint32_t>(depth_));
  w.Write<std::uint32_t>(static_cast<std::uint32_t>(kmeans_iterations_));
  w.Write<std::uint64_t>(seed_);
  w.Write<std::uint64_t>(training_documents_);
  w.Write<std::uint64_t>(training_descriptors_);
  w.WriteString(description_);
  w.Write<std::uint32_t>(static_cast<std::uint32_t>(children_count_.size()));
  w.WriteArray(children_begin_.data(), children_begin_.size());
  w.WriteArray(children_count_.data(), children_count_.size());
  w.WriteArray(centres_.data(), centres_.size());
  w.Write<std::uint32_t>(static_cast<std::uint32_t>(idf_.size()));
  w.WriteArray(idf_.data(), idf_.size());
  w.Finish();
}

VocabularyTree VocabularyTree::Parse(BinaryReader& r, std::string_view name) {
  auto corrupt = [&](const std::string& what) {
    return InputError(fmt::format("{} is not a valid vocabulary: {}", name, what));
  };
  VocabularyTree t;
  const auto branching = r.Read<std::uint32_t>();
  const auto depth = r.Read<std::uint32_t>();
  const auto iterations = r.Read<std::uint32_t>();
  if (branching < 2 || branching > kMaxBranching) throw corrupt(fmt::format("branching {}", branching));
  if (depth < 1 || depth > kMaxDepth) throw corrupt(fmt::format("depth {}", depth));
  t.branching_ = static_cast<int>(branching);
  t.depth_ = static_cast<int>(depth);
  t.kmeans_iterations_ = static_cast<int>(std::min<std::uint32_t>(iterations, 1u << 30));
  t.seed_ = r.Read<std::uint64_t>();
  t.training_documents_ = r.Read<std::uint64_t>();
  t.training_descriptors_ = r.Read<std::uint64_t>();
  t.description_ = r.ReadString();

  const std::uint32_t num_nodes = r.ReadCount(kMaxNodes);
  if (num_nodes == 0) throw corrupt("no nodes");
  t.children_begin_.resize(num_nodes);
  t.children_count_.resize(num_nodes);
  t.centres_.resize(std::size_t{num_nodes} * kDescriptorSize);
  r.ReadArray(t.children_begin_.data(), num_nodes);
  r.ReadArray(t.children_count_.data(), num_nodes);
  r.ReadArray(t.centres_.data(), t.centres_.size());
  const std::uint32_t num_words = r.ReadCount(kMaxNodes);
  t.idf_.resize(num_words);
  r.ReadArray(t.idf_.data(), num_words);

  // Structure: breadth-first, every node but the root is the child of exactly one earlier node,
  // no node deeper than `depth`. This also guarantees that Quantize() terminates.
  std::vector<std::uint8_t> level(num_nodes, 0);
  std::uint64_t next_child = 1;
  std::uint32_t leaves = 0;
  for (std::uint32_t i = 0; i < num_nodes; ++i) {
    const std::uint32_t count = t.children_count_[i];
    if (count == 0) {
      ++leaves;
      continue;
    }
    if (count > branching) throw corrupt(fmt::format("node {} has {} children, branching is {}", i, count, branching));
    if (t.children_begin_[i] != next_child || next_child + count > num_nodes) {
      throw corrupt(fmt::format("node {} has children at {}..{} of {} nodes", i, t.children_begin_[i],
                                std::uint64_t{t.children_begin_[i]} + count, num_nodes));
    }
    if (level[i] + 1u > depth) throw corrupt(fmt::format("node {} is deeper than depth {}", i, depth));
    for (std::uint32_t c = 0; c < count; ++c) level[next_child + c] = static_cast<std::uint8_t>(level[i] + 1);
    next_child += count;
  }
  if (next_child != num_nodes) throw corrupt(fmt::format("{} of {} nodes are unreachable", num_nodes - next_child, num_nodes));
  if (leaves != num_words) {
    throw corrupt(fmt::format("{} leaves but {} idf weights", leaves, num_words));
  }
  for (std::uint32_t w = 0; w < num_words; ++w) {
    if (!std::isfinite(t.idf_[w]) || t.idf_[w] < 0) throw corrupt(fmt::format("idf of word {} is {}", w, t.idf_[w]));
  }
  t.ComputeWordsOfNodes();
  return t;
}

VocabularyTree VocabularyTree::Load(const std::filesystem::path& path) {
  if (!std::filesystem::exists(path)) {
    throw InputError(fmt::format("vocabulary file {} does not exist", path.string()));
  }
  BinaryReader reader(path, kMagic, kFormatVersion);
  return Parse(reader, path.string());
}

VocabularyTree VocabularyTree::FromBytes(std::span<const std::uint8_t> bytes, std::string_view name) {
  BinaryReader reader(bytes, name, kMagic, kFormatVersion);
  return Parse(reader, name);
}

const VocabularyTree& VocabularyTree::Default() {
  static const VocabularyTree tree = FromBytes(DefaultVocabularyBytes(), "the built-in default vocabulary");
  return tree;
}

}  // namespace glam
