// Inverted-index database: tf-idf L1 scores against hand-computed values, ranking, exclusion,
// max_results, a query that only visits the postings of its own words, and retrieval with real
// SIFT from a synthetic flight (rendered here with `glam synth`) through the DEFAULT vocabulary:
// frames flown over the start again at the end of a loop find the start's submap first.
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "engine/alignment/submap_database.h"
#include "engine/alignment/vocabulary_tree.h"
#include "engine/core/error.h"
#include "engine/features/sift_extractor.h"
#include "engine/submap/frame_record.h"
#include "engine/video/frame_source.h"

namespace glam {
namespace {

namespace fs = std::filesystem;
using Words = std::vector<std::uint32_t>;

TEST(SubmapDatabaseTest, ScoresAreTfIdfL1AgainstHandComputedValues) {
  // idf: word 0 -> 1, word 1 -> 1, word 2 -> 2, word 3 -> 0 (in every training document).
  SubmapDatabase db(std::vector<float>{1, 1, 2, 0});
  const Words a = {0, 0, 1};     // weights 2, 1       -> (2/3, 1/3, 0)
  const Words b = {1, 2, 3, 3};  // weights 1, 2, 0    -> (0, 1/3, 2/3)
  db.Add(10, a);
  db.Add(20, b);
  EXPECT_EQ(db.size(), 2u);

  // Query (1/2, 1/2, 0): a = min(2/3,1/2) + min(1/3,1/2) = 5/6; b = min(1/2,1/3) = 1/3.
  const auto r = db.Query(Words{0, 1}, 10);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].submap_id, 10u);
  EXPECT_NEAR(r[0].score, 5.0 / 6.0, 1e-6);
  EXPECT_EQ(r[1].submap_id, 20u);
  EXPECT_NEAR(r[1].score, 1.0 / 3.0, 1e-6);

  // A bag against itself scores 1, order of words does not matter.
  const auto self = db.Query(Words{3, 2, 3, 1}, 1);
  ASSERT_EQ(self.size(), 1u);
  EXPECT_EQ(self[0].submap_id, 20u);
  EXPECT_NEAR(self[0].score, 1.0, 1e-6);

  // Only zero-idf words, or words nobody has: nothing is returned.
  EXPECT_TRUE(db.Query(Words{3, 3}, 10).empty());
  SubmapDatabase plain;  // no vocabulary: every word weighs 1
  plain.Add(1, Words{5, 6});
  EXPECT_TRUE(plain.Query(Words{7, 8, 1000}, 10).empty());
  EXPECT_NEAR(plain.Query(Words{5, 6}, 10).at(0).score, 1.0, 1e-6);
  EXPECT_NEAR(plain.Query(Words{5, 9}, 10).at(0).score, 0.5, 1e-6);
}

TEST(SubmapDatabaseTest, RankingExclusionAndMaxResults) {
  SubmapDatabase db;
  // Submap i shares words 0..(10 - i) with the query {0..9}: more shared words, higher score.
  for (std::uint32_t id = 0; id < 8; ++id) {
    Words words;
    for (std::uint32_t w = 0; w < 10 - id; ++w) words.push_back(w);
    for (std::uint32_t w = 0; w < id; ++w) words.push_back(100 + w);  // same length, unshared
    db.Add(id, words);
  }
  Words query(10);
  std::iota(query.begin(), query.end(), 0u);
  const auto all = db.Query(query, -1);
  ASSERT_EQ(all.size(), 8u);
  for (std::uint32_t i = 0; i < 8; ++i) {
    EXPECT_EQ(all[i].submap_id, i);
    EXPECT_NEAR(all[i].score, (10.0 - i) / 10.0, 1e-6);
  }
  const auto top3 = db.Query(query, 3);
  ASSERT_EQ(top3.size(), 3u);
  EXPECT_EQ(top3[2].submap_id, 2u);
  EXPECT_TRUE(db.Query(query, 0).empty());

  const auto excluded = db.Query(query, 3, [](std::uint32_t id) { return id == 0 || id == 2; });
  ASSERT_EQ(excluded.size(), 3u);
  EXPECT_EQ(excluded[0].submap_id, 1u);
  EXPECT_EQ(excluded[1].submap_id, 3u);
  EXPECT_EQ(excluded[2].submap_id, 4u);

  EXPECT_TRUE(db.contains(7));
  EXPECT_FALSE(db.contains(8));
  EXPECT_GT(db.MemoryBytes(), 8u * 10u * 8u);  // at least the postings themselves
}

