/// \file distributed_graph.cpp
/// \brief The distributed 3D graph builder: range read, Morton sample sort across ranks, the single-
/// process input preparation replayed on the distributed points, then one certified block per rank
/// whose halo cells are fetched from their owners round by round (distributed_graph.h, docs/mpi.md).
#include "pcl_delaunay_walk/mpi/distributed_graph.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>

#include "core/geometry/vec3d.h"
#include "core/graph/prepare_vertices.h"
#include "mpi/collectives.h"
#include "mpi/fault_injection.h"
#include "mpi/rank_block.h"

namespace dw {
namespace mpi {
namespace {

using collective::allGather;
using collective::gatherTo0;
using collective::toInt;
using detail::MortonCellGrid;
using detail::RankBlock;
using detail::since;
using detail::SparsePoints;
using detail::Triangulation3D;
using dw::detail::MortonItem;
static_assert(sizeof(MortonItem) == 24, "MortonItem travels as bytes");

/// Global (first occurrence) argmax of a per-vertex value: each rank offers its best value, the global
/// id of its first occurrence and that vertex; the smallest id among equal maxima wins, as in a
/// sequential scan in id order.
struct Best {
  double value;
  std::uint64_t id;
  Vec3f p;
  float pad;
};
Best globalBest(MPI_Comm comm, const Best& mine) {
  const std::vector<Best> all = allGather(comm, std::vector<Best>{mine});
  Best b = all[0];
  for (const Best& o : all)
    if (o.value > b.value || (o.value == b.value && o.id < b.id)) b = o;
  return b;
}

/// The single-process affine-dimension test (toleranceAffineDimension, geometry/affine_span.h) on the
/// distributed vertices, with the same operations in the same order, so that it decides the same way: returns
/// the dimension at relative tolerances 1e-9 and 1e-6.
std::pair<int, int> distributedDimension(MPI_Comm comm, const std::vector<Vec3f>& p, std::uint64_t first) {
  // Vertex 0 lives on the first rank with vertices (the only one with vertices and first id 0).
  const bool has0 = !p.empty() && first == 0;
  const Best b0{has0 ? 1.0 : -INFINITY, 0, has0 ? p[0] : Vec3f{0, 0, 0}, 0};
  const auto p0 = toVec3d(globalBest(comm, b0).p);
  Best m{-1.0, ~0ull, {0, 0, 0}, 0};
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto d = sub(toVec3d(p[i]), p0);
    const double l = dot(d, d);
    if (l > m.value) m = {l, first + i, p[i], 0};
  }
  const Best i1 = globalBest(comm, m);
  if (!(i1.value > 0)) return {0, 0};
  const double extent = std::sqrt(i1.value);
  auto dir = sub(toVec3d(i1.p), p0);
  for (double& c : dir) c /= extent;
  m = {-1.0, ~0ull, {0, 0, 0}, 0};
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto c = cross(dir, sub(toVec3d(p[i]), p0));
    const double l = dot(c, c);
    if (l > m.value) m = {l, first + i, p[i], 0};
  }
  const Best i2 = globalBest(comm, m);
  const double best2 = std::max(0.0, i2.value);
  auto w = sub(toVec3d(i2.p), p0);
  const double t = dot(w, dir);
  for (int a = 0; a < 3; ++a) w[a] -= t * dir[a];
  const double wl = std::sqrt(dot(w, w));
  for (double& c : w) c /= wl;
  const auto nrm = cross(dir, w);
  double off = 0;
  for (const Vec3f& q : p) off = std::max(off, std::fabs(dot(sub(toVec3d(q), p0), nrm)));
  MPI_Allreduce(MPI_IN_PLACE, &off, 1, MPI_DOUBLE, MPI_MAX, comm);
  auto dim = [&](double rel) {
    const double tol = rel * extent;
    if (std::sqrt(best2) <= tol) return 1;
    return off <= tol ? 2 : 3;
  };
  return {dim(1e-9), dim(1e-6)};
}

/// The share [first, first + xyz.size() / 3) of the input sequence that this rank reads.
struct InputShare {
  std::uint64_t first = 0;
  std::vector<double> xyz;
};

InputShare readShare(const PointInputSet& input, RankGraph& g) {
  const std::uint64_t n_in = input.size();
  if (n_in >= static_cast<std::uint64_t>(kInvalidIndex))
    throw Error("pcl_delaunay_walk: at most 2^32-2 input points are supported");
  g.input_points = n_in;
  const int P = g.size, me = g.rank;
  InputShare s;
  s.first = n_in * me / P;
  const std::uint64_t last = n_in * (me + 1) / P;
  s.xyz = input.read(s.first, last);
  if (s.xyz.size() != 3 * (last - s.first)) throw Error(input.describe() + ": short read");
  return s;
}

/// The single-process preparation (prepareVertices), replayed: bounding box of the finite points over
/// all ranks, origin at its centre, float local coordinates, Morton keys from the float positions.
/// Sets g.origin and returns this rank's items (input order) and the quantiser.
std::vector<MortonItem> mortonItems(MPI_Comm comm, const InputShare& in, RankGraph& g,
                                    dw::detail::MortonQuantiser& quantiser, double hi[3]) {
  const std::vector<double>& xyz = in.xyz;
  const std::size_t n_mine = xyz.size() / 3;
  auto finite = [&](std::size_t i) {
    return std::isfinite(xyz[3 * i]) && std::isfinite(xyz[3 * i + 1]) && std::isfinite(xyz[3 * i + 2]);
  };
  double ext[6] = {-INFINITY, -INFINITY, -INFINITY, -INFINITY, -INFINITY, -INFINITY};  // -lo, hi
  for (std::size_t i = 0; i < n_mine; ++i)
    if (finite(i))
      for (int a = 0; a < 3; ++a)
        ext[a] = std::max(ext[a], -xyz[3 * i + a]), ext[3 + a] = std::max(ext[3 + a], xyz[3 * i + a]);
  MPI_Allreduce(MPI_IN_PLACE, ext, 6, MPI_DOUBLE, MPI_MAX, comm);
  double lo[3];
  for (int a = 0; a < 3; ++a) lo[a] = -ext[a], hi[a] = ext[3 + a];
  const bool any_finite = lo[0] <= hi[0];
  const double extent = any_finite ? dw::detail::centreOfBox(lo, hi, g.origin.data()) : 0.0;
  quantiser = dw::detail::MortonQuantiser(g.origin.data(), lo, extent);
  std::vector<MortonItem> items;
  items.reserve(n_mine);
  for (std::size_t i = 0; i < n_mine; ++i) {
    if (!finite(i)) continue;
    MortonItem it;
    it.p = {static_cast<float>(xyz[3 * i] - g.origin[0]), static_cast<float>(xyz[3 * i + 1] - g.origin[1]),
            static_cast<float>(xyz[3 * i + 2] - g.origin[2])};
    it.input = static_cast<index_t>(in.first + i);
    it.key = quantiser.key(it.p);
    items.push_back(it);
  }
  return items;
}

/// Sample sort by Morton key across ranks: rank r receives keys in [split[r], split[r + 1]), so equal
/// keys (and with them exact duplicates) meet on one rank, and concatenating the ranks' sorted items in
/// rank order is the single-process vertex order. Returns the splitters.
std::vector<std::uint64_t> sampleSort(MPI_Comm comm, int P, std::vector<MortonItem>& items) {
  std::vector<std::uint64_t> split(P + 1, 0);
  split[P] = ~0ull;
  if (P > 1) {
    const std::size_t m = std::min<std::size_t>(items.size(), 4096);
    std::vector<std::uint64_t> sample(m);
    for (std::size_t k = 0; k < m; ++k) sample[k] = items[k * items.size() / m].key;
    std::vector<std::uint64_t> all = allGather(comm, sample);
    std::sort(all.begin(), all.end());
    for (int r = 1; r < P; ++r) split[r] = all.empty() ? ~0ull : all[r * all.size() / P];
  }
  std::vector<int> dest(items.size());
  std::vector<std::size_t> cnt(P, 0);
  for (std::size_t i = 0; i < items.size(); ++i) {
    dest[i] =
        static_cast<int>(std::upper_bound(split.begin() + 1, split.end() - 1, items[i].key) - split.begin()) -
        1;
    ++cnt[dest[i]];
  }
  std::vector<MortonItem> send(items.size());
  {
    std::vector<std::size_t> fill(P, 0);
    for (int r = 1; r < P; ++r) fill[r] = fill[r - 1] + cnt[r - 1];
    for (std::size_t i = 0; i < items.size(); ++i) send[fill[dest[i]]++] = items[i];
  }
  std::vector<MortonItem>().swap(items);
  std::vector<int>().swap(dest);
  items = collective::exchangeRecords(comm, send, cnt, "a sort message", "one rank's sort share",
                                      "one rank's sorted share");
  std::vector<MortonItem>().swap(send);
  std::sort(items.begin(), items.end(),
            [](const MortonItem& a, const MortonItem& b) { return dw::detail::mortonItemLess(a, b); });
  return split;
}

/// Duplicates (equal float positions) collapse onto their first item, as in the single-process run.
/// Fills g's points and originals; returns the vertices' Morton keys.
std::vector<std::uint64_t> collapseDuplicates(std::vector<MortonItem>& items, RankGraph& g) {
  std::vector<std::uint64_t> keys;
  g.originals_offsets.push_back(0);
  for (std::size_t k = 0; k < items.size(); ++k) {
    if (k == 0 || !dw::detail::samePosition(items[k].p, items[k - 1].p)) {
      if (!g.points.empty()) g.originals_offsets.push_back(static_cast<index_t>(g.originals.size()));
      g.points.push_back(items[k].p);
      keys.push_back(items[k].key);
    }
    g.originals.push_back(items[k].input);
  }
  if (!g.points.empty()) g.originals_offsets.push_back(static_cast<index_t>(g.originals.size()));
  std::vector<MortonItem>().swap(items);
  return keys;
}

/// Degenerate or tiny inputs take the single-process path on rank 0 (they are small or flat, and the
/// block method needs a proper 3D triangulation in every block).
void buildOnRank0(MPI_Comm comm, const std::vector<double>& xyz, RankGraph& g) {
  std::vector<double> all = gatherTo0(comm, xyz);
  g.gathered_fallback = true;
  g.points.clear(), g.originals.clear(), g.originals_offsets.clear();
  if (g.rank == 0) g.fallback = buildDelaunayGraph(PointView::fromDouble(all.data(), all.size() / 3));
  g.dimension = g.fallback.dimension;
  MPI_Bcast(&g.dimension, 1, MPI_INT, 0, comm);
}

/// The halo grid: cells of 2^k quantisation steps, about 4 points each on volumetric data before
/// cell_shift (each step doubles the edge).
MortonCellGrid haloGrid(const dw::detail::MortonQuantiser& quantiser, const double hi[3],
                        const std::array<double, 3>& origin, std::uint64_t nv, int cell_shift) {
  const double* lo = quantiser.lo;
  const double cell = quantiser.steps;
  double scale = 0;
  for (int a = 0; a < 3; ++a) scale = std::max(scale, hi[a] - lo[a]);
  MortonCellGrid grid;
  double vol = 1.0;
  for (int a = 0; a < 3; ++a) vol *= std::max(hi[a] - lo[a], scale * 1e-3);
  const double ideal = std::cbrt(vol / std::max(1.0, double(nv) / 4.0)) * cell;  // in quantisation steps
  grid.k = std::clamp(static_cast<int>(std::lround(std::log2(std::max(ideal, 1.0)))), 0, 20);
  grid.k = std::clamp(grid.k + cell_shift, 0, 20);
  for (;;) {
    for (int a = 0; a < 3; ++a) {
      const std::uint32_t qmax =
          static_cast<std::uint32_t>(std::clamp((hi[a] - lo[a]) * cell, 0.0, double((1u << 21) - 1)));
      grid.dims[a] = static_cast<int>(qmax >> grid.k) + 1;
    }
    if (grid.numCells() <= (std::size_t(1) << 31) || grid.k == 20) break;
    ++grid.k;
  }
  grid.width = std::ldexp(1.0, grid.k) / cell;
  for (int a = 0; a < 3; ++a) grid.base[a] = lo[a] - origin[a];
  // Quantisation rounds (fp - lo) * cell once and the float-to-world conversion once: far below this.
  grid.slack =
      1e-9 * (scale + std::fabs(origin[0]) + std::fabs(origin[1]) + std::fabs(origin[2])) + 1e-6 * grid.width;
  return grid;
}

/// Which cells hold a vertex on any rank (one bit per cell).
std::vector<std::uint64_t> occupiedCells(MPI_Comm comm, const MortonCellGrid& grid,
                                         const std::vector<std::uint64_t>& keys) {
  std::vector<std::uint64_t> occupied((grid.numCells() + 63) / 64, 0);
  for (std::uint64_t key : keys) {
    const std::uint32_t c = grid.cellOfKey(key);
    occupied[c >> 6] |= std::uint64_t{1} << (c & 63);
  }
  MPI_Allreduce(MPI_IN_PLACE, occupied.data(), toInt(occupied.size(), "the cell occupancy"), MPI_UINT64_T,
                MPI_BOR, comm);
  return occupied;
}

/// The global hull: its boundary points are on some block's local hull; rank 0 triangulates the
/// candidates and tells everyone the hull vertices, whose coordinates go into pts. Returns their ids.
std::vector<index_t> globalHull(MPI_Comm comm, const RankBlock& block, SparsePoints& pts,
                                const RankGraph& g) {
  struct Cand {
    index_t id;
    Vec3f p;
  };
  const std::uint64_t nv = g.vertices;
  std::vector<Cand> cand;
  for (index_t h : block.hullVertices()) cand.push_back({h, pts[h]});
  std::vector<Cand> all_cand = gatherTo0(comm, cand);
  std::vector<Cand> hull;
  if (g.rank == 0) {
    auto byId = [](const Cand& a, const Cand& b) { return a.id < b.id; };
    std::sort(all_cand.begin(), all_cand.end(), byId);
    all_cand.erase(std::unique(all_cand.begin(), all_cand.end(),
                               [](const Cand& a, const Cand& b) { return a.id == b.id; }),
                   all_cand.end());
    SparsePoints hp(nv);
    std::vector<index_t> ids;
    for (const Cand& c : all_cand) hp[c.id] = c.p, ids.push_back(c.id);
    Triangulation3D k;
    k.setPoints(hp.data(), hp.size());
    const std::vector<index_t> order = detail::brio(ids);
    k.build(order.data(), order.size());
    for (index_t h : k.hullVertices()) {
      const auto it = std::lower_bound(all_cand.begin(), all_cand.end(), h,
                                       [](const Cand& a, index_t id) { return a.id < id; });
      hull.push_back(*it);
    }
  }
  std::uint64_t nh = hull.size();
  MPI_Bcast(&nh, 1, MPI_UINT64_T, 0, comm);
  hull.resize(nh);
  MPI_Bcast(hull.data(), toInt(nh * sizeof(Cand), "the hull"), MPI_BYTE, 0, comm);
  std::vector<index_t> hull_ids;
  for (const Cand& c : hull) {
    if (c.id >= nv) throw Error("dw::mpi: internal inconsistency: hull vertex out of range");
    if (c.id < g.first_vertex || c.id >= g.first_vertex + g.points.size()) pts[c.id] = c.p;
    hull_ids.push_back(c.id);
  }
  return hull_ids;
}

}  // namespace

