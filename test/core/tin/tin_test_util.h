/// \file tin_test_util.h
/// \brief Helpers shared by the TIN tests: canonical triangle sets and point generators.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw_test {

/// Triangles as a sorted list of rotations that start at their smallest index (orientation kept).
template <typename Container>
std::vector<std::array<dw::index_t, 3>> canonical(const Container& t) {
  std::vector<std::array<dw::index_t, 3>> out;
  for (std::size_t i = 0; i + 2 < t.size(); i += 3) {
    std::array<dw::index_t, 3> a{t[i], t[i + 1], t[i + 2]};
    while (a[0] > a[1] || a[0] > a[2]) a = {a[1], a[2], a[0]};
    out.push_back(a);
  }
  std::sort(out.begin(), out.end());
  return out;
}

struct Cloud {
  std::vector<double> x, y;
  std::size_t size() const { return x.size(); }
  void add(double a, double b) {
    x.push_back(a);
    y.push_back(b);
  }
};

inline Cloud randomCloud(std::size_t n, unsigned seed, double w = 100.0, double h = 100.0) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(0.0, w), uy(0.0, h);
  Cloud c;
  for (std::size_t i = 0; i < n; ++i) c.add(ux(rng), uy(rng));
  return c;
}

/// A w x h integer grid (every unit square is cocircular), shuffled.
inline Cloud gridCloud(int w, int h, unsigned seed, double step = 1.0) {
  Cloud c;
  std::vector<std::pair<int, int>> cells;
  for (int i = 0; i < w; ++i)
    for (int j = 0; j < h; ++j) cells.emplace_back(i, j);
  std::mt19937 rng(seed);
  std::shuffle(cells.begin(), cells.end(), rng);
  for (const auto& p : cells) c.add(p.first * step, p.second * step);
  return c;
}

/// Uniform points quantised to a LAS-like 0.01 grid (many exact ties and duplicates).
inline Cloud quantisedCloud(std::size_t n, unsigned seed, double w = 20.0) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> u(0, int(w * 100));
  Cloud c;
  for (std::size_t i = 0; i < n; ++i) c.add(u(rng) * 0.01, u(rng) * 0.01);
  return c;
}

}  // namespace dw_test
