/// \file nanoflann_peer.cpp
/// \brief nanoflann's KDTreeSingleIndexAdaptor (L2_Simple, leaf size 10: its defaults for 3D) as a
/// peer. Compiled once per nanoflann version (bench/CMakeLists.txt): DW_NANOFLANN_NS renames the
/// library's namespace so that two versions share a process without clashing, DW_NANOFLANN_FACTORY
/// names this unit's factory and DW_NANOFLANN_LABEL the version reported.
// nanoflann 1.4.3's header uses std::uint32_t without including <cstdint>; newer GCCs no longer
// bring it in through other headers.
#include <cstdint>
#define nanoflann DW_NANOFLANN_NS
#include <nanoflann.hpp>
#undef nanoflann

#include <algorithm>

#include "peers/peers.h"

namespace dwb {
namespace {

namespace nf = DW_NANOFLANN_NS;

class NanoflannPeer : public NnMethod {
 public:
  std::string name() const override { return std::string("nanoflann-") + DW_NANOFLANN_LABEL; }
  std::string version() const override { return DW_NANOFLANN_LABEL; }
  bool hasKnn() const override { return true; }
  void build(const std::vector<float>& xyz) override {
    index_.reset();
    cloud_.xyz = xyz;
    // The constructor builds the tree (nanoflann >= 1.4).
    index_ = std::make_unique<Index>(3, cloud_, nf::KDTreeSingleIndexAdaptorParams(10));
  }
  std::size_t memoryBytes() const override {
    return index_ ? index_->usedMemory(*index_) + cloud_.xyz.size() * sizeof(float) : 0;
  }

 protected:
  void nearestRange(const float* q, std::size_t b, std::size_t e, NnBatch& out) override {
    for (std::size_t i = b; i < e; ++i) {
      std::uint32_t idx = 0;
      float d2 = 0;
      nf::KNNResultSet<float, std::uint32_t> rs(1);
      rs.init(&idx, &d2);
      index_->findNeighbors(rs, q + 3 * i, params());
      out.index[i] = static_cast<int>(idx);
      out.dist2[i] = d2;
    }
  }
  void knnRange(const float* q, std::size_t b, std::size_t e, std::size_t k, std::size_t,
                KnnBatch& out) override {
    std::vector<std::uint32_t> idx(k);
    std::vector<float> d2(k);
    for (std::size_t i = b; i < e; ++i) {
      nf::KNNResultSet<float, std::uint32_t> rs(k);
      rs.init(idx.data(), d2.data());
      index_->findNeighbors(rs, q + 3 * i, params());
      store(out, i, idx.data(), d2.data(), rs.size());
    }
  }
  void radiusRange(const float* q, std::size_t b, std::size_t e, float r2, std::size_t,
                   KnnBatch& out) override {
#if NANOFLANN_VERSION >= 0x150
    std::vector<nf::ResultItem<std::uint32_t, float>> m;
    const nf::SearchParameters sp(0.f, false);
#else
    std::vector<std::pair<std::uint32_t, float>> m;
    const nf::SearchParams sp(32, 0.f, false);
#endif
    for (std::size_t i = b; i < e; ++i) {
      // Unsorted, as every peer here: the count and the farthest answer need no order.
      const std::size_t found = index_->radiusSearch(q + 3 * i, r2, m, sp);
      float far2 = 0.f;
      for (std::size_t j = 0; j < found; ++j) far2 = std::max(far2, m[j].second);
      out.count[i] = static_cast<std::uint32_t>(found);
      out.far2[i] = far2;
    }
  }

 private:
#if NANOFLANN_VERSION >= 0x150
  static nf::SearchParameters params() {
    return nf::SearchParameters();
  }
#else
  static nf::SearchParams params() {
    return nf::SearchParams();
  }
#endif
  struct Cloud {
    std::vector<float> xyz;
    std::size_t kdtree_get_point_count() const { return xyz.size() / 3; }
    float kdtree_get_pt(std::size_t i, std::size_t d) const { return xyz[3 * i + d]; }
    template <class BBox>
    bool kdtree_get_bbox(BBox&) const {
      return false;
    }
  };
  using Index = nf::KDTreeSingleIndexAdaptor<nf::L2_Simple_Adaptor<float, Cloud>, Cloud, 3, std::uint32_t>;
  Cloud cloud_;
  std::unique_ptr<Index> index_;
};

}  // namespace

std::unique_ptr<NnMethod> DW_NANOFLANN_FACTORY() {
  return std::make_unique<NanoflannPeer>();
}

}  // namespace dwb
