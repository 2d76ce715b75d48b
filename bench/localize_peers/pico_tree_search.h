/// \file pico_tree_search.h
/// \brief pico_tree's static kd_tree as the ICP loop's correspondence search (dw_localize_bench only).
///
/// The tree indexes the caller's float array in place through pico_tree's space_map, as nanoflann's
/// adaptor does, so the map is never copied; leaf size 10 and the default sliding-midpoint rule, the
/// setting of pico_tree's own benchmarks and of the nanoflann row. Its metric is squared L2 in float,
/// like the walk's, so the loop's poses must equal the walk's (the bench prints the difference).
#pragma once

#include <cmath>
#include <cstdint>
#include <pico_tree/kd_tree.hpp>
#include <pico_tree/map_traits.hpp>
#include <vector>

#include "pcl_delaunay_walk/core/registration/icp.h"

namespace dw_bench {

/// Version label of the copy in ../shared/peers (its README): the last release plus the commit.
inline constexpr const char* kPicoTreeLabel = "pico_tree 1.0.0+ @3796726";

class PicoTreeSearch final : public dw::CorrespondenceSearch {
 public:
  /// Builds the tree over `xyz` (3 floats a point), which must outlive the search.
  explicit PicoTreeSearch(const std::vector<float>& xyz)
      : xyz_(xyz), tree_(Space(xyz.data(), xyz.size() / 3), pico_tree::max_leaf_size_t(10)) {}

  std::size_t size() const override { return xyz_.size() / 3; }
  const float* point(std::size_t i) const override { return &xyz_[3 * i]; }

  bool nearest(const float q[3], dw::index_t&, std::int32_t& index, float& dist2) const override {
    if (size() == 0 || !std::isfinite(q[0]) || !std::isfinite(q[1]) || !std::isfinite(q[2])) return false;
    Tree::neighbor_type nn;
    tree_.search_nn(Point(q), nn);
    index = std::int32_t(nn.index);
    dist2 = nn.distance;
    return true;
  }

 private:
  using Point = pico_tree::point_map<const float, 3>;
  using Space = pico_tree::space_map<Point>;
  using Tree = pico_tree::kd_tree<Space>;

  const std::vector<float>& xyz_;
  Tree tree_;
};

}  // namespace dw_bench
