// Shared helpers of the builder3d tests: point generators (general position and degenerate), edge-set
// normalisation, and a brute-force nearest-neighbour reference.
#pragma once

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/builder3d/triangulation_3d.h"
#include "core/util/space_filling_curve.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"
#include "pcl_delaunay_walk/core/graph/types.h"

namespace b3d_test {

using Edges = std::vector<std::pair<dw::index_t, dw::index_t>>;

inline std::string sharedData(const std::string& rel) {
  return std::string(DW_SHARED_DATA_DIR) + "/" + rel;
}
inline bool exists(const std::string& p) {
  return std::ifstream(p).good();
}

/// Sorted, deduplicated (min, max) pairs: the form in which two builders' outputs are compared.
inline Edges normalise(Edges e) {
  for (auto& p : e)
    if (p.first > p.second) std::swap(p.first, p.second);
  std::sort(e.begin(), e.end());
  e.erase(std::unique(e.begin(), e.end()), e.end());
  return e;
}

/// The edges of a kernel's triangulation, normalised (extracted on `threads` threads).
inline Edges kernelEdges(const dw::builder3d::Triangulation3D& k, unsigned threads = 1) {
  Edges all;
  for (auto& c : k.edgeChunks(threads)) all.insert(all.end(), c.begin(), c.end());
  return normalise(all);
}

/// Keeps the first copy of every exact duplicate (the builders' contract wants distinct points).
inline std::vector<dw::Vec3f> distinct(const std::vector<dw::Vec3f>& in) {
  std::set<std::tuple<float, float, float>> seen;
  std::vector<dw::Vec3f> out;
  for (const auto& p : in)
    if (seen.insert({p.x, p.y, p.z}).second) out.push_back(p);
  return out;
}

inline std::vector<dw::Vec3f> uniformCube(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<dw::Vec3f> p(n);
  for (auto& q : p) q = {u(rng), u(rng), u(rng)};
  return distinct(p);
}

inline std::vector<dw::Vec3f> sphereSurface(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::vector<dw::Vec3f> p(n);
  for (auto& q : p) {
    double v[3] = {g(rng), g(rng), g(rng)};
    const double r = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    q = {float(v[0] / r), float(v[1] / r), float(v[2] / r)};
  }
  return distinct(p);
}

inline std::vector<dw::Vec3f> torusSurface(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> a(0.0, 2.0 * M_PI);
  std::vector<dw::Vec3f> p(n);
  for (auto& q : p) {
    const double u = a(rng), v = a(rng);
    q = {float((2.0 + 0.6 * std::cos(v)) * std::cos(u)), float((2.0 + 0.6 * std::cos(v)) * std::sin(u)),
         float(0.6 * std::sin(v))};
  }
  return distinct(p);
}

/// nx * ny * nz integer grid: every cell's 8 corners are cospherical, every face's 4 coplanar.
inline std::vector<dw::Vec3f> grid(int nx, int ny, int nz, float step = 1.0f) {
  std::vector<dw::Vec3f> p;
  for (int x = 0; x < nx; ++x)
    for (int y = 0; y < ny; ++y)
      for (int z = 0; z < nz; ++z) p.push_back({x * step, y * step, z * step});
  return p;
}

/// Every integer point on the sphere x^2 + y^2 + z^2 = r2 (all exactly cospherical).
inline std::vector<dw::Vec3f> latticeSphere(int r2) {
  std::vector<dw::Vec3f> p;
  const int r = static_cast<int>(std::sqrt(double(r2)));
  for (int x = -r; x <= r; ++x)
    for (int y = -r; y <= r; ++y) {
      const int z2 = r2 - x * x - y * y;
      if (z2 < 0) continue;
      const int z = static_cast<int>(std::lround(std::sqrt(double(z2))));
      if (z * z != z2) continue;
      p.push_back({float(x), float(y), float(z)});
      if (z != 0) p.push_back({float(x), float(y), float(-z)});
    }
  return p;
}

/// Uniform points rounded to a coarse grid (LAS-like quantisation): many ties, some duplicates removed.
inline std::vector<dw::Vec3f> quantised(std::size_t n, unsigned seed, float step) {
  std::vector<dw::Vec3f> p = uniformCube(n, seed);
  for (auto& q : p)
    q = {std::round(q.x / step) * step, std::round(q.y / step) * step, std::round(q.z / step) * step};
  return distinct(p);
}

inline std::vector<dw::Vec3f> toVec3f(const std::vector<double>& xyz) {
  std::vector<dw::Vec3f> p(xyz.size() / 3);
  double c[3] = {0, 0, 0};
  for (std::size_t i = 0; i < p.size(); ++i)
    for (int k = 0; k < 3; ++k) c[k] += xyz[3 * i + k] / double(p.size());
  for (std::size_t i = 0; i < p.size(); ++i)
    p[i] = {float(xyz[3 * i] - c[0]), float(xyz[3 * i + 1] - c[1]), float(xyz[3 * i + 2] - c[2])};
  return distinct(p);
}

/// The points in Morton order (ids follow a space-filling curve, as buildDelaunayGraph hands them to
/// the builders: blocks and parallel cells are compact only then). The inputs here are distinct.
inline std::vector<dw::Vec3f> mortonSorted(const std::vector<dw::Vec3f>& p) {
  return dw::mortonSortedDistinct(p);
}

}  // namespace b3d_test
