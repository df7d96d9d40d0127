// Vocabulary tree: training puts known clusters into their own words, real SIFT descriptors of
// the same scene point keep their word under a small viewpoint change far more often than
// chance (with the shipped default vocabulary), files round-trip exactly, and corrupt files are
// rejected with InputError; `glam vocab train | info` work on images and reject bad input.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <random>
#include <set>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "engine/alignment/default_vocabulary.h"
#include "engine/alignment/vocabulary_tree.h"
#include "engine/core/error.h"
#include "engine/features/sift_extractor.h"
#include "engine/submap/frame_record.h"

namespace glam {
namespace {

namespace fs = std::filesystem;

struct Clusters {
  std::vector<Descriptor> centres;
  Descriptor Sample(int cluster, std::mt19937& rng, double sigma = 4.0) const {
    std::normal_distribution<double> noise(0, sigma);
    Descriptor d;
    for (int i = 0; i < kDescriptorSize; ++i) {
      d[i] = static_cast<std::uint8_t>(std::clamp(std::lround(centres[cluster][i] + noise(rng)), 0L, 255L));
    }
    return d;
  }
};

Clusters MakeClusters(int count, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> value(0, 255);
  Clusters c;
  for (int k = 0; k < count; ++k) {
    Descriptor d;
    for (auto& v : d) v = static_cast<std::uint8_t>(value(rng));
    c.centres.push_back(d);
  }
  return c;
}

// One document per cluster, `per_cluster` noisy samples each.
std::vector<std::vector<Descriptor>> ClusterDocuments(const Clusters& clusters, int per_cluster, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<std::vector<Descriptor>> docs(clusters.centres.size());
  for (std::size_t k = 0; k < docs.size(); ++k) {
    for (int i = 0; i < per_cluster; ++i) docs[k].push_back(clusters.Sample(static_cast<int>(k), rng));
  }
  return docs;
}

VocabularyTreeOptions SmallOptions() {
  VocabularyTreeOptions o;
  o.branching = 4;
  o.depth = 3;
  o.seed = 7;
  return o;
}

fs::path TempPath(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "glam_vocabulary_test";
  fs::create_directories(dir);
  return dir / (name + "_" + std::to_string(::getpid()));
}

std::vector<std::uint8_t> ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void WriteBytes(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

TEST(VocabularyTreeTest, KnownClustersGetTheirOwnWords) {
  constexpr int kClusters = 12;
  const Clusters clusters = MakeClusters(kClusters, 11);
  const VocabularyTree tree = VocabularyTree::Train(ClusterDocuments(clusters, 60, 12), SmallOptions());
  ASSERT_GE(tree.num_words(), kClusters);
  ASSERT_LE(tree.num_words(), 64);

  // Fresh samples (not used for training): no word may collect two clusters.
  std::mt19937 rng(99);
  std::map<std::uint32_t, std::set<int>> clusters_of_word;
  for (int k = 0; k < kClusters; ++k) {
    for (int i = 0; i < 100; ++i) {
      const std::uint32_t w = tree.Quantize(clusters.Sample(k, rng));
      ASSERT_LT(w, static_cast<std::uint32_t>(tree.num_words()));
      clusters_of_word[w].insert(k);
    }
  }
  std::set<int> seen;
  for (const auto& [word, ks] : clusters_of_word) {
    EXPECT_EQ(ks.size(), 1u) << "word " << word << " holds " << ks.size() << " clusters";
    seen.insert(ks.begin(), ks.end());
    // Each word occurs in exactly one of the 12 training documents.
    EXPECT_NEAR(tree.idf(word), std::log(12.0), 1e-5);
  }
  EXPECT_EQ(seen.size(), static_cast<std::size_t>(kClusters));
}

TEST(VocabularyTreeTest, TrainingIsDeterministicAndSubsamples) {
  const Clusters clusters = MakeClusters(8, 21);
  const auto docs = ClusterDocuments(clusters, 50, 22);
  VocabularyTreeOptions options = SmallOptions();
  options.max_training_descriptors = 200;  // of 400: clustering on a subset
  const VocabularyTree a = VocabularyTree::Train(docs, options);
  const VocabularyTree b = VocabularyTree::Train(docs, options);
  EXPECT_EQ(a.training_descriptors(), 200u);
  EXPECT_EQ(a.training_documents(), 8u);
  ASSERT_EQ(a.num_words(), b.num_words());
  std::mt19937 rng(5);
  for (int i = 0; i < 400; ++i) {
    const Descriptor d = clusters.Sample(i % 8, rng, 20.0);
    EXPECT_EQ(a.Quantize(d), b.Quantize(d));
  }
  for (int w = 0; w < a.num_words(); ++w) EXPECT_EQ(a.idf(w), b.idf(w));
}

TEST(VocabularyTreeTest, OptionsAndInputAreChecked) {
  VocabularyTreeOptions o;
  EXPECT_NO_THROW(o.Check());
  o.branching = 1;
  EXPECT_THROW(o.Check(), InputError);
  o = {};
  o.depth = 0;
  EXPECT_THROW(o.Check(), InputError);
  o = {};
  o.branching = 64;
  o.depth = 8;  // 2.8e14 words
  EXPECT_THROW(o.Check(), InputError);
  o = {};
  o.kmeans_iterations = 0;
  EXPECT_THROW(o.Check(), InputError);
  // Fewer descriptors than branching: nothing to cluster.
  EXPECT_THROW(VocabularyTree::Train({{Descriptor{}, Descriptor{}}}, VocabularyTreeOptions{}), InputError);
}

TEST(VocabularyTreeTest, SaveLoadRoundTripQuantisesIdentically) {
  const Clusters clusters = MakeClusters(10, 31);
  VocabularyTree tree = VocabularyTree::Train(ClusterDocuments(clusters, 40, 32), SmallOptions());
  tree.set_description("round trip test");
  const fs::path path = TempPath("roundtrip");
  tree.Save(path);
  EXPECT_FALSE(fs::exists(path.string() + ".tmp"));
  const VocabularyTree loaded = VocabularyTree::Load(path);
  const VocabularyTree from_bytes = VocabularyTree::FromBytes(ReadBytes(path), "bytes");
  for (const VocabularyTree* t : {&loaded, &from_bytes}) {
    EXPECT_EQ(t->num_words(), tree.num_words());
    EXPECT_EQ(t->num_nodes(), tree.num_nodes());
    EXPECT_EQ(t->branching(), 4);
    EXPECT_EQ(t->depth(), 3);
    EXPECT_EQ(t->seed(), 7u);
    EXPECT_EQ(t->training_documents(), 10u);
    EXPECT_EQ(t->training_descriptors(), 400u);
    EXPECT_EQ(t->description(), "round trip test");
    for (int w = 0; w < tree.num_words(); ++w) EXPECT_EQ(t->idf(w), tree.idf(w));
  }
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> value(0, 255);
  std::vector<Descriptor> probes;
  for (int i = 0; i < 500; ++i) probes.push_back(clusters.Sample(i % 10, rng, 30.0));
  for (int i = 0; i < 500; ++i) {
    Descriptor d;
    for (auto& v : d) v = static_cast<std::uint8_t>(value(rng));
    probes.push_back(d);
  }
  EXPECT_EQ(loaded.Quantize(probes), tree.Quantize(probes));
  EXPECT_EQ(from_bytes.Quantize(probes), tree.Quantize(probes));
  fs::remove(path);
}

// Header layout (see vocabulary_tree.h): magic 8, version 4, branching/depth/iterations 3x4,
// seed/documents/descriptors 3x8, description (4 + length), num_nodes 4.
constexpr std::size_t kVersionOffset = 8;
std::size_t NumNodesOffset(std::size_t description_length) { return 8 + 4 + 12 + 24 + 4 + description_length; }

template <typename T>
void Poke(std::vector<std::uint8_t>& bytes, std::size_t offset, T value) {
  std::memcpy(bytes.data() + offset, &value, sizeof(T));
}

void ExpectLoadError(const fs::path& path, const std::vector<std::uint8_t>& bytes, const std::string& needle) {
  WriteBytes(path, bytes);
  try {
    VocabularyTree::Load(path);
    ADD_FAILURE() << "expected InputError containing '" << needle << "'";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
  }
  EXPECT_THROW(VocabularyTree::FromBytes(bytes, "bytes"), InputError);
}

TEST(VocabularyTreeTest, LoadRejectsBadFiles) {
  const fs::path missing = TempPath("missing");
  try {
    VocabularyTree::Load(missing);
    ADD_FAILURE() << "missing file loaded";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }

  VocabularyTree tree = VocabularyTree::Train(ClusterDocuments(MakeClusters(6, 41), 30, 42), SmallOptions());
  tree.set_description("x");
  const fs::path good = TempPath("good");
  tree.Save(good);
  const std::vector<std::uint8_t> bytes = ReadBytes(good);
  const fs::path bad = TempPath("bad");

  std::vector<std::uint8_t> b = bytes;
  std::memcpy(b.data(), "NOTVOCAB", 8);
  ExpectLoadError(bad, b, "is not a GLAMVOCT file");

  b = bytes;
  Poke<std::uint32_t>(b, kVersionOffset, 99);
  ExpectLoadError(bad, b, "format version 99");

  for (std::size_t cut : {std::size_t{4}, std::size_t{20}, bytes.size() / 3, bytes.size() / 2, bytes.size() - 1}) {
    ExpectLoadError(bad, std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(cut)),
                    cut < 8 ? "is not a" : "truncated");
  }

  // Inconsistent sizes: one idf weight fewer than there are leaves (and the file one float shorter).
  const auto num_words = static_cast<std::uint32_t>(tree.num_words());
  b = bytes;
  b.resize(b.size() - 4);
  Poke<std::uint32_t>(b, b.size() - 4 * (num_words - 1) - 4, num_words - 1);
  ExpectLoadError(bad, b, "leaves but");

  // A node with more children than the branching factor.
  const std::size_t nodes_at = NumNodesOffset(1);
  std::uint32_t num_nodes;
  std::memcpy(&num_nodes, bytes.data() + nodes_at, 4);
  ASSERT_EQ(num_nodes, static_cast<std::uint32_t>(tree.num_nodes()));
  b = bytes;
  Poke<std::uint32_t>(b, nodes_at + 4 + 4 * num_nodes, 9);  // children_count[0]
  ExpectLoadError(bad, b, "children");

  // Children that point back at the root (would loop forever).
  b = bytes;
  Poke<std::uint32_t>(b, nodes_at + 4, 0);  // children_begin[0]
  ExpectLoadError(bad, b, "children");

  // Absurd node count.
  b = bytes;
  Poke<std::uint32_t>(b, nodes_at, 0xFFFFFFFFu);
  ExpectLoadError(bad, b, "exceeds");

  fs::remove(good);
  fs::remove(bad);
}

// A textured image with detail at several scales (deterministic), like aerial ground texture.
cv::Mat TextureImage(int width, int height, std::uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat sum(height, width, CV_32F, cv::Scalar(0));
  for (int cell : {3, 7, 17, 41}) {
    cv::Mat small((height + cell - 1) / cell, (width + cell - 1) / cell, CV_32F);
    rng.fill(small, cv::RNG::UNIFORM, 0, 1);
    cv::Mat up;
    cv::resize(small, up, cv::Size(width, height), 0, 0, cv::INTER_CUBIC);
    sum += up;
  }
  cv::Mat grey;
  cv::normalize(sum, sum, 0, 255, cv::NORM_MINMAX);
  sum.convertTo(grey, CV_8U);
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

TEST(VocabularyTreeTest, DefaultVocabularyKeepsWordsUnderSmallViewpointChange) {
  const VocabularyTree& vocab = VocabularyTree::Default();
  ASSERT_GE(vocab.num_words(), 1000);
  EXPECT_EQ(&vocab, &VocabularyTree::Default());
  EXPECT_FALSE(vocab.description().empty());

  // The same scene seen after a 3 degree rotation, 2 % zoom and a shift, with pixel noise.
  const cv::Mat image = TextureImage(640, 360, 17);
  const cv::Mat warp = cv::getRotationMatrix2D(cv::Point2f(320, 180), 3.0, 1.02) +
                       (cv::Mat_<double>(2, 3) << 0, 0, 4.5, 0, 0, -2.5);
  cv::Mat moved;
  cv::warpAffine(image, moved, warp, image.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  cv::Mat noise(moved.size(), CV_8UC3);
  cv::randn(noise, cv::Scalar::all(0), cv::Scalar::all(2));
  moved += noise;

  const SiftExtractor sift;
  const Features fa = sift.Extract(image);
  const Features fb = sift.Extract(moved);
  const CompactFeatures a = CompactFeatures::From(fa);
  const CompactFeatures b = CompactFeatures::From(fb);
  ASSERT_GT(a.size(), 300u);
  const std::vector<std::uint32_t> wa = vocab.Quantize(a.descriptors);
  const std::vector<std::uint32_t> wb = vocab.Quantize(b.descriptors);

  // Pairs by geometry: the keypoint of b at the warped position of a keypoint of a.
  int pairs = 0;
  int same = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const cv::Point2f& p = fa.keypoints[i].pt;
    const cv::Point2d q(warp.at<double>(0, 0) * p.x + warp.at<double>(0, 1) * p.y + warp.at<double>(0, 2),
                        warp.at<double>(1, 0) * p.x + warp.at<double>(1, 1) * p.y + warp.at<double>(1, 2));
    int best = -1;
    double best_d = 0.7;
    for (std::size_t j = 0; j < b.size(); ++j) {
      const double d = std::hypot(fb.keypoints[j].pt.x - q.x, fb.keypoints[j].pt.y - q.y);
      const double size_ratio = fb.keypoints[j].size / (1.02 * fa.keypoints[i].size);
      if (d < best_d && size_ratio > 0.8 && size_ratio < 1.25) best_d = d, best = static_cast<int>(j);
    }
    if (best < 0) continue;
    ++pairs;
    same += wa[i] == wb[best] ? 1 : 0;
  }
  // Chance that two unrelated descriptors of this scene share a word.
  std::map<std::uint32_t, int> histogram;
  for (std::uint32_t w : wa) ++histogram[w];
  double chance = 0;
  for (const auto& [w, n] : histogram) chance += std::pow(static_cast<double>(n) / wa.size(), 2);
  const double rate = static_cast<double>(same) / std::max(1, pairs);
  std::cout << "default vocabulary: " << pairs << " geometric pairs, same word " << 100 * rate
            << " %, chance " << 100 * chance << " %, " << histogram.size() << " distinct words of "
            << vocab.num_words() << "\n";
  ASSERT_GT(pairs, 100);
  EXPECT_GT(rate, 10 * chance);
  EXPECT_GT(rate, 0.3);
}

// The shipped file survives Save/Load unchanged; prints the costs the aligner pays (not asserted).
TEST(VocabularyTreeTest, DefaultVocabularyRoundTripsAndReportsCosts) {
  using Clock = std::chrono::steady_clock;
  auto ms = [](Clock::time_point since) { return std::chrono::duration<double, std::milli>(Clock::now() - since).count(); };
  auto start = Clock::now();
  const VocabularyTree embedded = VocabularyTree::FromBytes(DefaultVocabularyBytes(), "embedded");
  const double parse_ms = ms(start);
  const fs::path path = TempPath("default");
  VocabularyTree::Default().Save(path);
  start = Clock::now();
  const VocabularyTree loaded = VocabularyTree::Load(path);
  const double load_ms = ms(start);
  EXPECT_EQ(fs::file_size(path), DefaultVocabularyBytes().size());
  EXPECT_EQ(ReadBytes(path), std::vector<std::uint8_t>(DefaultVocabularyBytes().begin(), DefaultVocabularyBytes().end()));

  const cv::Mat image = TextureImage(1280, 720, 23);
  const CompactFeatures features = CompactFeatures::From(SiftExtractor().Extract(image));
  ASSERT_GT(features.size(), 1000u);
  start = Clock::now();
  const std::vector<std::uint32_t> words = VocabularyTree::Default().Quantize(features.descriptors);
  const double quantize_ms = ms(start);
  EXPECT_EQ(loaded.Quantize(features.descriptors), words);
  EXPECT_EQ(embedded.Quantize(features.descriptors), words);
  std::cout << "default vocabulary: " << DefaultVocabularyBytes().size() << " bytes, " << embedded.num_words()
            << " words; parse (embedded) " << parse_ms << " ms, Load (file) " << load_ms << " ms; Quantize "
            << 1000.0 * quantize_ms / static_cast<double>(features.size()) << " ms per 1000 descriptors ("
            << features.size() << " descriptors)\n";
  fs::remove(path);
}

#ifdef GLAM_BIN
int RunGlam(const std::string& args, const fs::path& output) {
  const std::string command = std::string("'") + GLAM_BIN + "' --log-level warn " + args + " >'" +
                              output.string() + "' 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(VocabularyTreeTest, CliTrainsFromImagesAndReportsInfo) {
  const fs::path dir = TempPath("cli");
  fs::create_directories(dir / "folder");
  for (int i = 0; i < 3; ++i) {
    cv::imwrite((dir / "folder" / ("img" + std::to_string(i) + ".png")).string(), TextureImage(320, 240, 100 + i));
  }
  cv::imwrite((dir / "single.png").string(), TextureImage(320, 240, 200));
  const fs::path out = dir / "out" / "vocab.bin";
  const fs::path log = dir / "log.txt";
  ASSERT_EQ(RunGlam(fmt::format("vocab train --out '{}' --branching 4 --depth 2 --seed 3 '{}' '{}'", out.string(),
                                (dir / "folder").string(), (dir / "single.png").string()),
                    log),
            0)
      << ReadText(log);
  const VocabularyTree tree = VocabularyTree::Load(out);
  EXPECT_EQ(tree.training_documents(), 4u);  // three folder images + one image file
  EXPECT_EQ(tree.branching(), 4);
  EXPECT_EQ(tree.depth(), 2);
  EXPECT_EQ(tree.seed(), 3u);
  EXPECT_GE(tree.num_words(), 10);

  ASSERT_EQ(RunGlam(fmt::format("vocab info '{}'", out.string()), log), 0) << ReadText(log);
  const std::string info = ReadText(log);
  EXPECT_NE(info.find(fmt::format("words: {}", tree.num_words())), std::string::npos) << info;
  EXPECT_NE(info.find("training documents: 4"), std::string::npos) << info;

  // Bad input is a user error (exit code 2) with a message naming it.
  EXPECT_EQ(RunGlam(fmt::format("vocab train --out '{}' '{}'", out.string(), (dir / "nope.mp4").string()), log), 2);
  EXPECT_NE(ReadText(log).find("nope.mp4"), std::string::npos) << ReadText(log);
  EXPECT_EQ(RunGlam(fmt::format("vocab info '{}'", (dir / "single.png").string()), log), 2);
  EXPECT_NE(ReadText(log).find("is not a GLAMVOCT file"), std::string::npos) << ReadText(log);
  EXPECT_EQ(RunGlam(fmt::format("vocab train --out '{}' --depth 0 '{}'", out.string(), (dir / "single.png").string()), log), 2);
  fs::remove_all(dir);
}
#endif

}  // namespace
}  // namespace glam
