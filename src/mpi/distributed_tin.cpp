/// \file distributed_tin.cpp
/// \brief The MPI driver: range read of one LAS file or a pre-split set, sampled strip splitters, all-to-all
/// redistribution, leaf triangulation, and the pairwise merge tree over ranks.
#include "pcl_delaunay_walk/mpi/distributed_tin.h"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <numeric>

#include "mpi/collectives.h"
#include "mpi/fault_injection.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"

namespace dw {
namespace mpi {
namespace {

using collective::toInt;

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

struct PointRecord {  // one point in flight between ranks
  double x, y, z;
  std::uint64_t gid;
};

void sendGroup(MPI_Comm comm, int to, const StripGroup& g) {
  const std::vector<unsigned char> b = g.serialize();
  MPI_Send(b.data(), toInt(b.size(), "a merge band"), MPI_BYTE, to, 7, comm);
}

StripGroup receiveGroup(MPI_Comm comm, int from) {
  MPI_Status st;
  MPI_Probe(from, 7, comm, &st);
  int count = 0;
  MPI_Get_count(&st, MPI_BYTE, &count);
  std::vector<unsigned char> b(static_cast<std::size_t>(count));
  MPI_Recv(b.data(), count, MPI_BYTE, from, 7, comm, MPI_STATUS_IGNORE);
  return StripGroup::deserialize(b.data(), b.size());
}

void append(StripPoints& to, const StripPoints& from) {
  to.gid.insert(to.gid.end(), from.gid.begin(), from.gid.end());
  to.x.insert(to.x.end(), from.x.begin(), from.x.end());
  to.y.insert(to.y.end(), from.y.begin(), from.y.end());
  to.z.insert(to.z.end(), from.z.begin(), from.z.end());
}

/// Keeps only the points some emitted triangle uses, sorted by gid.
StripPoints usedPoints(const StripPoints& pool, const std::vector<index_t>& triangles) {
  std::vector<index_t> used(triangles);
  std::sort(used.begin(), used.end());
  used.erase(std::unique(used.begin(), used.end()), used.end());
  std::vector<std::size_t> order(pool.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return pool.gid[a] < pool.gid[b]; });
  StripPoints out;
  out.reserve(used.size());
  std::size_t k = 0;
  for (index_t g : used) {
    while (k < order.size() && pool.gid[order[k]] < g) ++k;
    if (k == order.size() || pool.gid[order[k]] != g)
      throw Error("dw::mpi: internal inconsistency: no coordinates for emitted vertex " + std::to_string(g));
    const std::size_t i = order[k];
    out.push(g, pool.x[i], pool.y[i], pool.z[i]);
  }
  return out;
}

/// Where rank r's share of the records starts (r = P: the end). Equal shares, moved to the nearest
/// LAZ chunk boundary so that each chunk is decoded by one rank; where that would leave some rank
/// without records (chunks larger than a share), the equal shares themselves. Every rank computes
/// the same boundaries from the headers alone.
std::uint64_t rankBoundary(const LasInputSet& input, int r, int P) {
  const std::uint64_t n = input.size();
  auto equal = [&](int k) { return n * std::uint64_t(k) / std::uint64_t(P); };
  for (int k = 0; k < P; ++k)
    if (input.alignToChunk(equal(k)) >= input.alignToChunk(equal(k + 1))) return equal(r);
  return input.alignToChunk(equal(r));
}

/// This rank's contiguous share of the kept records (of one file or of a pre-split set), numbered by
/// global index; sets t's frame and total_points.
std::vector<PointRecord> readRecords(MPI_Comm comm, const DistributedTinOptions& options, RankTin& t) {
  const int P = t.size, me = t.rank;
  const LasInputSet input(options.inputs, options.max_records);
  const std::string name =
      input.paths().size() == 1 ? input.paths()[0] : std::to_string(input.paths().size()) + " input files";
  const std::uint64_t first = rankBoundary(input, me, P), last = rankBoundary(input, me + 1, P);
  t.frame = input.frame();
  std::vector<PointRecord> mine;
  mine.reserve(last - first);
  input.forEach(first, last, [&](const las::LasRecord& r, double x, double y, double z) {
    if (options.classification >= 0 && r.classification != options.classification) return;
    mine.push_back({x, y, options.intensity_as_z ? double(r.intensity) : z, 0});
  });
  // Global indices count kept records in file order, exactly as the single-process reader does.
  const collective::RankRange kept = collective::rankRange(comm, mine.size());
  const std::uint64_t base = kept.first, total = kept.total;
  t.total_points = total;
  if (total == 0) throw Error(name + ": no points to triangulate");
  if (total >= 0xffffffffull) throw Error(name + ": too many points for 32-bit global indices");
  for (std::size_t i = 0; i < mine.size(); ++i) mine[i].gid = base + i;
  return mine;
}

/// The long axis and equal-count splitters split[0..P] (split[0] = -inf, split[P] = +inf) from a
/// gathered sample.
int stripSplitters(MPI_Comm comm, int P, const std::vector<PointRecord>& mine, std::vector<double>& split) {
  double ext[4] = {-INFINITY, -INFINITY, -INFINITY, -INFINITY};  // -min x, max x, -min y, max y
  for (const PointRecord& p : mine) {
    ext[0] = std::max(ext[0], -p.x);
    ext[1] = std::max(ext[1], p.x);
    ext[2] = std::max(ext[2], -p.y);
    ext[3] = std::max(ext[3], p.y);
  }
  MPI_Allreduce(MPI_IN_PLACE, ext, 4, MPI_DOUBLE, MPI_MAX, comm);
  const int axis = (ext[3] + ext[2]) > (ext[1] + ext[0]) ? 1 : 0;
  auto along = [axis](const PointRecord& p) { return axis == 0 ? p.x : p.y; };
  split.assign(P + 1, 0.0);
  split[0] = -INFINITY;
  split[P] = INFINITY;
  if (P > 1) {
    const std::size_t m = std::min<std::size_t>(mine.size(), 8192);
    std::vector<double> sample(m);
    for (std::size_t k = 0; k < m; ++k) sample[k] = along(mine[k * mine.size() / m]);
    std::vector<double> all = collective::allGather(comm, sample);
    std::sort(all.begin(), all.end());
    for (int r = 1; r < P; ++r) split[r] = all.empty() ? INFINITY : all[r * all.size() / P];
  }

  return axis;
}

/// Redistributes: strip r = [split[r], split[r + 1]). Sources are concatenated in rank order, so the
/// received points are already sorted by global index.
StripPoints redistribute(MPI_Comm comm, int P, int axis, const std::vector<double>& split,
                         std::vector<PointRecord>& mine) {
  auto along = [axis](const PointRecord& p) { return axis == 0 ? p.x : p.y; };
  std::vector<std::size_t> send_n(P, 0);
  auto stripOf = [&](const PointRecord& p) {
    return static_cast<int>(std::upper_bound(split.begin() + 1, split.end() - 1, along(p)) - split.begin()) -
           1;
  };
  std::vector<int> dest(mine.size());
  std::size_t finite = 0;
  for (std::size_t i = 0; i < mine.size(); ++i) {
    dest[i] = std::isfinite(mine[i].x) && std::isfinite(mine[i].y) ? stripOf(mine[i]) : -1;
    if (dest[i] >= 0) ++send_n[dest[i]], ++finite;
  }
  std::vector<PointRecord> out(finite);
  {
    std::vector<std::size_t> fill(P, 0);
    for (int r = 1; r < P; ++r) fill[r] = fill[r - 1] + send_n[r - 1];
    for (std::size_t i = 0; i < mine.size(); ++i)
      if (dest[i] >= 0) out[fill[dest[i]]++] = mine[i];
  }
  std::vector<PointRecord>().swap(mine);
  std::vector<int>().swap(dest);
  std::vector<PointRecord> strip = collective::exchangeRecords(comm, out, send_n, "a redistribution message",
                                                               "one rank's share", "one rank's strip");
  std::vector<PointRecord>().swap(out);
  StripPoints pts;
  pts.reserve(strip.size());
  for (const PointRecord& p : strip) pts.push(static_cast<index_t>(p.gid), p.x, p.y, p.z);
  std::vector<PointRecord>().swap(strip);
  return pts;
}

/// The merge tree: at step s, rank r (r % 2s == 0) takes the group of rank r + s. pool collects the
/// coordinates of the points that arrive.
template <class Progress>
StripGroup mergeUpTree(MPI_Comm comm, StripGroup group, StripPoints& pool, RankTin& t,
                       const DistributedTinOptions& options, const StripOptions& sopt, Progress&& progress) {
  const int P = t.size, me = t.rank;
  checkFault(options.inject_fault, t.rank, "merge");  // every rank passes here, senders and receivers alike
  for (int step = 1; step < P; step *= 2) {
    if (me % (2 * step) == step) {
      sendGroup(comm, me - step, group);
      group = StripGroup();
      break;
    }
    if (me % (2 * step) == 0 && me + step < P) {
      StripGroup right = receiveGroup(comm, me + step);
      append(pool, right.band);
      const std::size_t before = t.emitted.band_points;
      group = mergeStrips(std::move(group), std::move(right), t.emitted, sopt);
      progress("merge level " + std::to_string(step) + ": " + std::to_string(t.emitted.band_points - before) +
               " band points on rank 0");
    }
  }
  if (me == 0 && !(std::isinf(group.lo) && std::isinf(group.hi)))
    throw Error("dw::mpi: internal inconsistency: the merge tree did not reach the whole axis");
  return group;
}

}  // namespace

RankTin triangulateDistributed(MPI_Comm comm, const DistributedTinOptions& options) {
  RankTin t;
  MPI_Comm_rank(comm, &t.rank);
  MPI_Comm_size(comm, &t.size);
  const int P = t.size, me = t.rank;
  auto progress = [&](const std::string& s) {
    if (me == 0 && options.progress) options.progress(s);
  };

  auto t0 = std::chrono::steady_clock::now();
  std::vector<PointRecord> mine = readRecords(comm, options, t);
  t.timings.read_s = since(t0);
  progress("read " + std::to_string(t.total_points) + " points on " + std::to_string(P) + " ranks");
  checkFault(options.inject_fault, t.rank, "read");

  t0 = std::chrono::steady_clock::now();
  std::vector<double> split;
  const int axis = stripSplitters(comm, P, mine, split);
  StripPoints pts = redistribute(comm, P, axis, split, mine);
  t.strip_points = pts.size();
  t.timings.exchange_s = since(t0);
  progress("redistributed into " + std::to_string(P) + " strips along " + (axis ? "y" : "x"));

  // Leaf: triangulate the strip, emit what is sure in it.
  t0 = std::chrono::steady_clock::now();
  StripOptions sopt;
  sopt.num_threads = std::max(1u, options.num_threads);
  StripPoints pool = pts;  // coordinates for the output piece
  StripGroup group;
  if (split[me] < split[me + 1]) {
    group = processLeaf(std::move(pts), axis, split[me], split[me + 1], t.emitted, sopt);
  } else {  // equal splitters: an empty strip
    group.axis = axis;
    group.lo = split[me];
    group.hi = split[me + 1];
  }
  t.timings.leaf_s = since(t0);
  checkFault(options.inject_fault, t.rank, "leaf");
  progress("leaves done");

  // The merge tree up to rank 0.
  t0 = std::chrono::steady_clock::now();
  group = mergeUpTree(comm, std::move(group), pool, t, options, sopt, progress);
  t.timings.merge_s = since(t0);
  t.coords = usedPoints(pool, t.emitted.triangles);
  return t;
}

}  // namespace mpi
}  // namespace dw
