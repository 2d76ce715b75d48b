/// \file parallel_insertion.h
/// \brief Private to the 3D triangulation: the ownership policy of a parallel pass's threads, which
/// the insertion (triangulation_3d.cpp) inlines and the passes (parallel_insertion.cpp) set up.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/builder3d/triangulation_3d.h"

namespace dw {
namespace builder3d {

// Fresh slots handed to a thread at a time. Only taken chunks are written (and so mapped); a thread's
// last chunk is partly unused, and with 1024 (when the whole range was written up front) the pass's
// slack of three chunks per thread held 4 B/pt of the dragon's peak at 16 threads.
constexpr std::size_t kSlotChunk = 256;

// The cells of one parallel pass: a k-d split of the pending points, one leaf per thread, each with
// the same number of points. Nodes are {direction, split, child below, child at or above}; direction
// -1 marks a leaf, whose `below` is the thread.
//
// Every pass after the first cuts along other directions. What a pass defers lies in thin sheets along
// its cuts; a later pass that cut along the same directions put its medians into those very sheets
// (measured at 16 threads on 1M points: third passes that inserted 11-17 % of their points, even with
// the cuts moved to gaps beside the sheets, which only placed them at a sheet's edge). Cut along other
// directions, an earlier sheet spreads over the whole range of the new coordinate, and only the lines
// where a new cut crosses it are deferred again (third passes then insert ~74 %). The directions have
// small integer components, so a float point's coordinate along one (three exact products summed in
// double in a fixed order) is the same wherever it is computed, with or without fused multiply-adds:
// every call site agrees on who owns a vertex.
struct Triangulation3D::CellSplit {
  struct Node {
    int direction;
    double split;
    unsigned below, above;
  };
  std::vector<Node> nodes;
  const double (*directions)[3] = nullptr;

  // Pass 0 cuts along the axes, later passes along orthogonal triples with one body diagonal each.
  // What two passes in a row leave lies along the line where their first cuts cross; the next pass's
  // first direction is independent of theirs, so its cut crosses that line instead of containing it
  // (in the order (1,0,0), (1,1,1), (-1,1,1): two threads' third pass inserted 26 % of the
  // points left, in this order 93 %).
  static constexpr double kDirections[5][3][3] = {
      {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}},    {{1, 1, 1}, {1, -1, 0}, {1, 1, -2}},
      {{1, -1, 1}, {1, 0, -1}, {1, 2, 1}},  {{-1, 1, 1}, {0, 1, -1}, {2, 1, 1}},
      {{1, 1, -1}, {1, 0, 1}, {1, -2, -1}},
  };

  double coordinate(const Vec3f& p, int direction) const {
    // Pass 0 reads the point's own coordinate (every point's cell is found once per pass, and a sparse
    // pass descends at each of its ~40 ownership tests per insertion).
    if (directions == kDirections[0]) return direction == 0 ? p.x : direction == 1 ? p.y : p.z;
    const double* d = directions[direction];
    return double(p.x) * d[0] + double(p.y) * d[1] + double(p.z) * d[2];
  }

  unsigned cellOf(const Vec3f& p) const {
    unsigned i = 0;
    while (nodes[i].direction >= 0)
      i = coordinate(p, nodes[i].direction) < nodes[i].split ? nodes[i].below : nodes[i].above;
    return nodes[i].below;
  }

  // The cells of pass `pass`: points[0..m) split among `count` threads, level by level. A segment is
  // split at the median of its coordinates along the level's direction (points equal to it go above),
  // its first `count / 2` threads below; the segments of a level are split on up to `workers` threads.
  // Each segment's keys are computed once, not at each comparison of the selection (a pass's cut, on
  // one thread, took 2-6 ms of its set-up on 16 device threads).
  void build(const Vec3f* points, std::size_t m, unsigned count, unsigned pass, unsigned workers);
};

// A thread of a parallel pass owns the vertices in its cell, and the tetrahedra whose four vertices
// it owns; the infinite vertex counts as everybody's. Only the owner changes a tetrahedron's vertices.
// A thread writes a neighbour code only across a face whose vertices it owns, and two faces of one
// tetrahedron always share a finite vertex, so every such code has one writer. A thread reads only
// tetrahedra it owns or that nobody owns (all share an owned face with one it owns), which nobody else
// writes, so those reads are plain; so are all neighbour codes, since no thread reads another's. The
// exceptions are a walk's start, a tetrahedron found through vertex_tet_ (ownsTet, startAtVertex),
// which may be another thread's: those reads, and every write of a vertex slot or of vertex_tet_ that
// they may meet, are relaxed atomics (plain moves on x86, but defined behaviour and TSan-clean).
struct Triangulation3D::Cell {
  static constexpr bool kShared = true;
  const CellSplit* split = nullptr;
  const Vec3f* points = nullptr;
  const std::uint8_t* cell_of = nullptr;  // every point's cell in this pass, when the pass has one
  std::size_t n = 0;
  unsigned me = 0;
  bool ownsVertex(index_t v) const {
    if (v >= n) return v == kInfinite;  // not kDead
    return cellOf(v) == me;
  }
  unsigned cellOf(index_t v) const { return cell_of != nullptr ? cell_of[v] : split->cellOf(points[v]); }
};

}  // namespace builder3d
}  // namespace dw
