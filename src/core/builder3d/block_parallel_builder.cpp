// Block-parallel Delaunay edges: blocks + certified, growing halos. See block_parallel_builder.h.
#include "block_parallel_builder.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <limits>

#include "core/geometry/rounded_circumsphere.h"
#include "core/graph/cell_grid.h"
#include "halo_certification.h"
#include "insertion_order.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "triangulation_3d.h"

namespace dw {
namespace builder3d {
namespace {

/// The cells of all points (about 4 per cell on volumetric data): a CellGrid over their bounding box
/// and, per cell, its points (CSR).
struct PointCells {
  CellGrid grid;
  std::vector<std::uint32_t> cell_of;  // per point
  std::vector<std::uint32_t> start;    // CSR over cells
  std::vector<index_t> members;

  explicit PointCells(const std::vector<Vec3f>& p) {
    const std::size_t n = p.size();
    double lo[3] = {p[0].x, p[0].y, p[0].z}, hi[3] = {p[0].x, p[0].y, p[0].z};
    for (const Vec3f& q : p) {
      const double c[3] = {q.x, q.y, q.z};
      for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], c[k]), hi[k] = std::max(hi[k], c[k]);
    }
    double ext[3], vol = 1.0, emax = 0.0;
    for (int k = 0; k < 3; ++k) {
      ext[k] = hi[k] - lo[k];
      emax = std::max(emax, ext[k]);
    }
    for (int k = 0; k < 3; ++k) vol *= std::max(ext[k], emax * 1e-3);
    double cell = std::max(std::cbrt(vol / std::max<double>(1.0, double(n) / 4.0)), emax / 1024.0);
    if (!(cell > 0.0)) cell = 1.0;
    for (int k = 0; k < 3; ++k) {
      grid.base[k] = lo[k];
      grid.dims[k] = std::max(1, std::min(1024, int(std::ceil(ext[k] / cell)) + 1));
    }
    grid.width = cell;
    cell_of.resize(n);
    start.assign(grid.numCells() + 1, 0);
    for (std::size_t i = 0; i < n; ++i) {
      cell_of[i] = grid.index(grid.coord(p[i].x, 0), grid.coord(p[i].y, 1), grid.coord(p[i].z, 2));
      ++start[cell_of[i] + 1];
    }
    for (std::size_t c = 0; c < grid.numCells(); ++c) start[c + 1] += start[c];
    members.resize(n);
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < n; ++i) members[fill[cell_of[i]]++] = static_cast<index_t>(i);
  }
};

/// One block: its own vertex range, the cells it holds completely, its kernel.
class Block {
 public:
  Block(const std::vector<Vec3f>& points, const PointCells& cells, std::size_t first, std::size_t last)
      : points_(points),
        cells_(cells),
        grid_(cells.grid),
        first_(first),
        last_(last),
        covered_(cells.grid.numCells(), 0) {}

  // Own cells plus one ring of cells around them, triangulated.
  void triangulate() {
    std::vector<std::uint32_t> own;
    for (std::size_t i = first_; i < last_; ++i) {
      const std::uint32_t c = cells_.cell_of[i];
      if (!covered_[c]) {
        covered_[c] = 1;
        own.push_back(c);
      }
    }
    std::vector<index_t> ids;
    for (std::uint32_t c : own) grid_.forRing(c, [&](std::uint32_t nc) { covered_[nc] = 1; });
    for (std::size_t c = 0; c < grid_.numCells(); ++c)
      if (covered_[c])
        ids.insert(ids.end(), cells_.members.begin() + cells_.start[c],
                   cells_.members.begin() + cells_.start[c + 1]);
    halo_points_ = ids.size() - (last_ - first_);
    const std::vector<index_t> order = brioOrder(points_, std::move(ids));
    kernel_.setPoints(points_.data(), points_.size());
    kernel_.trackBirths(true);
    kernel_.build(order.data(), order.size());
  }

  std::vector<index_t> hullVertices() const { return kernel_.hullVertices(); }

