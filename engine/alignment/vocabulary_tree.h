// Vocabulary tree (Nistér & Stewénius 2006): hierarchical k-means over SIFT descriptors that
// turns each descriptor into a visual word, so that thread 2 can find submaps that see the same
// ground by comparing bags of words through an inverted index (submap_database.h) instead of
// matching every pair of submaps (quadratic in their number).
//
// Why these choices:
//  * It works on glam::Descriptor (uint8 RootSIFT, QuantizeDescriptor) because that is what
//    landmarks store; training on anything else (float SIFT, plain SIFT) would put the words
//    in the wrong places.
//  * Centres are stored as uint8 too: a 10^4-word tree is ~1.4 MB (instead of ~5.7 MB as
//    float), loads in milliseconds and descends with integer arithmetic. Training assigns
//    descriptors to children with the rounded centres, so training and Quantize() agree.
//  * The idf weight of every word is computed once, at training time, over the training
//    documents (one document = one training frame). A database therefore never re-weights its
//    stored vectors when submaps are added, and scores are comparable over the whole flight.
//  * Descent is greedy (nearest centre per level, L2), which costs branching x depth distance
//    computations (40 for the default 10 x 4) per descriptor.
//
// File format (little-endian, binary_io.h), version 1:
//   magic "GLAMVOCT", uint32 version
//   uint32 branching, uint32 depth, uint32 kmeans_iterations, uint64 seed,
//   uint64 training_documents, uint64 training_descriptors, string description
//   uint32 num_nodes, uint32 children_begin[num_nodes], uint32 children_count[num_nodes],
//   uint8 centres[num_nodes * 128]        (nodes in breadth-first order, node 0 = root)
//   uint32 num_words, float idf[num_words] (words = leaves in breadth-first order)
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "engine/map/landmark.h"

namespace glam {

class BinaryReader;

struct VocabularyTreeOptions {
  int branching = 10;  // k of every k-means
  int depth = 4;       // levels below the root: up to branching^depth words
  int kmeans_iterations = 10;
  // Clustering uses at most this many descriptors (a deterministic random subset; every
  // descriptor still counts for the idf weights). Bounds training memory: the root k-means
  // holds them as float (512 bytes each).
  int max_training_descriptors = 400000;
  std::uint64_t seed = 1;  // k-means++ seeding and subsampling; same seed + data = same tree

  void Check() const;  // throws InputError
};

class VocabularyTree {
 public:
  static constexpr std::uint32_t kFormatVersion = 1;

  // Hierarchical k-means over all descriptors of `documents`; a document is one training
  // image (its descriptors), used for the idf weights. Throws InputError when there are fewer
  // descriptors than `branching` (nothing to cluster). Logs progress per level.
  static VocabularyTree Train(const std::vector<std::vector<Descriptor>>& documents,
                              const VocabularyTreeOptions& options);

  // Word id in [0, num_words()).
  std::uint32_t Quantize(const Descriptor& descriptor) const;
  std::vector<std::uint32_t> Quantize(std::span<const Descriptor> descriptors) const;

  // log(N_docs / n_docs_containing_word) over the training documents (0 for a word found in
  // every document: it tells nothing apart).
  double idf(std::uint32_t word) const { return idf_[word]; }
  const std::vector<float>& idf_weights() const { return idf_; }
  int num_words() const { return static_cast<int>(idf_.size()); }
  int num_nodes() const { return static_cast<int>(children_count_.size()); }
  int branching() const { return branching_; }
  int depth() const { return depth_; }
  int kmeans_iterations() const { return kmeans_iterations_; }
  std::uint64_t seed() const { return seed_; }
  std::uint64_t training_documents() const { return training_documents_; }
  std::uint64_t training_descriptors() const { return training_descriptors_; }
  // Free text saved with the tree (e.g. what it was trained on).
  const std::string& description() const { return description_; }
  void set_description(std::string description) { description_ = std::move(description); }

  // Atomic (written to a temporary file, then renamed). Throws EnvironmentError on I/O failure.
  void Save(const std::filesystem::path& path) const;
  // Throws InputError with a message naming the file for a missing file, a foreign magic, an
  // unknown version, truncation or inconsistent contents.
  static VocabularyTree Load(const std::filesystem::path& path);
  // The same format from memory (the embedded default); `name` appears in error messages.
  static VocabularyTree FromBytes(std::span<const std::uint8_t> bytes, std::string_view name);

  // The vocabulary shipped with GLAM (data/vocabulary/, embedded in the library at build time,
  // see data/vocabulary/README.md): available from any working directory and after install.
  // Parsed once, on first use; thread-safe.
  static const VocabularyTree& Default();

 private:
  static VocabularyTree Parse(BinaryReader& reader, std::string_view name);
  std::uint32_t ComputeWordsOfNodes();  // returns the number of words (leaves)
  const std::uint8_t* centre(std::uint32_t node) const { return &centres_[std::size_t{node} * kDescriptorSize]; }

  int branching_ = 0;
  int depth_ = 0;
  int kmeans_iterations_ = 0;
  std::uint64_t seed_ = 0;
  std::uint64_t training_documents_ = 0;
  std::uint64_t training_descriptors_ = 0;
  std::string description_;
  // Breadth-first tree: the children of node i are children_begin_[i] .. + children_count_[i].
  std::vector<std::uint32_t> children_begin_;
  std::vector<std::uint32_t> children_count_;
  std::vector<std::uint8_t> centres_;        // num_nodes x 128
  std::vector<std::uint32_t> word_of_node_;  // leaves only (derived, not stored)
  std::vector<float> idf_;
};

}  // namespace glam
