#include "engine/features/feature_matcher.h"

#include <algorithm>

#include <opencv2/features2d.hpp>

#include "engine/core/error.h"
#include "engine/core/options.h"
#include "engine/features/knn_search.h"

namespace glam {
namespace internal {

std::vector<Knn2> Knn2BruteForce(const cv::Mat& query, const cv::Mat& train) {
  std::vector<Knn2> result(static_cast<size_t>(query.rows));
  if (query.rows == 0 || train.rows == 0) return result;
  cv::BFMatcher matcher(cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(query, train, knn, 2);
  for (const auto& row : knn) {
    for (size_t j = 0; j < row.size() && j < 2; ++j) {
      Knn2& out = result[static_cast<size_t>(row[j].queryIdx)];
      out.index[j] = row[j].trainIdx;
      out.distance[j] = row[j].distance;
    }
  }
  return result;
}

}  // namespace internal

void MatchOptions::Check() const {
  CheckInRange("MatchOptions.ratio", ratio, 0.05f, 1.0f);
  CheckGreater("MatchOptions.max_distance", max_distance, 0.0f);
  CheckInRange("MatchOptions.flann_trees", flann_trees, 1, 64);
  CheckInRange("MatchOptions.flann_checks", flann_checks, 1, 100000);
}

MatcherType ChooseMatcher(int query_rows, int train_rows) {
  return static_cast<double>(query_rows) * train_rows <= kAutoBruteForceMaxPairs
             ? MatcherType::kBruteForce
             : MatcherType::kFlann;
}

namespace {

std::vector<internal::Knn2> Knn2(const cv::Mat& query, const cv::Mat& train,
                                 const MatchOptions& options) {
  MatcherType type = options.type;
  if (type == MatcherType::kAuto) type = ChooseMatcher(query.rows, train.rows);
  if (type == MatcherType::kBruteForce) return internal::Knn2BruteForce(query, train);
  return internal::Knn2Flann(query, train, options.flann_trees, options.flann_checks,
                             options.seed);
}

}  // namespace

std::vector<Match> MatchDescriptors(const cv::Mat& query, const cv::Mat& train,
                                    const MatchOptions& options) {
  options.Check();
  GLAM_CHECK(query.empty() || query.type() == CV_32F, "descriptors must be CV_32F");
  GLAM_CHECK(train.empty() || train.type() == CV_32F, "descriptors must be CV_32F");
  GLAM_CHECK(query.empty() || train.empty() || query.cols == train.cols,
             "descriptor lengths differ: {} vs {}", query.cols, train.cols);
  std::vector<Match> matches;
  if (query.rows == 0 || train.rows == 0) return matches;

  const auto knn = Knn2(query, train, options);
  for (int q = 0; q < query.rows; ++q) {
    const internal::Knn2& k = knn[static_cast<size_t>(q)];
    if (k.index[0] < 0 || k.distance[0] > options.max_distance) continue;
    if (options.ratio < 1.0f && !(k.distance[0] < options.ratio * k.distance[1])) continue;
    matches.push_back({q, k.index[0], k.distance[0]});
  }
  if (!options.mutual || matches.empty()) return matches;

  // Reverse search only for the train rows that were matched.
  std::vector<int> trains;
  trains.reserve(matches.size());
  for (const Match& m : matches) trains.push_back(m.train);
  std::sort(trains.begin(), trains.end());
  trains.erase(std::unique(trains.begin(), trains.end()), trains.end());
  cv::Mat reverse_query(static_cast<int>(trains.size()), train.cols, CV_32F);
  for (size_t i = 0; i < trains.size(); ++i) train.row(trains[i]).copyTo(reverse_query.row(static_cast<int>(i)));
  const auto reverse = Knn2(reverse_query, query, options);
  std::vector<Match> mutual;
  mutual.reserve(matches.size());
  for (const Match& m : matches) {
    const size_t r = static_cast<size_t>(
        std::lower_bound(trains.begin(), trains.end(), m.train) - trains.begin());
    if (reverse[r].index[0] == m.query) mutual.push_back(m);
  }
  return mutual;
}

}  // namespace glam
