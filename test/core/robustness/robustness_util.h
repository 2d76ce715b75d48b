// Shared helpers of the robustness tests: a brute-force oracle, a graph-file forger and an allocation
// probe. The oracle measures distances in the graph's own float frame, like the search does, so ties
// are the only source of disagreement.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/graph/graph_io.h"
#include "pcl_delaunay_walk/core/search/neighbour_search.h"

namespace dw_robust {

inline std::vector<double> randomCloud(std::size_t n, unsigned seed, double lo = -1.0, double hi = 1.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  std::vector<double> xyz(3 * n);
  for (double& v : xyz) v = u(rng);
  return xyz;
}

inline bool finitePoint(const double* p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

/// Sorted squared distances from q (local frame of g) to every finite input point.
inline std::vector<float> bruteForce(const dw::DelaunayGraph& g, const std::vector<double>& xyz,
                                     const dw::Vec3f& q) {
  std::vector<float> d;
  for (std::size_t i = 0; i + 2 < xyz.size(); i += 3)
    if (finitePoint(&xyz[i])) d.push_back(dw::squaredDistance(q, g.toLocal(xyz[i], xyz[i + 1], xyz[i + 2])));
  std::sort(d.begin(), d.end());
  return d;
}

/// Float distances computed along two paths may differ by a few ulps of the larger operands.
inline float tolerance(float d2, float scale2) {
  return 1e-5f * d2 + 1e-6f * scale2;
}

/// Checks nearest (every start strategy), kNN and radius at `queries` against brute force. Returns
/// a description of the first mismatch, or "" when all agree.
std::string checkAgainstBruteForce(const std::vector<double>& xyz, const dw::DelaunayGraph::ConstPtr& g,
                                   const std::vector<dw::Vec3f>& queries);

/// Queries in g's local frame: on input points, inside the bounding box and outside it.
std::vector<dw::Vec3f> mixedQueries(const dw::DelaunayGraph& g, const std::vector<double>& xyz, std::size_t n,
                                    unsigned seed);

/// Recomputes the payload and header checksums of a serialised graph after a test edited it, so the
/// loader's structural checks (not only its checksum) are what rejects the file. Mirrors the file
/// format of graph_io.cpp; Forger.ReproducesRealChecksums fails if the two drift apart.
void reseal(std::vector<std::uint8_t>& file);

/// Byte offsets of the graph file header fields (graph_io.cpp, format version 1).
namespace hdr {
constexpr std::size_t kVersion = 8, kHeaderSize = 12, kDimension = 16, kNumVertices = 24, kNumEdges = 32,
                      kNumInput = 40, kNumOriginals = 48, kOrigin = 56, kPayloadBytes = 80,
                      kPayloadChecksum = 88, kHeaderChecksum = 96, kSize = 104;
}

template <typename T>
void poke(std::vector<std::uint8_t>& f, std::size_t at, T v) {
  std::memcpy(f.data() + at, &v, sizeof v);
}
template <typename T>
T peek(const std::vector<std::uint8_t>& f, std::size_t at) {
  T v;
  std::memcpy(&v, f.data() + at, sizeof v);
  return v;
}

/// Largest single operator-new request made by this thread while a probe is alive (allocation_probe.cpp
/// replaces the global operator new). Lets a test prove that a loader sizes nothing from untrusted
/// header fields.
class AllocationProbe {
 public:
  AllocationProbe();
  ~AllocationProbe();
  std::size_t largest() const;
};

}  // namespace dw_robust
