/// \file nn_methods.h
/// \brief The PCL-side exact nearest-neighbour peers behind the batch interface of nn_method.h:
/// pcl::search::KdTree (FLANN), Debian's nanoflann, pcl::search::Octree; and the factory by name over
/// them, brute force and the Delaunay walk's strategies. Each peer's inner loop is its own.
#pragma once

#include <pcl/common/common.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/search/octree.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#ifdef DW_HAVE_NANOFLANN
#include <nanoflann.hpp>
static_assert(NANOFLANN_VERSION >= 0x140,
              "NanoflannNn relies on the constructor building the tree (nanoflann 1.4)");
#endif

#include "core/util/space_filling_curve.h"
#include "datasets.h"
#include "nn_method.h"

namespace dwb {

/// pcl::search::KdTree (FLANN, exact: one kd-tree, unlimited checks), queried exactly as PCL's
/// CorrespondenceEstimation does: nearestKSearch(point, 1, ...).
class PclKdTreeNn : public NnMethod {
 public:
  std::string name() const override { return "pcl-kdtree"; }
  void build(const std::vector<float>& xyz) override {
    cloud_ = toCloud(xyz);
    tree_.reset(new pcl::search::KdTree<pcl::PointXYZ>(false));
    tree_->setInputCloud(cloud_);
  }

 protected:
  void nearestRange(const float* q, std::size_t b, std::size_t e, NnBatch& out) override {
    pcl::Indices idx(1);
    std::vector<float> d2(1);
    for (std::size_t i = b; i < e; ++i) {
      tree_->nearestKSearch(pcl::PointXYZ(q[3 * i], q[3 * i + 1], q[3 * i + 2]), 1, idx, d2);
      out.index[i] = idx[0];
      out.dist2[i] = d2[0];
    }
  }
  bool hasKnn() const override { return true; }
  void knnRange(const float* q, std::size_t b, std::size_t e, std::size_t k, std::size_t,
                KnnBatch& out) override {
    pcl::Indices idx;
    std::vector<float> d2;
    for (std::size_t i = b; i < e; ++i) {
      const int found = tree_->nearestKSearch(pcl::PointXYZ(q[3 * i], q[3 * i + 1], q[3 * i + 2]),
                                              static_cast<int>(k), idx, d2);
      store(out, i, idx.data(), d2.data(), static_cast<std::size_t>(std::max(0, found)));
    }
  }
  // The tree was made unsorted (KdTree(false)), as NormalEstimation and clustering use it.
  void radiusRange(const float* q, std::size_t b, std::size_t e, float r2, std::size_t,
                   KnnBatch& out) override {
    pcl::Indices idx;
    std::vector<float> d2;
    const double r = std::sqrt(static_cast<double>(r2));
    for (std::size_t i = b; i < e; ++i) {
      const int found = tree_->radiusSearch(pcl::PointXYZ(q[3 * i], q[3 * i + 1], q[3 * i + 2]), r, idx, d2);
      out.count[i] = static_cast<std::uint32_t>(std::max(0, found));
      out.far2[i] = d2.empty() ? 0.f : *std::max_element(d2.begin(), d2.end());
    }
  }

 private:
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud_;
  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree_;
};

/// pcl::search::Octree (exact nearestKSearch). Its speed depends on the leaf size; we aim at a few
/// points per occupied leaf of a surface-like cloud: resolution = 2 x (bbox diagonal / sqrt(n)).
class PclOctreeNn : public NnMethod {
 public:
  std::string name() const override { return "pcl-octree"; }
  void build(const std::vector<float>& xyz) override {
    cloud_ = toCloud(xyz);
    const double n = std::max<double>(1.0, cloud_->size());
    // Surface-like clouds: spacing ~ sqrt(area / n), with the bbox diagonal squared for the area. The
    // factor (2) can be swept with DW_BENCH_OCTREE_FACTOR: the best differs by data set
    // (docs/benchmarks.md, "Nearest-neighbour search").
    double diag = 0;
    {
      Eigen::Vector4f lo, hi;
      pcl::getMinMax3D(*cloud_, lo, hi);
      diag = (hi - lo).head<3>().norm();
    }
    const char* factor = std::getenv("DW_BENCH_OCTREE_FACTOR");
    resolution_ = std::max(1e-6, (factor ? std::atof(factor) : 2.0) * diag / std::sqrt(n));
    tree_.reset(new pcl::search::Octree<pcl::PointXYZ>(resolution_));
    tree_->setInputCloud(cloud_);
  }
  double resolution() const { return resolution_; }

 protected:
  void nearestRange(const float* q, std::size_t b, std::size_t e, NnBatch& out) override {
    pcl::Indices idx(1);
    std::vector<float> d2(1);
    for (std::size_t i = b; i < e; ++i) {
      tree_->nearestKSearch(pcl::PointXYZ(q[3 * i], q[3 * i + 1], q[3 * i + 2]), 1, idx, d2);
      out.index[i] = idx[0];
      out.dist2[i] = d2[0];
    }
  }

