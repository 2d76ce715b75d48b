/// \file types.h
/// \brief Basic types of the PCL-free core: indices, float vectors and the edge record of the walk graph.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

namespace dw {

/// Vertex / input index. 32 bits: halves the memory traffic of the walk against 64-bit indices.
using index_t = std::uint32_t;
constexpr index_t kInvalidIndex = std::numeric_limits<index_t>::max();

/// A position relative to the graph origin. Float keeps a vertex in 12 bytes; the double origin keeps
/// georeferenced coordinates (~6e6 m) at full resolution.
struct Vec3f {
  float x, y, z;
};

inline float dot(const Vec3f& a, const Vec3f& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline Vec3f operator-(const Vec3f& a, const Vec3f& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline float squaredDistance(const Vec3f& a, const Vec3f& b) {
  const Vec3f d = a - b;
  return dot(d, d);
}

/// One directed Delaunay edge i->j as the walk reads it (seed: Anderson et al. 2022, Alg. 1):
/// unit vector e = (x_j - x_i)/|x_j - x_i| and half-length m = |x_j - x_i|/2. For a query p with
/// u = p - x_i, u.e > m  <=>  p is strictly closer to x_j than to x_i.
struct EdgeRecord {
  float ex, ey, ez;
  float m;
  index_t j;
};
static_assert(sizeof(EdgeRecord) == 20, "EdgeRecord must stay packed: one neighbourhood is one read");

/// Base of every error the module throws; the message says what was wrong and where.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A graph file that is corrupt, truncated, foreign or of an unsupported version.
class GraphFileError : public Error {
 public:
  using Error::Error;
};

}  // namespace dw
