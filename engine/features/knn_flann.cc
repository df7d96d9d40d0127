// OpenCV's bundled FLANN (cv::flann), not Debian's standalone libflann: the standalone 1.9.2
// shuffles with std::random_device while building kd-trees, so its matches differ from run to
// run; OpenCV's copy draws from cv::theRNG() and std::rand(), both of which we seed.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <mutex>

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/flann.hpp>

#include "engine/features/knn_search.h"

namespace glam::internal {

std::vector<Knn2> Knn2Flann(const cv::Mat& query, const cv::Mat& train, int trees, int checks,
                            unsigned seed) {
  std::vector<Knn2> result(static_cast<size_t>(query.rows));
  if (query.rows == 0 || train.rows == 0) return result;
  std::unique_ptr<cv::flann::Index> index;
  {
    // std::rand() is process-global: serialise builds so the seed means something.
    static std::mutex build_mutex;
    std::lock_guard<std::mutex> lock(build_mutex);
    std::srand(seed);
    cv::theRNG().state = 0x9E3779B97F4A7C15ull ^ seed;  // thread-local
    index = std::make_unique<cv::flann::Index>(train, cv::flann::KDTreeIndexParams(trees),
                                               cvflann::FLANN_DIST_L2);
  }
  const int k = std::min(2, train.rows);
  const cv::flann::SearchParams params(checks);
  // Searching a built index is read-only: split the queries over OpenCV's thread pool.
  cv::parallel_for_(cv::Range(0, query.rows), [&](const cv::Range& range) {
    cv::Mat indices, dists;
    index->knnSearch(query.rowRange(range), indices, dists, k, params);
    for (int i = 0; i < indices.rows; ++i) {
      Knn2& out = result[static_cast<size_t>(range.start + i)];
      for (int j = 0; j < k; ++j) {
        out.index[j] = indices.at<int>(i, j);
        out.distance[j] = std::sqrt(dists.at<float>(i, j));  // FLANN's L2 is squared
      }
    }
  }, std::max(1.0, query.rows / 256.0));
  return result;
}

}  // namespace glam::internal
