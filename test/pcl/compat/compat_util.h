// Shared helpers of the pcl.compat suite: the search classes we ship, made through one factory so
// that every behaviour runs on each of them, and the references they are held to (PCL's own
// pcl::search::KdTree / pcl::KdTreeFLANN, and brute force in FLANN's metric).
#pragma once

#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_representation.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include <algorithm>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/util/point_file.h"
#include "pcl_delaunay_walk/search/delaunay_walk.h"
#include "pcl_delaunay_walk/search/kdtree_delaunay_walk.h"

namespace dw_compat {

using P = pcl::PointXYZ;
using Cloud = pcl::PointCloud<P>;

/// The search classes we ship, by name (the test parameter).
enum class Backend { DelaunayWalk, KdTreeDelaunayWalk };

inline std::string backendName(Backend b) {
  return b == Backend::DelaunayWalk ? "DelaunayWalk" : "KdTreeDelaunayWalk";
}

/// A search of the given kind with a point representation set the way a user of that class sets it.
template <typename PointT>
typename pcl::search::Search<PointT>::Ptr makeSearch(
    Backend b, const typename pcl::PointRepresentation<PointT>::ConstPtr& rep = nullptr, bool sorted = true) {
  if (b == Backend::DelaunayWalk) {
    auto w = std::make_shared<pcl::search::DelaunayWalk<PointT>>(sorted);
    if (rep) w->setPointRepresentation(rep);
    return w;
  }
  auto t = std::make_shared<pcl::search::KdTreeDelaunayWalk<PointT>>(sorted);
  if (rep) {
    // Through the base pointer, as pcl::Registration does: search::KdTree's method is not virtual.
    pcl::search::KdTree<PointT>& base = *t;
    base.setPointRepresentation(rep);
  }
  return t;
}

inline std::string dataPath(const std::string& name) {
  return std::string(DW_TEST_DATA_DIR) + "/" + name;
}

/// A bundled cloud (data/*.pcd through PCL, *.ply through the core's reader).
inline Cloud::Ptr loadData(const std::string& name) {
  const std::string path = dataPath(name);
  Cloud::Ptr c(new Cloud);
  if (path.size() > 4 && path.substr(path.size() - 4) == ".pcd") {
    if (pcl::io::loadPCDFile(path, *c) < 0) ADD_FAILURE() << "cannot read " << path;
    return c;
  }
  const std::vector<double> xyz = dw::readPointsXyz(path);
  for (std::size_t i = 0; i < xyz.size() / 3; ++i)
    c->push_back(P(float(xyz[3 * i]), float(xyz[3 * i + 1]), float(xyz[3 * i + 2])));
  return c;
}

inline Cloud::Ptr randomCloud(std::size_t n, unsigned seed, float extent = 1.f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-extent, extent);
  Cloud::Ptr c(new Cloud);
  for (std::size_t i = 0; i < n; ++i) c->push_back(P(u(rng), u(rng), u(rng)));
  return c;
}

/// Every step-th point: keeps brute-force references cheap.
inline Cloud::Ptr everyNth(const Cloud& c, std::size_t step) {
  Cloud::Ptr s(new Cloud);
  for (std::size_t i = 0; i < c.size(); i += step) s->push_back(c[i]);
  return s;
}

/// Squared distance of two represented vectors, operation for operation as FLANN's L2_Simple.
inline float flannL2(const std::vector<float>& a, const std::vector<float>& b) {
  float r = 0.f;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const float d = a[i] - b[i];
    r += d * d;
  }
  return r;
}

template <typename PointT>
std::vector<float> vectorized(const pcl::PointRepresentation<PointT>& rep, const PointT& p) {
  std::vector<float> v(static_cast<std::size_t>(rep.getNumberOfDimensions()));
  rep.vectorize(p, v);
  return v;
}