RankGraph buildGraphDistributed(MPI_Comm comm, const PointInputSet& input, const DistributedGraphOptions& o) {
  RankGraph g;
  MPI_Comm_rank(comm, &g.rank);
  MPI_Comm_size(comm, &g.size);
  const int P = g.size;
  auto progress = [&](const std::string& s) {
    if (g.rank == 0 && o.progress) o.progress(s);
  };
  auto t0 = std::chrono::steady_clock::now();
  const InputShare in = readShare(input, g);
  g.timings.read_s = since(t0);
  checkFault(o.inject_fault, g.rank, "read");
  progress("read " + std::to_string(g.input_points) + " points on " + std::to_string(P) + " ranks");

  t0 = std::chrono::steady_clock::now();
  dw::detail::MortonQuantiser quantiser;
  double hi[3];
  std::vector<MortonItem> items = mortonItems(comm, in, g, quantiser, hi);
  const std::vector<std::uint64_t> split = sampleSort(comm, P, items);
  std::vector<std::uint64_t> keys = collapseDuplicates(items, g);
  const collective::RankRange range = collective::rankRange(comm, g.points.size());
  const std::uint64_t base = range.first, nv = range.total;
  g.first_vertex = static_cast<index_t>(base);
  g.vertices = nv;
  g.timings.sort_s = since(t0);
  checkFault(o.inject_fault, g.rank, "sort");
  progress("sorted " + std::to_string(nv) + " distinct points along the Morton curve");

  const auto dims = distributedDimension(comm, g.points, base);
  if (nv < 64u * unsigned(P) || dims.second < 3) {
    progress("degenerate input (" + std::to_string(nv) + " vertices, dimension " +
             std::to_string(dims.first) + "): rank 0 builds it alone");
    buildOnRank0(comm, in.xyz, g);
    return g;
  }

  // The block: own vertices plus one ring of cells, triangulated.
  t0 = std::chrono::steady_clock::now();
  const MortonCellGrid grid = haloGrid(quantiser, hi, g.origin, nv, o.cell_shift);
  g.cells = grid.numCells();
  const std::vector<std::uint64_t> occupied = occupiedCells(comm, grid, keys);
  if (nv > Triangulation3D::kMaxVertices)
    throw Error("dw::mpi: " + std::to_string(nv) + " vertices exceed the 3D kernel's limit");
  SparsePoints pts(nv);
  std::copy(g.points.begin(), g.points.end(), pts.data() + base);
  RankBlock block(comm, grid, occupied, split, pts, keys, g.first_vertex,
                  static_cast<index_t>(base + g.points.size()));
  block.triangulate();
  g.timings.block_s = since(t0);
  checkFault(o.inject_fault, g.rank, "block");
  progress("blocks triangulated (own cells plus one ring)");

  t0 = std::chrono::steady_clock::now();
  const std::vector<index_t> hull_ids = globalHull(comm, block, pts, g);
  g.hull_points = hull_ids.size();
  g.timings.hull_s = since(t0);
  progress("global hull: " + std::to_string(hull_ids.size()) + " vertices");

  // Certify: grow halos (fetching cells) until every tetrahedron around the own vertices is global.
  t0 = std::chrono::steady_clock::now();
  checkFault(o.inject_fault, g.rank, "grow");
  // One rank holds every point: its triangulation is the global one, nothing to certify.
  if (P > 1) block.certify(hull_ids);
  g.edges = block.edges();
  g.halo_points = block.haloPoints();
  g.fetched_points = block.fetchedPoints();
  g.growth_rounds = block.rounds();
  g.halo_exchanges = block.exchanges();
  g.timings.exchange_s = block.exchangeSeconds();
  g.timings.grow_s = since(t0);
  progress("halos certified");
  return g;
}

