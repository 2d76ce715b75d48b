/// \file kd_ann.h
/// \brief KD-ANN start locator: a k-d tree over the graph vertices descended once, without
/// backtracking (seed §4). Approximate by design; the walk that follows makes the answer exact.
#pragma once

#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {

class KdAnnLocator {
 public:
  KdAnnLocator() = default;
  /// Builds over `points` (vertex order kept; the tree stores indices). Leaves hold <= leaf_size points.
  explicit KdAnnLocator(const std::vector<Vec3f>& points, unsigned leaf_size = 8);

  /// Vertex of the descended leaf nearest to q (a linear scan of that one leaf).
  index_t locate(const Vec3f& q, const std::vector<Vec3f>& points) const;
  bool empty() const { return nodes_.empty(); }

 private:
  struct Node {
    float split;        ///< split value (inner) ; unused in leaves
    std::uint32_t a;    ///< inner: left child; leaf: begin into index_
    std::uint32_t b;    ///< inner: right child; leaf: end into index_
    std::int32_t axis;  ///< 0..2 inner, -1 leaf
  };
  std::uint32_t buildNode(const std::vector<Vec3f>& points, std::uint32_t begin, std::uint32_t end,
                          unsigned leaf_size);
  std::vector<Node> nodes_;
  std::vector<index_t> index_;
};

}  // namespace dw