 private:
  double resolution_ = 0;
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud_;
  pcl::search::Octree<pcl::PointXYZ>::Ptr tree_;
};

#ifdef DW_HAVE_NANOFLANN
/// nanoflann's KDTreeSingleIndexAdaptor with L2_Simple (the metric it recommends for 3D), leaf size
/// 10 (its default), over the points in place through the adaptor interface.
///
/// With `sorted` (a control for the walks' batch order): each batch is answered grouped by the query
/// points' cells in a 32^3 Morton order over the reference's bounding box, the sort timed with the
/// queries. The walks'
/// estimator groups its batch by start vertex; this gives the tree the same kind of locality.
class NanoflannNn : public NnMethod {
 public:
  explicit NanoflannNn(bool sorted = false) : sorted_(sorted) {}
  std::string name() const override { return sorted_ ? "nanoflann-sorted" : "nanoflann"; }
  void build(const std::vector<float>& xyz) override {
    cloud_.xyz = xyz;
    // The constructor builds the tree (nanoflann >= 1.4; Debian 12 ships 1.4.2). An explicit
    // buildIndex() after it would build it twice.
    index_.reset(new Index(3, cloud_, nanoflann::KDTreeSingleIndexAdaptorParams(10)));
    if (sorted_) {
      for (int d = 0; d < 3; ++d) lo_[d] = hi_[d] = xyz.empty() ? 0.f : xyz[d];
      for (std::size_t i = 0; i < xyz.size(); i += 3)
        for (int d = 0; d < 3; ++d)
          lo_[d] = std::min(lo_[d], xyz[i + d]), hi_[d] = std::max(hi_[d], xyz[i + d]);
    }
  }

 protected:
  void nearestRange(const float* q, std::size_t b, std::size_t e, NnBatch& out) override {
    if (!sorted_) return answer(q, b, e, nullptr, out);
    // A counting sort on 32^3 Morton cells of the reference's box (queries outside it clamp to its
    // faces): O(n), like the walks' grouping by start vertex; std::sort on full keys cost more than
    // the locality saved.
    constexpr unsigned kBits = 5;
    std::vector<std::uint32_t> cell(e - b), first((std::size_t(1) << (3 * kBits)) + 1, 0);
    for (std::size_t i = b; i < e; ++i) {
      std::uint32_t c[3];
      for (int d = 0; d < 3; ++d) {
        const float extent = hi_[d] > lo_[d] ? hi_[d] - lo_[d] : 1.f;
        const float t = std::min(1.f, std::max(0.f, (q[3 * i + d] - lo_[d]) / extent));
        c[d] = static_cast<std::uint32_t>(t * float((1u << kBits) - 1));
      }
      cell[i - b] = static_cast<std::uint32_t>(dw::mortonKey(c[0], c[1], c[2]));
      ++first[cell[i - b] + 1];
    }
    for (std::size_t k = 1; k < first.size(); ++k) first[k] += first[k - 1];
    std::vector<std::uint32_t> order(e - b);
    for (std::size_t i = b; i < e; ++i) order[first[cell[i - b]]++] = static_cast<std::uint32_t>(i);
    answer(q, 0, order.size(), order.data(), out);
  }

 private:
  // Queries order[k] (or k itself) for k in [b, e).
  void answer(const float* q, std::size_t b, std::size_t e, const std::uint32_t* order, NnBatch& out) {
    for (std::size_t k = b; k < e; ++k) {
      const std::size_t i = order ? order[k] : k;
      std::uint32_t idx = 0;
      float d2 = 0;
      nanoflann::KNNResultSet<float, std::uint32_t> rs(1);
      rs.init(&idx, &d2);
      index_->findNeighbors(rs, q + 3 * i, nanoflann::SearchParams());
      out.index[i] = static_cast<int>(idx);
      out.dist2[i] = d2;
    }
  }

  struct Cloud {
    std::vector<float> xyz;
    std::size_t kdtree_get_point_count() const { return xyz.size() / 3; }
    float kdtree_get_pt(std::size_t i, std::size_t d) const { return xyz[3 * i + d]; }
    template <class BBox>
    bool kdtree_get_bbox(BBox&) const {
      return false;
    }
  };
  using Index = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Cloud>, Cloud, 3,
                                                    std::uint32_t>;
  Cloud cloud_;
  std::unique_ptr<Index> index_;
  bool sorted_ = false;
  float lo_[3] = {0, 0, 0}, hi_[3] = {0, 0, 0};
};
#endif

/// Method names in report order.
inline std::vector<std::string> allMethodNames() {
  return {
      "brute-force", "pcl-kdtree", "nanoflann",          "pcl-octree",        "walk-zero",
      "walk-kd-ann", "walk-pnn",   "walk-pnn-optimized", "walk-pnn-prefetch", "walk-pnn-optimized-prefetch"};
}

/// Creates a method by name; nullptr when it is not compiled in (nanoflann without the header).
inline std::unique_ptr<NnMethod> makeMethod(const std::string& name) {
  if (name == "brute-force") return std::make_unique<BruteForceNn>();
  if (name == "pcl-kdtree") return std::make_unique<PclKdTreeNn>();
  if (name == "pcl-octree") return std::make_unique<PclOctreeNn>();
  if (name == "nanoflann" || name == "nanoflann-sorted") {
#ifdef DW_HAVE_NANOFLANN
    return std::make_unique<NanoflannNn>(name == "nanoflann-sorted");
#else
    return nullptr;
#endif
  }
  if (name.rfind("walk-", 0) == 0) return makeWalk(name);
  throw dw::Error("dw_bench: unknown method '" + name + "'");
}

}  // namespace dwb
