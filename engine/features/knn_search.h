// Internal to glam_features: the two k-nearest-neighbour back-ends behind MatchDescriptors.
// FLANN stays in its own translation unit (knn_flann.cc) so its heavy headers are compiled once.
#pragma once

#include <limits>
#include <vector>

#include <opencv2/core.hpp>

namespace glam::internal {

// Two nearest train rows of one query row; index -1 / distance +inf when absent.
// Distances are L2 (not squared).
struct Knn2 {
  int index[2] = {-1, -1};
  float distance[2] = {std::numeric_limits<float>::infinity(),
                       std::numeric_limits<float>::infinity()};
};

std::vector<Knn2> Knn2Flann(const cv::Mat& query, const cv::Mat& train, int trees, int checks,
                            unsigned seed);
std::vector<Knn2> Knn2BruteForce(const cv::Mat& query, const cv::Mat& train);

}  // namespace glam::internal
