/// \file dynamic_delaunay_graph.h
/// \brief A walk graph for sliding-window maps: points are added to and removed from the
/// reference without re-triangulating, and the walk graph of the live points is made from the kept
/// 3D Delaunay triangulation.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <unordered_map>
#include <vector>

#include "pcl_delaunay_walk/core/graph/delaunay_graph.h"
#include "pcl_delaunay_walk/core/graph/point_view.h"

namespace dw {

namespace builder3d {
class Triangulation3D;
}

/// Owns a changing point set and its 3D Delaunay triangulation.
///
/// - Every inserted point gets a PointId, never reused. Internally points live in slots (the kernel's
///   vertex ids); a removed point's slot is recycled by a later insertion, so memory and the cost of
///   graph() follow the live set, not the whole history.
/// - insert() adds the points to the triangulation (Bowyer-Watson), remove() deletes them
///   (Triangulation3D::remove). The triangulation always equals a fresh build of the live points with
///   the same slot ids, so graph() gives what buildDelaunayGraph gives for the live points: the same
///   edge set on input in general position; on cospherical ties both are valid Delaunay graphs (the
///   choice follows the ids) and the walk, kNN and radius search are exact on either.
/// - While the live points do not span 3D (fewer than 4, coplanar, collinear) there is no
///   triangulation and graph() falls back to buildDelaunayGraph on the live points, which handles
///   those sets exactly (planar sets by the exact 2D engine of dw::tin); the triangulation is
///   built as soon as the points span 3D again.
/// - Coordinates are stored as float relative to a double origin (docs/architecture.md, "The walk
///   graph"). Choose an origin near the data: float keeps about 7 significant digits of the offset from it.
/// - Bad input (NaN/Inf, a point equal to a live point or to another in the same batch, an unknown or
///   repeated id) throws dw::Error before anything changes.
///
/// Not thread-safe for concurrent modification; graph() may run while nothing modifies.
class DynamicDelaunayGraph {
 public:
  using PointId = std::uint64_t;
  static constexpr PointId kNoId = ~PointId(0);

  /// The origin is taken from the first non-empty insertion (the centre of its bounding box).
  DynamicDelaunayGraph();
  /// A fixed origin for the local float frame.
  explicit DynamicDelaunayGraph(const std::array<double, 3>& origin);
  // The kernel reads the point array in place: a copy would read the original's.
  DynamicDelaunayGraph(const DynamicDelaunayGraph&) = delete;
  DynamicDelaunayGraph& operator=(const DynamicDelaunayGraph&) = delete;
  DynamicDelaunayGraph(DynamicDelaunayGraph&&) noexcept;
  DynamicDelaunayGraph& operator=(DynamicDelaunayGraph&&) noexcept;
  ~DynamicDelaunayGraph();

  /// Adds the points (caller coordinates) and returns their ids, in input order. All or nothing.
  std::vector<PointId> insert(const PointView& points);

  /// Removes the points with these ids. All or nothing.
  void remove(const std::vector<PointId>& ids);

  /// Number of live points.
  std::size_t size() const { return slot_of_.size(); }
  bool contains(PointId id) const { return slot_of_.count(id) != 0; }
  /// Live ids, ascending (the input order of graph()).
  std::vector<PointId> liveIds() const;
  /// The live point whose float position in the local frame is exactly `local`, or kNoId.
  PointId idAt(const Vec3f& local) const;
  /// Caller coordinates of a live point (its float position plus the origin). Throws for unknown ids.
  std::array<double, 3> position(PointId id) const;

  /// Whether the live points span 3D, so that a triangulation is kept.
  bool triangulated() const { return triangulated_; }
  const std::array<double, 3>& origin() const { return origin_; }

  /// The walk graph of the live points: input i of the graph is the point liveIds()[i], also written
  /// to `input_ids` when given. O(live points + tetrahedra), one thread; `num_threads` is passed to
  /// buildDelaunayGraph while the points do not span 3D.
  DelaunayGraph graph(std::vector<PointId>* input_ids = nullptr, unsigned num_threads = 1) const;