  // Grows the halo until every finite tetrahedron around the block's own vertices is certified, then
  // inserts the global hull boundary points it lacks (so its infinite tetrahedra are global ones) and
  // grows again. Hull points come last: inserted early they would join the block's vertices to far
  // away points through the still-thin halo, and those huge spheres would pull in most of the cloud.
  void certify(const std::vector<index_t>& hull) {
    grow();
    for (index_t h : hull)
      if (!covered_[cells_.cell_of[h]]) {
        kernel_.insert(h);
        extra_.push_back(h);
      }
    std::sort(extra_.begin(), extra_.end());
    halo_points_ += extra_.size();
    grow();
  }

  std::vector<std::pair<index_t, index_t>> edges() const { return kernel_.edgesFrom(first_, last_); }
  std::size_t haloPoints() const { return halo_points_; }

  // Certification passes (halo_certification.h): a tetrahedron whose ball holds points of cells not
  // yet held grows the halo by those whole cells; the global hull points already inserted are skipped.
  void grow() {
    std::vector<std::uint32_t> grown;
    passes_.run(
        kernel_, static_cast<index_t>(first_), static_cast<index_t>(last_),
        [&](const index_t* tv, unsigned, std::size_t) {
          const std::size_t before = grown.size();
          missingUnderBall(tv, grown);
          return grown.size() != before ? HaloVerdict::kConflict : HaloVerdict::kCertified;
        },
        [&] { return insertCells(grown); });
  }

  std::size_t rounds() const { return passes_.rounds(); }

 private:
  // Inserts the points of the grown cells (in Morton order: short walks between insertions) and
  // returns how many cells grew, which ends the passes when 0.
  std::size_t insertCells(std::vector<std::uint32_t>& grown) {
    std::vector<index_t> ids;
    for (std::uint32_t c : grown)
      for (std::uint32_t k = cells_.start[c]; k < cells_.start[c + 1]; ++k) {
        const index_t id = cells_.members[k];
        if (!std::binary_search(extra_.begin(), extra_.end(), id)) ids.push_back(id);
      }
    std::sort(ids.begin(), ids.end());
    for (index_t id : ids) kernel_.insert(id);
    halo_points_ += ids.size();
    const std::size_t cells = grown.size();
    grown.clear();
    return cells;
  }

  // Appends (and marks held) every cell not yet held that has a point inside the circumsphere of the
  // finite tetrahedron tv, enlarged by a bound on the rounding of its centre and radius. When none
  // has, every point of the ball is in the kernel: the tetrahedron is certified.
  void missingUnderBall(const index_t* tv, std::vector<std::uint32_t>& grown) {
    const RoundedCircumsphere ball =
        roundedCircumsphere(points_[tv[0]], points_[tv[1]], points_[tv[2]], points_[tv[3]], grid_.width);
    const double R = ball.radius;
    int range[3][2];
    grid_.cellsUnderBall(ball.centre, R, ball.unbounded(), 0.0, range);
    const double* centre = ball.centre;
    const bool all = !std::isfinite(R);
    const double R2 = R * R;
    for (int x = range[0][0]; x <= range[0][1]; ++x)
      for (int y = range[1][0]; y <= range[1][1]; ++y)
        for (int z = range[2][0]; z <= range[2][1]; ++z) {
          const std::uint32_t c = grid_.index(std::uint32_t(x), std::uint32_t(y), std::uint32_t(z));
          if (covered_[c] || cells_.start[c] == cells_.start[c + 1]) continue;
          if (!all) {
            // Skip cells whose box misses the ball: huge spheres of hull slivers only cut a cap.
            const int xyz[3] = {x, y, z};
            double d2 = 0.0;
            for (int k = 0; k < 3; ++k) {
              const double b0 = grid_.base[k] + xyz[k] * grid_.width, b1 = b0 + grid_.width;
              const double d = centre[k] < b0 ? b0 - centre[k] : (centre[k] > b1 ? centre[k] - b1 : 0.0);
              d2 += d * d;
            }
            if (d2 > R2 * (1.0 + 1e-12)) continue;
          }
          bool inside = all;
          for (std::uint32_t k = cells_.start[c]; k < cells_.start[c + 1] && !inside; ++k) {
            const Vec3f& q = points_[cells_.members[k]];
            const double dx = q.x - centre[0], dy = q.y - centre[1], dz = q.z - centre[2];
            inside = dx * dx + dy * dy + dz * dz <= R2;
          }
          if (!inside) continue;
          covered_[c] = 1;
          grown.push_back(c);
        }
  }