TEST(SubmapDatabaseTest, QueryVisitsOnlyThePostingsOfItsWords) {
  SubmapDatabase db(std::vector<float>(2000, 1.0f));
  // 100 submaps on words 0..199 (two groups of words), 400 submaps on words 1000..1999.
  std::size_t expected_postings = 0;
  for (std::uint32_t id = 0; id < 500; ++id) {
    Words words;
    if (id < 100) {
      for (std::uint32_t w = (id % 2) * 100; w < (id % 2) * 100 + 100; ++w) words.push_back(w);
      if (id % 2 == 0) expected_postings += 10;  // the query's words 0..9, once each
    } else {
      for (std::uint32_t w = 1000 + id % 7; w < 2000; w += 7) words.push_back(w);
    }
    db.Add(id, words);
  }
  DatabaseQueryStats stats;
  const auto r = db.Query(Words{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}, -1, {}, &stats);
  EXPECT_EQ(stats.query_words, 10u);
  EXPECT_EQ(stats.postings_visited, expected_postings);
  EXPECT_EQ(stats.submaps_scored, 50u);  // the even ids below 100, and nothing else
  ASSERT_EQ(r.size(), 50u);
  for (const DatabaseMatch& m : r) {
    EXPECT_LT(m.submap_id, 100u);
    EXPECT_EQ(m.submap_id % 2, 0u);
    EXPECT_NEAR(m.score, 0.1, 1e-6);
  }
}

// 200 submaps x 3000 words with the default vocabulary's idf: a perturbed copy of one submap's
// bag finds it first. Prints build / query time and memory for the report (not asserted).
TEST(SubmapDatabaseTest, CostsAt200SubmapsOf3000Words) {
  using Clock = std::chrono::steady_clock;
  auto ms = [](Clock::time_point since) { return std::chrono::duration<double, std::milli>(Clock::now() - since).count(); };
  const VocabularyTree& vocab = VocabularyTree::Default();
  std::mt19937 rng(4);
  std::uniform_int_distribution<std::uint32_t> word(0, static_cast<std::uint32_t>(vocab.num_words() - 1));
  std::vector<Words> bags(200, Words(3000));
  for (Words& bag : bags) {
    for (auto& w : bag) w = word(rng);
  }
  SubmapDatabase db(vocab);
  auto start = Clock::now();
  for (std::uint32_t id = 0; id < bags.size(); ++id) db.Add(id, bags[id]);
  const double add_ms = ms(start);

  constexpr int kQueries = 20;
  double query_ms = 0;
  DatabaseQueryStats stats;
  for (int q = 0; q < kQueries; ++q) {
    const std::uint32_t target = static_cast<std::uint32_t>(q * 9 + 5);
    Words query = bags[target];
    for (std::size_t i = 0; i < query.size(); i += 3) query[i] = word(rng);  // a third replaced
    start = Clock::now();
    const auto ranked = db.Query(query, 10, {}, &stats);
    query_ms += ms(start);
    ASSERT_FALSE(ranked.empty());
    EXPECT_EQ(ranked[0].submap_id, target);
  }
  std::cout << "database 200 x 3000 words: Add total " << add_ms << " ms, Query " << query_ms / kQueries
            << " ms (" << stats.postings_visited << " postings, " << stats.submaps_scored
            << " submaps scored), memory " << db.MemoryBytes() / 1024.0 << " KiB\n";
}

#ifdef GLAM_BIN
// Camera centres (world_from_cam translations) of a TUM trajectory file, in line order.
std::vector<Eigen::Vector3d> CameraCentres(const fs::path& tum) {
  std::ifstream in(tum);
  std::vector<Eigen::Vector3d> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double t, x, y, z;
    if (fields >> t >> x >> y >> z) out.emplace_back(x, y, z);
  }
  return out;
}

// Descriptors of the given frames of a video (SIFT as `glam map` extracts them).
std::vector<std::vector<Descriptor>> FrameDescriptors(const fs::path& video) {
  auto source = OpenFrameSource(video);
  const SiftExtractor sift;
  std::vector<std::vector<Descriptor>> out;
  while (auto frame = source->Next()) out.push_back(CompactFeatures::From(sift.Extract(frame->bgr)).descriptors);
  return out;
}

