/// \file pico_tree_peer.cpp
/// \brief pico_tree's static kd_tree as a peer: float points in a std::vector of std::array, squared
/// L2 metric, leaf size 10 (the setting of its own benchmarks), its default sliding-midpoint rule.
#include <algorithm>
#include <array>
#include <pico_tree/array_traits.hpp>
#include <pico_tree/kd_tree.hpp>
#include <pico_tree/vector_traits.hpp>

#include "peers/peers.h"

namespace dwb {
namespace {

class PicoTreePeer : public NnMethod {
 public:
  std::string name() const override { return "pico_tree-" DW_PICO_TREE_LABEL; }
  std::string version() const override { return DW_PICO_TREE_LABEL; }
  bool hasKnn() const override { return true; }
  void build(const std::vector<float>& xyz) override {
    tree_.reset();
    Space pts(xyz.size() / 3);
    for (std::size_t i = 0; i < pts.size(); ++i) pts[i] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
    tree_ = std::make_unique<Tree>(std::move(pts), pico_tree::max_leaf_size_t(10));
  }

 protected:
  void nearestRange(const float* q, std::size_t b, std::size_t e, NnBatch& out) override {
    Tree::neighbor_type nn;
    for (std::size_t i = b; i < e; ++i) {
      tree_->search_nn(Point{q[3 * i], q[3 * i + 1], q[3 * i + 2]}, nn);
      out.index[i] = nn.index;
      out.dist2[i] = nn.distance;
    }
  }
  void knnRange(const float* q, std::size_t b, std::size_t e, std::size_t k, std::size_t,
                KnnBatch& out) override {
    std::vector<Tree::neighbor_type> nbrs;
    std::vector<int> idx(k);
    std::vector<float> d2(k);
    for (std::size_t i = b; i < e; ++i) {
      tree_->search_knn(Point{q[3 * i], q[3 * i + 1], q[3 * i + 2]}, k, nbrs);
      for (std::size_t j = 0; j < nbrs.size(); ++j) idx[j] = nbrs[j].index, d2[j] = nbrs[j].distance;
      store(out, i, idx.data(), d2.data(), nbrs.size());
    }
  }
  void radiusRange(const float* q, std::size_t b, std::size_t e, float r2, std::size_t,
                   KnnBatch& out) override {
    std::vector<Tree::neighbor_type> nbrs;
    for (std::size_t i = b; i < e; ++i) {
      tree_->search_radius(Point{q[3 * i], q[3 * i + 1], q[3 * i + 2]}, r2, nbrs, false);
      float far2 = 0.f;
      for (const auto& n : nbrs) far2 = std::max(far2, n.distance);
      out.count[i] = static_cast<std::uint32_t>(nbrs.size());
      out.far2[i] = far2;
    }
  }

 private:
  using Point = std::array<float, 3>;
  using Space = std::vector<Point>;
  using Tree = pico_tree::kd_tree<Space>;
  std::unique_ptr<Tree> tree_;
};

}  // namespace

std::unique_ptr<NnMethod> makePicoTree() {
  return std::make_unique<PicoTreePeer>();
}

}  // namespace dwb