DelaunayGraph gatherGraph(MPI_Comm comm, RankGraph&& part) {
  DelaunayGraph g;
  if (part.gathered_fallback) return part.rank == 0 ? std::move(part.fallback) : g;
  std::vector<index_t> counts(part.points.size());
  for (std::size_t v = 0; v < counts.size(); ++v)
    counts[v] = part.originals_offsets[v + 1] - part.originals_offsets[v];
  const std::vector<Vec3f> points = gatherTo0(comm, part.points);
  std::vector<Vec3f>().swap(part.points);
  const std::vector<index_t> all_counts = gatherTo0(comm, counts);
  const std::vector<index_t> originals = gatherTo0(comm, part.originals);
  std::vector<index_t>().swap(part.originals);
  EdgeList edges = gatherTo0(comm, part.edges);
  EdgeList().swap(part.edges);
  if (part.rank != 0) return g;
  if (points.size() != part.vertices || all_counts.size() != part.vertices)
    throw Error("dw::mpi: internal inconsistency: gathered vertex count");
  g.origin = part.origin;
  g.dimension = 3;
  g.points = points;
  g.originals = originals;
  g.originals_offsets.assign(1, 0);
  for (index_t c : all_counts) g.originals_offsets.push_back(g.originals_offsets.back() + c);
  if (g.originals_offsets.back() != g.originals.size())
    throw Error("dw::mpi: internal inconsistency: gathered originals");
  g.input_to_vertex.assign(part.input_points, kInvalidIndex);
  for (std::size_t v = 0; v < g.points.size(); ++v)
    for (index_t k = g.originals_offsets[v]; k < g.originals_offsets[v + 1]; ++k) {
      if (g.originals[k] >= part.input_points) throw Error("dw::mpi: internal inconsistency: input index");
      g.input_to_vertex[g.originals[k]] = static_cast<index_t>(v);
    }
  assembleEdges(g, std::move(edges));
  return g;
}

}  // namespace mpi
}  // namespace dw