TEST(SubmapDatabaseTest, LoopEndRetrievesTheStartWithTheDefaultVocabulary) {
  // A loop flight whose last frames fly over its first ones again (the synthetic loop closes
  // with ~15 % overlap). Seed 9 and these settings are used by no other test.
  const fs::path dir = fs::path(GLAM_TEST_FIXTURES_DIR) / "vocabulary_loop";
  const std::string command = std::string("'") + GLAM_BIN +
                              "' --log-level warn synth --trajectory loop --frames 120 --width 320 --height 180 "
                              "--altitude 20 --speed 40 --seed 9 --out '" + dir.string() + "'";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  const auto frames = FrameDescriptors(dir / "video.mp4");
  ASSERT_EQ(frames.size(), 120u);

  // Submaps of 12 frames each over the first 96 frames (eight areas around the loop); the
  // query is the bag of the last 12 frames, which fly over the start again.
  const VocabularyTree& vocab = VocabularyTree::Default();
  SubmapDatabase db(vocab);
  std::vector<Words> bags;
  for (std::uint32_t s = 0; s < 8; ++s) {
    std::vector<Descriptor> descriptors;
    for (std::size_t f = s * 12; f < s * 12 + 12; ++f) {
      descriptors.insert(descriptors.end(), frames[f].begin(), frames[f].end());
    }
    bags.push_back(vocab.Quantize(descriptors));
    db.Add(s, bags.back());
  }
  std::vector<Descriptor> query_descriptors;
  for (std::size_t f = 108; f < 120; ++f) {
    query_descriptors.insert(query_descriptors.end(), frames[f].begin(), frames[f].end());
  }
  const Words query = vocab.Quantize(query_descriptors);

  // Ground truth: the submap whose cameras flew closest to the query's (mean over query frames
  // of the distance to the submap's nearest camera), and the farthest one.
  const std::vector<Eigen::Vector3d> centres = CameraCentres(dir / "gt_trajectory.tum");
  ASSERT_EQ(centres.size(), 120u);
  std::vector<double> distance(8, 0.0);
  for (std::uint32_t s = 0; s < 8; ++s) {
    for (std::size_t q = 108; q < 120; ++q) {
      double nearest = 1e9;
      for (std::size_t f = s * 12; f < s * 12 + 12; ++f) nearest = std::min(nearest, (centres[q] - centres[f]).norm());
      distance[s] += nearest / 12;
    }
  }
  const auto closest = static_cast<std::uint32_t>(std::min_element(distance.begin(), distance.end()) - distance.begin());
  const auto farthest = static_cast<std::uint32_t>(std::max_element(distance.begin(), distance.end()) - distance.begin());
  ASSERT_LT(distance[closest], 10.0);   // the clip does revisit (footprint ~23 m wide)
  ASSERT_GT(distance[farthest], 30.0);  // and has an area that does not overlap the query

  const auto ranked = db.Query(query, 8);
  ASSERT_FALSE(ranked.empty());
  std::cout << "loop query:";
  for (const auto& m : ranked) std::cout << " " << m.submap_id << ":" << m.score;
  std::cout << " (closest " << closest << ", farthest " << farthest << ")\n";
  EXPECT_EQ(ranked[0].submap_id, closest);
  const auto far = std::find_if(ranked.begin(), ranked.end(), [&](const auto& m) { return m.submap_id == farthest; });
  if (far != ranked.end()) {
    EXPECT_LT(far->score, 0.6 * ranked[0].score);
  }

  // Against itself every submap scores 1 and comes first.
  for (std::uint32_t s = 0; s < 8; ++s) {
    const auto self = db.Query(bags[s], 1);
    ASSERT_EQ(self.size(), 1u);
    EXPECT_EQ(self[0].submap_id, s);
    EXPECT_NEAR(self[0].score, 1.0, 1e-5);
  }
  // Excluding the start hands the first place to another submap.
  const auto without_start = db.Query(query, 8, [&](std::uint32_t id) { return id == closest; });
  ASSERT_EQ(without_start.size(), 7u);
  EXPECT_EQ(without_start[0].submap_id, ranked[1].submap_id);
}
#endif

}  // namespace
}  // namespace glam
