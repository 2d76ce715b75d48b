/// \file distributed_raster.cpp
/// \brief Row bands of the distributed TIN's raster (see distributed_raster.h).
#include "pcl_delaunay_walk/mpi/distributed_raster.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "mpi/collectives.h"

namespace dw {
namespace mpi {

namespace {

/// One triangle in flight to a band: frame x, y and value of its corners, smallest gid first.
struct TriangleRecord {
  double x[3], y[3], v[3];
};

/// Rows the triangle's cell centres may lie in: the rasteriser's own candidate range
/// (tin_raster.cpp, centreRange with its 1e-6 slack) widened by a whole row each side, clipped to
/// the grid; false when it misses the grid.
bool candidateRows(const TriangleRecord& t, const dem::RasterGrid& g, std::size_t& r0, std::size_t& r1) {
  const double ymin = std::min({t.y[0], t.y[1], t.y[2]}), ymax = std::max({t.y[0], t.y[1], t.y[2]});
  const double lo = std::ceil((g.north - ymax) / g.cell - 0.5) - 1;
  const double hi = std::floor((g.north - ymin) / g.cell - 0.5) + 1;
  if (!(hi >= 0) || !(lo <= double(g.rows) - 1)) return false;
  r0 = lo < 0 ? 0 : std::size_t(lo);
  r1 = hi > double(g.rows) - 1 ? g.rows - 1 : std::size_t(hi);
  return r0 <= r1;
}

/// The same kill test as dem::rasterizeTinRows (squared edge lengths against max_edge squared).
bool killed(const TriangleRecord& t, double max_edge) {
  const double max_edge2 = max_edge > 0 ? max_edge * max_edge : HUGE_VAL;
  bool k = false;
  for (int j = 0; j < 3; ++j) {
    const double dx = t.x[(j + 1) % 3] - t.x[j], dy = t.y[(j + 1) % 3] - t.y[j];
    k = k || dx * dx + dy * dy > max_edge2;
  }
  return k;
}

}  // namespace

bool globalFrameBox(MPI_Comm comm, const RankTin& tin, double lo[2], double hi[2]) {
  double ext[4] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL};  // -min x, -min y, max x, max y
  for (std::size_t i = 0; i < tin.coords.size(); ++i) {
    ext[0] = std::max(ext[0], -tin.coords.x[i]);
    ext[1] = std::max(ext[1], -tin.coords.y[i]);
    ext[2] = std::max(ext[2], tin.coords.x[i]);
    ext[3] = std::max(ext[3], tin.coords.y[i]);
  }
  MPI_Allreduce(MPI_IN_PLACE, ext, 4, MPI_DOUBLE, MPI_MAX, comm);
  lo[0] = -ext[0], lo[1] = -ext[1], hi[0] = ext[2], hi[1] = ext[3];
  return lo[0] <= hi[0] && lo[1] <= hi[1];
}

void rowBand(std::size_t rows, int rank, int size, std::size_t& begin, std::size_t& end) {
  begin = rows * std::size_t(rank) / std::size_t(size);
  end = rows * std::size_t(rank + 1) / std::size_t(size);
}

RasterBand rasterizeBands(MPI_Comm comm, const RankTin& tin, const dem::RasterGrid& grid,
                          const dem::TinRasterOptions& options) {
  const int P = tin.size;
  std::vector<std::size_t> first(P + 1);  // band r = rows [first[r], first[r + 1])
  for (int r = 0; r <= P; ++r) first[r] = grid.rows * std::size_t(r) / std::size_t(P);

  // This rank's triangles with their corners, smallest gid first (the rotation the rasteriser uses).
  const StripPoints& c = tin.coords;
  const std::vector<index_t>& tri = tin.emitted.triangles;
  std::vector<TriangleRecord> mine;
  mine.reserve(tri.size() / 3);
  std::size_t killed_here = 0;
  for (std::size_t k = 0; k + 2 < tri.size(); k += 3) {
    const index_t* v = &tri[k];
    const int f = v[0] < v[1] ? (v[0] < v[2] ? 0 : 2) : (v[1] < v[2] ? 1 : 2);
    TriangleRecord t;
    for (int j = 0; j < 3; ++j) {
      const index_t g = v[(f + j) % 3];
      const auto it = std::lower_bound(c.gid.begin(), c.gid.end(), g);
      if (it == c.gid.end() || *it != g)
        throw Error("dw::mpi: internal inconsistency: no coordinates for vertex " + std::to_string(g));
      const std::size_t i = std::size_t(it - c.gid.begin());
      t.x[j] = c.x[i], t.y[j] = c.y[i], t.v[j] = c.z[i];
    }
    if (killed(t, options.max_edge)) {
      ++killed_here;
      continue;
    }
    mine.push_back(t);
  }

  // To every non-empty band the triangle's candidate rows meet, grouped by rank.
  auto forEachBand = [&](const TriangleRecord& t, auto&& fn) {
    std::size_t r0, r1;
    if (!candidateRows(t, grid, r0, r1)) return;
    int b = int(std::upper_bound(first.begin(), first.end(), r0) - first.begin()) - 1;
    for (; b < P && first[b] <= r1; ++b)
      if (first[b] < first[b + 1]) fn(b);
  };
  std::vector<std::size_t> send_n(P, 0);
  for (const TriangleRecord& t : mine) forEachBand(t, [&](int b) { ++send_n[b]; });
  std::vector<std::size_t> fill(P, 0);
  for (int r = 1; r < P; ++r) fill[r] = fill[r - 1] + send_n[r - 1];
  std::vector<TriangleRecord> out(fill[P - 1] + send_n[P - 1]);
  for (const TriangleRecord& t : mine) forEachBand(t, [&](int b) { out[fill[b]++] = t; });
  std::vector<TriangleRecord>().swap(mine);
  const std::vector<TriangleRecord> got = collective::exchangeRecords(
      comm, out, send_n, "a raster band message", "one rank's triangles", "one rank's raster band");
  std::vector<TriangleRecord>().swap(out);

  RasterBand band;
  band.row_begin = first[tin.rank];
  band.row_end = first[tin.rank + 1];
  band.triangles = got.size();
  std::vector<double> x(3 * got.size()), y(3 * got.size()), v(3 * got.size());
  for (std::size_t k = 0; k < got.size(); ++k)
    for (int j = 0; j < 3; ++j)
      x[3 * k + j] = got[k].x[j], y[3 * k + j] = got[k].y[j], v[3 * k + j] = got[k].v[j];
  std::vector<index_t> idx(3 * got.size());
  std::iota(idx.begin(), idx.end(), index_t(0));
  band.values.resize((band.row_end - band.row_begin) * grid.cols);
  dem::TinRasterStats s;
  if (band.row_end > band.row_begin)
    s = dem::rasterizeTinRows(x.data(), y.data(), v.data(), x.size(), idx.data(), idx.size(), grid,
                              band.row_begin, band.row_end, band.values.data(), options);
  unsigned long long sums[2] = {s.cells_set, killed_here};
  MPI_Allreduce(MPI_IN_PLACE, sums, 2, MPI_UNSIGNED_LONG_LONG, MPI_SUM, comm);
  band.stats.cells_set = std::size_t(sums[0]);
  band.stats.triangles_killed = std::size_t(sums[1]);
  return band;
}

}  // namespace mpi
}  // namespace dw
