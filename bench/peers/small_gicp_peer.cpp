/// \file small_gicp_peer.cpp
/// \brief small_gicp's KdTree as a peer (its defaults: leaf size 20, axis-aligned splits), over its own
/// PointCloud of double homogeneous points, as small_gicp's registration uses it. It has no radius
/// search; kNN and 1-NN only. Also small_gicp's own ICP and GICP (peers.h, smallGicpAlign).
#include <chrono>
#include <small_gicp/ann/kdtree.hpp>
#include <small_gicp/factors/gicp_factor.hpp>
#include <small_gicp/factors/icp_factor.hpp>
#include <small_gicp/points/point_cloud.hpp>
#include <small_gicp/registration/reduction.hpp>
#include <small_gicp/registration/registration.hpp>
#include <small_gicp/util/normal_estimation.hpp>

#include "peers/peers.h"

namespace dwb {
namespace {

class SmallGicpPeer : public NnMethod {
 public:
  std::string name() const override { return "small_gicp-" DW_SMALL_GICP_LABEL; }
  std::string version() const override { return DW_SMALL_GICP_LABEL; }
  bool hasKnn() const override { return true; }
  void build(const std::vector<float>& xyz) override {
    tree_.reset();
    auto cloud = std::make_shared<small_gicp::PointCloud>();
    cloud->resize(xyz.size() / 3);
    for (std::size_t i = 0; i < cloud->size(); ++i)
      cloud->point(i) = Eigen::Vector4d(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2], 1.0);
    tree_ = std::make_unique<Tree>(cloud);
  }

 protected:
  void nearestRange(const float* q, std::size_t b, std::size_t e, NnBatch& out) override {
    for (std::size_t i = b; i < e; ++i) {
      std::size_t idx = 0;
      double d2 = 0;
      tree_->nearest_neighbor_search(Eigen::Vector4d(q[3 * i], q[3 * i + 1], q[3 * i + 2], 1.0), &idx, &d2);
      out.index[i] = static_cast<int>(idx);
      out.dist2[i] = static_cast<float>(d2);
    }
  }
  void knnRange(const float* q, std::size_t b, std::size_t e, std::size_t k, std::size_t,
                KnnBatch& out) override {
    std::vector<std::size_t> idx(k);
    std::vector<double> d2(k);
    for (std::size_t i = b; i < e; ++i) {
      const std::size_t found = tree_->knn_search(Eigen::Vector4d(q[3 * i], q[3 * i + 1], q[3 * i + 2], 1.0),
                                                  static_cast<int>(k), idx.data(), d2.data());
      store(out, i, idx.data(), d2.data(), found);
    }
  }

 private:
  using Tree = small_gicp::KdTree<small_gicp::PointCloud>;
  std::unique_ptr<Tree> tree_;
};

}  // namespace

namespace {
std::shared_ptr<small_gicp::PointCloud> toSmallGicp(const std::vector<float>& xyz) {
  auto c = std::make_shared<small_gicp::PointCloud>();
  c->resize(xyz.size() / 3);
  for (std::size_t i = 0; i < c->size(); ++i)
    c->point(i) = Eigen::Vector4d(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2], 1.0);
  return c;
}

template <typename Factor>
small_gicp::RegistrationResult alignWith(const small_gicp::PointCloud& target,
                                         const small_gicp::PointCloud& source,
                                         const small_gicp::KdTree<small_gicp::PointCloud>& tree,
                                         double max_dist, int max_iterations) {
  small_gicp::Registration<Factor, small_gicp::SerialReduction> reg;
  reg.rejector.max_dist_sq = max_dist * max_dist;
  reg.optimizer.max_iterations = max_iterations;
  return reg.align(target, source, tree);
}
}  // namespace

PeerIcpResult smallGicpAlign(const std::vector<float>& source, const std::vector<float>& target, bool gicp,
                             double max_dist, int max_iterations) {
  const double t0 = processCpuSeconds();
  auto tgt = toSmallGicp(target), src = toSmallGicp(source);
  auto tree = std::make_shared<small_gicp::KdTree<small_gicp::PointCloud>>(tgt);
  if (gicp) {
    const small_gicp::KdTree<small_gicp::PointCloud> src_tree(src);
    small_gicp::estimate_covariances(*tgt, *tree, 10);
    small_gicp::estimate_covariances(*src, src_tree, 10);
  }
  const double t1 = processCpuSeconds();
  const small_gicp::RegistrationResult r =
      gicp ? alignWith<small_gicp::GICPFactor>(*tgt, *src, *tree, max_dist, max_iterations)
           : alignWith<small_gicp::ICPFactor>(*tgt, *src, *tree, max_dist, max_iterations);
  PeerIcpResult out;
  out.seconds = processCpuSeconds() - t0;
  out.prep_seconds = t1 - t0;
  out.pose = r.T_target_source.matrix();
  out.iterations = static_cast<int>(r.iterations);
  out.converged = r.converged;
  return out;
}

std::unique_ptr<NnMethod> makeSmallGicpKdTree() {
  return std::make_unique<SmallGicpPeer>();
}

}  // namespace dwb