  /// The walk graph of the live points, kept up to date across insert() and remove(): each
  /// neighbourhood is kept per point, and only the points whose Delaunay star changed since the last
  /// call are re-read from the triangulation (their star alone); the graph is then laid out from the
  /// kept neighbourhoods, O(live points + edges) copying and no pass over the tetrahedra. Vertex v
  /// and input v are the live point in the v-th smallest slot; `input_ids` (when given) receives
  /// their ids in that order. As a graph over point ids it equals graph(): the same neighbours, the
  /// same edge records (only vertex numbers differ). While the points do not span 3D it is graph().
  /// The returned graph does not change afterwards; while the caller holds it, the next call lays
  /// out a new one, otherwise it reuses its storage.
  DelaunayGraph::ConstPtr walkGraph(std::vector<PointId>* input_ids = nullptr);
  /// Points whose neighbourhood the last walkGraph() re-read (all live points on the first call and
  /// after the triangulation was rebuilt).
  std::size_t lastRefreshed() const { return last_refreshed_; }

  /// Checks the triangulation (Triangulation3D::validate) and the id bookkeeping; throws dw::Error.
  void validate() const;

  /// For tests and diagnostics: the kernel, and a live point's slot (its vertex id in the kernel and
  /// the index of its float position in slotPoints()).
  /// (The kernel's type is internal: tests reach it through the private include directory.)
  const builder3d::Triangulation3D& kernel() const { return *kernel_; }
  index_t slotOf(PointId id) const;
  const std::vector<Vec3f>& slotPoints() const { return points_; }

 private:
  struct PositionHash {
    std::size_t operator()(const std::array<std::uint32_t, 3>& k) const;
  };
  using PositionKey = std::array<std::uint32_t, 3>;
  static PositionKey keyOf(const Vec3f& p);
  std::vector<index_t> liveSlots() const;
  void rebuildIfSpans3D();
  // The finite vertices adjacent to slot s (each once) into link_, given a tetrahedron holding s.
  void collectLink(index_t s, index_t root);
  // Marks s and (when `neighbours`) every vertex adjacent to it as needing its neighbourhood re-read.
  void markDirty(index_t s, bool neighbours);
  // Re-reads the neighbourhoods of the dirty slots (all live ones after a rebuild): star by star, or
  // for many of them in one pass over the tetrahedra (refreshByScan).
  void refreshDirty();
  void refreshByScan();
  // Writes slot s's edge records from link_ (its distinct neighbours).
  void recordNeighbourhood(index_t s);
  void layOutWalkGraph(DelaunayGraph& g, std::vector<PointId>* input_ids);

  std::array<double, 3> origin_{{0.0, 0.0, 0.0}};
  bool have_origin_ = false;
  std::vector<Vec3f> points_;     // per slot, local frame
  std::vector<PointId> slot_id_;  // per slot; kNoId for a free slot
  std::vector<index_t> free_slots_;
  std::unordered_map<PointId, index_t> slot_of_;
  std::unordered_map<PositionKey, index_t, PositionHash> slot_at_;  // live positions, for duplicates
  PointId next_id_ = 0;
  std::unique_ptr<builder3d::Triangulation3D> kernel_;  // null only in a moved-from graph
  bool triangulated_ = false;

  // walkGraph()'s state. Per slot: the neighbourhood as edge records whose j is the neighbour's
  // slot, in (m, slot) order; renumbering the live slots in ascending order keeps that order, so the
  // laid-out graph has the documented (m, j) order without sorting.
  std::vector<std::vector<EdgeRecord>> neighbourhood_;
  std::vector<std::uint8_t> dirty_;  // per slot
  std::vector<index_t> dirty_list_;  // the slots with dirty_ set (some may have died since)
  bool all_dirty_ = true;            // the triangulation was (re)built: re-read every point
  std::size_t last_refreshed_ = 0;
  std::vector<std::uint32_t> tet_seen_, slot_seen_;  // per tetrahedron / slot: stamp of the last visit
  std::uint32_t stamp_ = 0;
  std::vector<index_t> star_, link_;                 // collectLink's scratch and result
  std::vector<std::size_t> scan_start_, scan_fill_;  // refreshByScan's buckets, per slot
  std::vector<index_t> scan_bucket_;
  std::vector<std::uint64_t> record_keys_;  // recordNeighbourhood's sort keys
  std::shared_ptr<DelaunayGraph> walk_graph_;
  std::vector<index_t> vertex_of_slot_;
};

}  // namespace dw
