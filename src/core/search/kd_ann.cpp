#include "pcl_delaunay_walk/core/search/kd_ann.h"

#include <algorithm>
#include <numeric>

namespace dw {

KdAnnLocator::KdAnnLocator(const std::vector<Vec3f>& points, unsigned leaf_size) {
  if (points.empty()) return;
  index_.resize(points.size());
  std::iota(index_.begin(), index_.end(), index_t(0));
  nodes_.reserve(2 * points.size() / std::max(1u, leaf_size) + 1);
  buildNode(points, 0, static_cast<std::uint32_t>(points.size()), std::max(1u, leaf_size));
}

std::uint32_t KdAnnLocator::buildNode(const std::vector<Vec3f>& pts, std::uint32_t begin, std::uint32_t end,
                                      unsigned leaf_size) {
  const std::uint32_t id = static_cast<std::uint32_t>(nodes_.size());
  nodes_.push_back({0.f, begin, end, -1});
  if (end - begin <= leaf_size) return id;
  float lo[3] = {pts[index_[begin]].x, pts[index_[begin]].y, pts[index_[begin]].z};
  float hi[3] = {lo[0], lo[1], lo[2]};
  for (std::uint32_t k = begin; k < end; ++k) {
    const float c[3] = {pts[index_[k]].x, pts[index_[k]].y, pts[index_[k]].z};
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], c[a]);
      hi[a] = std::max(hi[a], c[a]);
    }
  }
  int axis = 0;
  for (int a = 1; a < 3; ++a)
    if (hi[a] - lo[a] > hi[axis] - lo[axis]) axis = a;
  if (hi[axis] == lo[axis]) return id;  // all equal along every axis: keep as one leaf
  auto coord = [&](index_t v) { return axis == 0 ? pts[v].x : axis == 1 ? pts[v].y : pts[v].z; };
  const std::uint32_t mid = begin + (end - begin) / 2;
  std::nth_element(index_.begin() + begin, index_.begin() + mid, index_.begin() + end,
                   [&](index_t a, index_t b) { return coord(a) < coord(b); });
  const float split = coord(index_[mid]);
  const std::uint32_t left = buildNode(pts, begin, mid, leaf_size);
  const std::uint32_t right = buildNode(pts, mid, end, leaf_size);
  nodes_[id] = {split, left, right, axis};
  return id;
}

index_t KdAnnLocator::locate(const Vec3f& q, const std::vector<Vec3f>& pts) const {
  if (nodes_.empty()) return kInvalidIndex;
  std::uint32_t n = 0;
  while (nodes_[n].axis >= 0) {
    const Node& node = nodes_[n];
    const float c = node.axis == 0 ? q.x : node.axis == 1 ? q.y : q.z;
    n = c < node.split ? node.a : node.b;
  }
  index_t best = index_[nodes_[n].a];
  float best_d2 = squaredDistance(q, pts[best]);
  for (std::uint32_t k = nodes_[n].a + 1; k < nodes_[n].b; ++k) {
    const float d2 = squaredDistance(q, pts[index_[k]]);
    if (d2 < best_d2) {
      best_d2 = d2;
      best = index_[k];
    }
  }
  return best;
}

}  // namespace dw
