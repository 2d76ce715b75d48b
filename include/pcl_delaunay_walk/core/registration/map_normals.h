/// \file map_normals.h
/// \brief Normals of a map for point-to-plane ICP, computed once from the walk's exact k nearest
/// neighbours: the eigenvector of the smallest eigenvalue of each neighbourhood's covariance.
#pragma once

#include <cstddef>
#include <vector>

#include "pcl_delaunay_walk/core/search/caller_metric_search.h"

namespace dw {

/// 3 floats per input of `search` (unit length; zero for a non-finite input or a neighbourhood with
/// fewer than 3 points or no plane, which point-to-plane ICP then skips). Runs on `threads` threads
/// (0: all cores); the result does not depend on the count. Throws dw::Error for k < 3.
std::vector<float> computeMapNormals(const CallerMetricSearch& search, std::size_t k = 10,
                                     unsigned threads = 0);

}  // namespace dw
