/// \file prepare_vertices.h
/// \brief The input preparation of the graph build: finite scan, centring, Morton key and order, and
/// the collapse of exact duplicates into one vertex. The distributed builder (src/mpi) replays the same
/// quantisation and order across ranks, so both share the pieces below.
#pragma once

#include <algorithm>
#include <cstdint>

#include "core/util/space_filling_curve.h"
#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"
#include "pcl_delaunay_walk/core/graph/point_view.h"

namespace dw {
namespace detail {

/// Largest supported extent along any axis: its square must stay well inside float range.
constexpr double kMaxExtent = 1e18;

/// Sets `origin` to the centre of the box [lo, hi] and returns the box's largest extent. Centring is
/// what keeps Qhull correct on georeferenced input, and float storage precise. Throws dw::Error when
/// an axis spans more than kMaxExtent (float squared distances would overflow).
double centreOfBox(const double lo[3], const double hi[3], double origin[3]);

/// The Morton quantisation: a float local position, back in world coordinates, scaled onto 21 bits per
/// axis over the finite points' bounding box. The key comes from the float position, so inputs that
/// round to one float position get equal keys and end up adjacent in the sort.
struct MortonQuantiser {
  double origin[3] = {0, 0, 0};
  double lo[3] = {0, 0, 0};
  double steps = 0;  ///< quantisation steps per unit of length: (2^21 - 1) / largest extent

  MortonQuantiser() = default;
  MortonQuantiser(const double o[3], const double box_lo[3], double extent) {
    for (int a = 0; a < 3; ++a) origin[a] = o[a], lo[a] = box_lo[a];
    steps = extent > 0 ? double((1u << 21) - 1) / extent : 0.0;
  }
  void cells(const Vec3f& local, std::uint32_t q[3]) const {
    const double fp[3] = {double(local.x) + origin[0], double(local.y) + origin[1],
                          double(local.z) + origin[2]};
    for (int a = 0; a < 3; ++a)
      q[a] = static_cast<std::uint32_t>(std::clamp((fp[a] - lo[a]) * steps, 0.0, double((1u << 21) - 1)));
  }
  std::uint64_t key(const Vec3f& local) const {
    std::uint32_t q[3];
    cells(local, q);
    return mortonKey(q[0], q[1], q[2]);
  }
};

/// One input point on its way to a vertex: Morton key, float local position, input index.
struct MortonItem {
  std::uint64_t key;
  Vec3f p;
  index_t input;
};

/// The vertex order: (key, x, y, z, input index). Total, so the same for every thread and rank count;
/// exact duplicates are adjacent in it.
inline bool mortonItemLess(const MortonItem& a, const MortonItem& b) {
  if (a.key != b.key) return a.key < b.key;
  if (a.p.x != b.p.x) return a.p.x < b.p.x;
  if (a.p.y != b.p.y) return a.p.y < b.p.y;
  if (a.p.z != b.p.z) return a.p.z < b.p.z;
  return a.input < b.input;
}

inline bool samePosition(const Vec3f& a, const Vec3f& b) {
  return a.x == b.x && a.y == b.y && a.z == b.z;
}

/// Fills g's origin, points (distinct float positions in Morton order), originals, originals_offsets and
/// input_to_vertex from the view, on `threads` threads in blocks joined in block order, so the result is
/// the same for any thread count. Returns false (g holding only input_to_vertex) when no input point
/// is finite.
bool prepareVertices(const PointView& view, unsigned threads, DelaunayGraph& g);

}  // namespace detail
}  // namespace dw