  const std::vector<Vec3f>& points_;
  const PointCells& cells_;
  const CellGrid& grid_;
  std::size_t first_, last_;
  std::vector<std::uint8_t> covered_;  // cells whose points are all in the kernel
  std::vector<index_t> extra_;         // global hull points inserted outside the held cells, sorted
  Triangulation3D kernel_;
  HaloCertification passes_;
  std::size_t halo_points_ = 0;
};

// One worker per block: the blocks are as many as the workers and of similar cost.
template <class Fn>
void forEachBlock(std::size_t count, Fn&& fn) {
  parallelFor(count, static_cast<unsigned>(count), [&](std::size_t b, std::size_t e, unsigned) {
    for (; b < e; ++b) fn(b);
  });
}

}  // namespace

EdgeList blockParallelDelaunayEdges(const std::vector<Vec3f>& points, unsigned num_blocks,
                                    BlockBuildStats* stats) {
  const std::size_t n = points.size();
  if (num_blocks <= 1 || n < 5) {
    Triangulation3D k;
    k.setPoints(points.data(), n);
    const std::vector<index_t> order = brioOrder(points);
    k.build(order.data(), order.size());
    if (stats) *stats = BlockBuildStats{1, 0, 0, 0};
    return Triangulation3D::joinChunks(k.releaseIntoEdgeChunks(1));
  }
  const PointCells cells(points);
  std::vector<Block> blocks;
  blocks.reserve(num_blocks);
  for (unsigned b = 0; b < num_blocks; ++b)
    blocks.emplace_back(points, cells, n * b / num_blocks, n * (b + 1) / num_blocks);

  // Map: every block triangulates its cells plus one ring.
  forEachBlock(num_blocks, [&](std::size_t b) { blocks[b].triangulate(); });

  // The global hull: its boundary points lie on some block's local hull boundary.
  std::vector<index_t> candidates;
  for (const Block& b : blocks) {
    const auto h = b.hullVertices();
    candidates.insert(candidates.end(), h.begin(), h.end());
  }
  std::sort(candidates.begin(), candidates.end());
  candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
  std::vector<index_t> hull;
  {
    Triangulation3D k;
    k.setPoints(points.data(), n);
    const std::vector<index_t> order = brioOrder(points, candidates);
    k.build(order.data(), order.size());
    hull = k.hullVertices();
  }
  // Every block inserts the whole hull boundary: where that is a large part of the cloud (points on a
  // convex surface such as a sphere) blocks would each redo most of the work. Sequential is faster.
  if (hull.size() > n / 16) {
    blocks.clear();
    return blockParallelDelaunayEdges(points, 1, stats);
  }

  // Certify: grow halos until every tetrahedron around a block's own vertices is global.
  std::vector<std::vector<std::pair<index_t, index_t>>> parts(num_blocks);
  forEachBlock(num_blocks, [&](std::size_t b) {
    blocks[b].certify(hull);
    parts[b] = blocks[b].edges();
  });
  if (stats) {
    *stats = BlockBuildStats{num_blocks, 0, hull.size(), 0};
    for (const Block& b : blocks) {
      stats->halo_points += b.haloPoints();
      stats->growth_rounds = std::max(stats->growth_rounds, b.rounds());
    }
  }
  blocks.clear();
  std::size_t total = 0;
  for (const auto& p : parts) total += p.size();
  EdgeList edges;
  edges.reserve(total);
  for (auto& p : parts) {
    edges.insert(edges.end(), p.begin(), p.end());
    std::vector<std::pair<index_t, index_t>>().swap(p);
  }
  return edges;
}

}  // namespace builder3d
}  // namespace dw