/// Brute force over the cloud in a representation's space: every valid point, ascending (d², index).
template <typename PointT>
std::vector<std::pair<float, int>> bruteAll(const pcl::PointCloud<PointT>& c, const PointT& q,
                                            const pcl::PointRepresentation<PointT>& rep,
                                            const pcl::Indices* subset = nullptr) {
  const std::vector<float> vq = vectorized(rep, q);
  std::vector<std::pair<float, int>> all;
  const std::size_t n = subset ? subset->size() : c.size();
  for (std::size_t i = 0; i < n; ++i) {
    const int ci = subset ? (*subset)[i] : static_cast<int>(i);
    if (!rep.isValid(c[ci])) continue;
    all.emplace_back(flannL2(vq, vectorized(rep, c[ci])), ci);
  }
  std::sort(all.begin(), all.end());
  all.erase(std::unique(all.begin(), all.end()), all.end());
  return all;
}

/// An answer equals a reference answer ties aside: the same distances bit for bit, rank by rank, and
/// the same index wherever the distance is not shared with a neighbouring rank. `ref_*` must be
/// sorted; `sorted` says whether `got_*` must be too (else it is compared as a set).
inline void expectSameAnswer(pcl::Indices got_i, std::vector<float> got_d, pcl::Indices ref_i,
                             std::vector<float> ref_d, bool sorted, const std::string& what) {
  ASSERT_EQ(got_i.size(), got_d.size()) << what;
  ASSERT_EQ(got_i.size(), ref_i.size()) << what;
  if (!sorted) {
    std::vector<std::pair<float, int>> g;
    for (std::size_t i = 0; i < got_i.size(); ++i) g.emplace_back(got_d[i], got_i[i]);
    std::sort(g.begin(), g.end());
    for (std::size_t i = 0; i < g.size(); ++i) got_d[i] = g[i].first, got_i[i] = g[i].second;
  }
  for (std::size_t i = 0; i < got_i.size(); ++i) {
    ASSERT_EQ(got_d[i], ref_d[i]) << what << ": distance at rank " << i;
    const bool tied =
        (i > 0 && ref_d[i - 1] == ref_d[i]) || (i + 1 < ref_d.size() && ref_d[i + 1] == ref_d[i]);
    if (!tied) {
      EXPECT_EQ(got_i[i], ref_i[i]) << what << ": index at rank " << i;
    }
  }
  std::vector<int> s(got_i.begin(), got_i.end());
  std::sort(s.begin(), s.end());
  EXPECT_TRUE(std::adjacent_find(s.begin(), s.end()) == s.end()) << what << ": an index is repeated";
}

/// Queries: cloud points, points jittered near them, and random points in and around the bounds.
inline std::vector<P> queriesNear(const Cloud& c, std::size_t n, unsigned seed) {
  P lo(1e30f, 1e30f, 1e30f), hi(-1e30f, -1e30f, -1e30f);
  auto finite = [](const P& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); };
  for (const P& p : c) {
    if (!finite(p)) continue;
    lo.x = std::min(lo.x, p.x), lo.y = std::min(lo.y, p.y), lo.z = std::min(lo.z, p.z);
    hi.x = std::max(hi.x, p.x), hi.y = std::max(hi.y, p.y), hi.z = std::max(hi.z, p.z);
  }
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, c.size() - 1);
  std::uniform_real_distribution<float> u(-0.1f, 1.1f);
  std::normal_distribution<float> jitter(0.f, 0.005f * (hi.x - lo.x));
  std::vector<P> q;
  while (q.size() < n) {
    const P& p = c[pick(rng)];
    if (!finite(p)) continue;
    switch (q.size() % 3) {
      case 0: q.push_back(p); break;
      case 1: q.emplace_back(p.x + jitter(rng), p.y + jitter(rng), p.z + jitter(rng)); break;
      default:
        q.emplace_back(lo.x + u(rng) * (hi.x - lo.x), lo.y + u(rng) * (hi.y - lo.y),
                       lo.z + u(rng) * (hi.z - lo.z));
    }
  }
  return q;
}

}  // namespace dw_compat
