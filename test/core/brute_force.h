// Brute-force reference for the exactness tests: squared distances over the graph's own float frame.
#pragma once

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/search/neighbour_search.h"

namespace dw_test {

inline std::string sharedData(const std::string& rel) {
  return std::string(DW_SHARED_DATA_DIR) + "/" + rel;
}
inline bool exists(const std::string& p) {
  return std::ifstream(p).good();
}

/// Squared distances from q to every finite input point, measured like the search does (local float).
inline std::vector<float> allDistances(const dw::DelaunayGraph& g, const std::vector<double>& xyz,
                                       const dw::Vec3f& q) {
  std::vector<float> d;
  for (std::size_t i = 0; i < xyz.size() / 3; ++i) {
    if (!std::isfinite(xyz[3 * i]) || !std::isfinite(xyz[3 * i + 1]) || !std::isfinite(xyz[3 * i + 2]))
      continue;
    d.push_back(dw::squaredDistance(q, g.toLocal(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2])));
  }
  std::sort(d.begin(), d.end());
  return d;
}

/// Tolerance for comparing float squared distances computed along different paths.
inline float tol(float d2, float scale2) {
  return 1e-5f * d2 + 1e-6f * scale2;
}

inline std::vector<double> uniformCube(std::size_t n, unsigned seed, double lo = -1, double hi = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  std::vector<double> xyz(3 * n);
  for (double& v : xyz) v = u(rng);
  return xyz;
}

}  // namespace dw_test
