// Shared helpers of the pcl::search::DelaunayWalk tests: clouds (synthetic and real) and the
// brute-force reference in PCL's metric (FLANN's float squared distance on the cloud's coordinates).
#pragma once

#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/util/point_file.h"

namespace dw_pcl_test {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

inline std::string sharedData(const std::string& rel) {
  return std::string(DW_SHARED_DATA_DIR) + "/" + rel;
}
inline bool exists(const std::string& p) {
  return std::ifstream(p).good();
}

/// Loads .pcd with PCL and .ply / .bin with the core's reader (it copes with the Stanford range-grid
/// PLYs). Returns null if the file is absent, so callers can GTEST_SKIP.
inline Cloud::Ptr loadShared(const std::string& rel) {
  const std::string path = sharedData(rel);
  if (!exists(path)) return nullptr;
  Cloud::Ptr c(new Cloud);
  if (path.size() > 4 && path.substr(path.size() - 4) == ".pcd") {
    if (pcl::io::loadPCDFile(path, *c) < 0) return nullptr;
  } else {
    const std::vector<double> xyz = dw::readPointsXyz(path);
    c->resize(xyz.size() / 3);
    for (std::size_t i = 0; i < c->size(); ++i)
      (*c)[i] = pcl::PointXYZ(float(xyz[3 * i]), float(xyz[3 * i + 1]), float(xyz[3 * i + 2]));
    c->width = static_cast<std::uint32_t>(c->size());
    c->height = 1;
  }
  return c;
}

/// Every `step`-th point, to keep brute-force references and Qhull builds small in tests.
inline Cloud::Ptr subsample(const Cloud& c, std::size_t step) {
  Cloud::Ptr s(new Cloud);
  for (std::size_t i = 0; i < c.size(); i += step) s->push_back(c[i]);
  return s;
}

inline Cloud::Ptr uniformCloud(std::size_t n, unsigned seed, float lo = -1.f, float hi = 1.f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  Cloud::Ptr c(new Cloud);
  for (std::size_t i = 0; i < n; ++i) c->push_back(pcl::PointXYZ(u(rng), u(rng), u(rng)));
  return c;
}

/// FLANN's L2_Simple, operation for operation.
inline float flannDistance(const pcl::PointXYZ& a, const pcl::PointXYZ& b) {
  const float dx = a.x - b.x, dy = a.y - b.y, dz = a.z - b.z;
  float r = 0.f;
  r += dx * dx;
  r += dy * dy;
  r += dz * dz;
  return r;
}

inline bool finite(const pcl::PointXYZ& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

struct Ref {
  std::vector<int> idx;
  std::vector<float> d2;
};

/// Every finite point (of the subset, if given) sorted by (distance, index).
inline Ref bruteAll(const Cloud& c, const pcl::PointXYZ& q, const pcl::Indices* subset = nullptr) {
  std::vector<std::pair<float, int>> all;
  const std::size_t n = subset ? subset->size() : c.size();
  for (std::size_t i = 0; i < n; ++i) {
    const int ci = subset ? (*subset)[i] : static_cast<int>(i);
    if (!finite(c[ci])) continue;
    all.emplace_back(flannDistance(q, c[ci]), ci);
  }
  std::sort(all.begin(), all.end());
  all.erase(std::unique(all.begin(), all.end()), all.end());  // a subset may repeat an index
  Ref r;
  for (const auto& a : all) {
    r.d2.push_back(a.first);
    r.idx.push_back(a.second);
  }
  return r;
}

inline Ref bruteKnn(const Cloud& c, const pcl::PointXYZ& q, int k, const pcl::Indices* subset = nullptr) {
  Ref r = bruteAll(c, q, subset);
  const std::size_t m = std::min<std::size_t>(r.idx.size(), static_cast<std::size_t>(std::max(k, 0)));
  r.idx.resize(m);
  r.d2.resize(m);
  return r;
}

/// The radius answer, from the full sorted reference of one query.
inline Ref radiusFrom(const Ref& all, double radius, unsigned max_nn) {
  Ref r;
  const float r2 = static_cast<float>(radius * radius);
  for (std::size_t i = 0; i < all.idx.size() && all.d2[i] < r2; ++i) {
    if (max_nn > 0 && r.idx.size() == max_nn) break;
    r.idx.push_back(all.idx[i]);
    r.d2.push_back(all.d2[i]);
  }
  return r;
}

inline Ref bruteRadius(const Cloud& c, const pcl::PointXYZ& q, double radius, unsigned max_nn,
                       const pcl::Indices* subset = nullptr) {
  return radiusFrom(bruteAll(c, q, subset), radius, max_nn);
}

/// Exactness: the same distances, element by element, bit for bit; indices may differ only among
/// points at exactly equal distance (ties), and each reported index must be at its reported distance.
inline void expectSameNeighbours(const Cloud& c, const pcl::PointXYZ& q, const Ref& ref,
                                 const pcl::Indices& idx, const std::vector<float>& d2,
                                 const std::string& what) {
  ASSERT_EQ(idx.size(), ref.idx.size()) << what;
  ASSERT_EQ(d2.size(), ref.d2.size()) << what;
  for (std::size_t i = 0; i < idx.size(); ++i) {
    ASSERT_EQ(d2[i], ref.d2[i]) << what << " rank " << i;
    ASSERT_GE(idx[i], 0) << what;
    ASSERT_LT(static_cast<std::size_t>(idx[i]), c.size()) << what;
    ASSERT_EQ(flannDistance(q, c[idx[i]]), d2[i]) << what << " rank " << i << " index " << idx[i];
  }
  std::vector<int> a(idx.begin(), idx.end());
  std::sort(a.begin(), a.end());
  ASSERT_TRUE(std::adjacent_find(a.begin(), a.end()) == a.end()) << what << ": an index is repeated";
}

/// Query points: some cloud points, some jittered near them, some random in (and beyond) the bounds.
inline std::vector<pcl::PointXYZ> queriesFor(const Cloud& c, std::size_t n, unsigned seed) {
  std::vector<pcl::PointXYZ> q;
  std::vector<std::size_t> fin;
  for (std::size_t i = 0; i < c.size(); ++i)
    if (finite(c[i])) fin.push_back(i);
  if (fin.empty()) {
    q.emplace_back(0.f, 0.f, 0.f);
    return q;
  }
  pcl::PointXYZ lo = c[fin[0]], hi = c[fin[0]];
  for (std::size_t i : fin) {
    lo.x = std::min(lo.x, c[i].x), lo.y = std::min(lo.y, c[i].y), lo.z = std::min(lo.z, c[i].z);
    hi.x = std::max(hi.x, c[i].x), hi.y = std::max(hi.y, c[i].y), hi.z = std::max(hi.z, c[i].z);
  }
  const float ext = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 1e-3f});
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, fin.size() - 1);
  std::normal_distribution<float> jit(0.f, 0.01f * ext);
  std::uniform_real_distribution<float> u(-0.2f, 1.2f);
  for (std::size_t i = 0; i < n; ++i) {
    const pcl::PointXYZ& p = c[fin[pick(rng)]];
    switch (i % 3) {
      case 0: q.push_back(p); break;
      case 1: q.emplace_back(p.x + jit(rng), p.y + jit(rng), p.z + jit(rng)); break;
      default:
        q.emplace_back(lo.x + u(rng) * (hi.x - lo.x), lo.y + u(rng) * (hi.y - lo.y),
                       lo.z + u(rng) * (hi.z - lo.z));
    }
  }
  return q;
}

}  // namespace dw_pcl_test
