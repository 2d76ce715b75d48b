/// \file delaunay_tin.cpp
/// \brief The map/reduce driver: strips (map), Bowyer-Watson per strip in parallel, pairwise tree merge
/// (reduce, also parallel), then the compact triangle output.
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>
#include <thread>

#include "bowyer_watson.h"
#include "pcl_delaunay_walk/core/predicates_2d.h"
#include "strip_merge.h"

namespace dw {
namespace tin {
namespace {

using detail::Group;
using detail::kDead;
using detail::kGhost;
constexpr std::size_t kNone = ~std::size_t{0};

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Runs fn(i) for i < count on up to `threads` threads; rethrows the first exception.
template <typename F>
void parallelFor(std::size_t count, unsigned threads, F&& fn) {
  const unsigned workers = static_cast<unsigned>(std::min<std::size_t>(threads, count));
  if (workers <= 1) {
    for (std::size_t i = 0; i < count; ++i) fn(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto body = [&]() {
    for (std::size_t i = next++; i < count; i = next++) {
      try {
        fn(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  for (unsigned w = 1; w < workers; ++w) pool.emplace_back(body);
  body();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

/// Applies the permutation `order` (new position -> old offset) to v[begin, begin + order.size()).
template <typename T>
void gather(T* v, const std::vector<index_t>& order, std::size_t begin, std::vector<T>& tmp) {
  tmp.resize(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) tmp[i] = v[order[i]];
  std::copy(tmp.begin(), tmp.end(), v + begin);
}

}  // namespace

TinResult triangulate(const double* x, const double* y, std::size_t n, const TinOptions& options) {
  return triangulate(std::vector<double>(x, x + n), std::vector<double>(y, y + n), options);
}

TinResult triangulate(std::vector<double>&& xin, std::vector<double>&& yin, const TinOptions& options) {
  const auto t_start = std::chrono::steady_clock::now();
  if (xin.size() != yin.size()) throw Error("dw::tin::triangulate: x and y have different lengths");
  const std::size_t n_in = xin.size();
  // Corners 3t + i of up to 2n + 2K triangles must fit 32 bits.
  if (n_in > 600000000u)
    throw Error("dw::tin::triangulate: too many points (" + std::to_string(n_in) +
                "); the limit is 600 million");
  const unsigned threads =
      options.num_threads ? options.num_threads : std::max(1u, std::thread::hardware_concurrency());
  std::mutex progress_mutex;
  auto progress = [&](const char* stage, double f) {
    if (!options.progress) return;
    std::lock_guard<std::mutex> lock(progress_mutex);
    options.progress(stage, f);
  };

  TinResult result;
  // Input is scanned in chunks in parallel (finite test, bounds, then strip counts and a stable
  // scatter): on many cores a serial pass here would cap the speed-up (Amdahl).
  const std::size_t chunks = std::max<std::size_t>(1, std::min<std::size_t>(4 * threads, n_in / 65536 + 1));
  auto chunkBegin = [&](std::size_t c) { return c * n_in / chunks; };
  auto finite = [&](std::size_t i) { return std::isfinite(xin[i]) && std::isfinite(yin[i]); };
  struct ChunkScan {
    double lo[2] = {0, 0}, hi[2] = {0, 0};
    bool any = false;
    std::size_t out_of_range = kNone;  // first finite point the exact predicates cannot handle
    std::vector<index_t> skipped;
    std::vector<std::size_t> count;  // per strip
  };
  std::vector<ChunkScan> scan(chunks);
  parallelFor(chunks, threads, [&](std::size_t c) {
    ChunkScan& cs = scan[c];
    for (std::size_t i = chunkBegin(c); i < chunkBegin(c + 1); ++i) {
      if (!finite(i)) {
        cs.skipped.push_back(static_cast<index_t>(i));
        continue;
      }
      if (cs.out_of_range == kNone && !(pred::inExactRange(xin[i]) && pred::inExactRange(yin[i])))
        cs.out_of_range = i;
      if (!cs.any) {
        cs.lo[0] = cs.hi[0] = xin[i];
        cs.lo[1] = cs.hi[1] = yin[i];
        cs.any = true;
      }
      cs.lo[0] = std::min(cs.lo[0], xin[i]);
      cs.hi[0] = std::max(cs.hi[0], xin[i]);
      cs.lo[1] = std::min(cs.lo[1], yin[i]);
      cs.hi[1] = std::max(cs.hi[1], yin[i]);
    }
  });
  for (const ChunkScan& cs : scan)
    if (cs.out_of_range != kNone) {
      const std::size_t i = cs.out_of_range;
      throw Error("dw::tin::triangulate: point " + std::to_string(i) + " (" + std::to_string(xin[i]) + ", " +
                  std::to_string(yin[i]) +
                  ") is outside the range where the exact predicates are exact (each coordinate 0 or "
                  "between 2^-150 ~ 7e-46 and 2^200 ~ 1.6e60 in magnitude); rescale or re-centre the input");
    }
  double lo[2] = {0, 0}, hi[2] = {0, 0};
  bool first = true;
  for (const ChunkScan& cs : scan) {
    result.skipped.insert(result.skipped.end(), cs.skipped.begin(), cs.skipped.end());
    if (!cs.any) continue;
    for (int k = 0; k < 2; ++k) {
      lo[k] = first ? cs.lo[k] : std::min(lo[k], cs.lo[k]);
      hi[k] = first ? cs.hi[k] : std::max(hi[k], cs.hi[k]);
    }
    first = false;
  }
  const std::size_t n = n_in - result.skipped.size();
  const int axis = (hi[1] - lo[1]) > (hi[0] - lo[0]) ? 1 : 0;
  const std::vector<double>& along = axis == 0 ? xin : yin;

  // Map: equal-count strips from quantiles of a deterministic sample of the long-axis coordinate.
  std::size_t want = options.num_strips ? options.num_strips : (n >= 200000 ? threads : 1);
  want = std::max<std::size_t>(1, std::min(want, std::max<std::size_t>(1, n / 16)));
  std::vector<double> splits;
  if (want > 1) {
    std::vector<double> sample;
    const std::size_t m = std::min<std::size_t>(n_in, 1 << 16);
    sample.reserve(m);
    for (std::size_t k = 0; k < m; ++k) {
      const double v = along[k * n_in / m];
      if (std::isfinite(v) && std::isfinite(axis == 0 ? yin[k * n_in / m] : xin[k * n_in / m]))
        sample.push_back(v);
    }
    std::sort(sample.begin(), sample.end());
    for (std::size_t k = 1; k < want && !sample.empty(); ++k) {
      const double s = sample[k * sample.size() / want];
      if (s > sample.front() && (splits.empty() || s > splits.back())) splits.push_back(s);
    }
  }
  const std::size_t num_strips = splits.size() + 1;
  auto stripOf = [&](std::size_t i) {
    return static_cast<std::size_t>(std::upper_bound(splits.begin(), splits.end(), along[i]) -
                                    splits.begin());
  };
  parallelFor(chunks, threads, [&](std::size_t c) {
    scan[c].count.assign(num_strips, 0);
    for (std::size_t i = chunkBegin(c); i < chunkBegin(c + 1); ++i)
      if (finite(i)) ++scan[c].count[stripOf(i)];
  });
  // Strip s starts at start[s]; within it, chunk c's points follow those of chunks < c (stable order,
  // so positions within a strip increase with the input index, i.e. with the rank).
  std::vector<std::size_t> start(num_strips + 1, 0);
  for (std::size_t s = 0; s < num_strips; ++s) {
    std::size_t at = start[s];
    for (ChunkScan& cs : scan) {
      const std::size_t c = cs.count[s];
      cs.count[s] = at;
      at += c;
    }
    start[s + 1] = at;
  }
  // Not value-initialised: the parallel scatter below is the first touch (a serial zero-fill of
  // 20 bytes/point measurably capped the many-core speed-up).
  std::unique_ptr<double[]> pxy(new double[2 * n]);
  std::unique_ptr<index_t[]> rank(new index_t[n]);
  parallelFor(chunks, threads, [&](std::size_t c) {
    std::vector<std::size_t>& fill = scan[c].count;
    for (std::size_t i = chunkBegin(c); i < chunkBegin(c + 1); ++i) {
      if (!finite(i)) continue;
      const std::size_t p = fill[stripOf(i)]++;
      pxy[2 * p] = xin[i];
      pxy[2 * p + 1] = yin[i];
      rank[p] = static_cast<index_t>(i);
    }
  });
  std::vector<ChunkScan>().swap(scan);
  std::vector<double>().swap(xin);
  std::vector<double>().swap(yin);
  result.stats.prepare_s = secondsSince(t_start);

  // Arena: strip s owns slots [2 start[s] + 2 s, 2 start[s + 1] + 2 (s + 1)), enough for 2 n_s + 2.
  const std::size_t total_slots = 2 * n + 2 * num_strips;
  std::unique_ptr<index_t[]> tv(new index_t[3 * total_slots]);
  std::unique_ptr<index_t[]> tn(new index_t[3 * total_slots]);
  const detail::TriangleArena arena{tv.get(), tn.get()};
  const detail::PointSet ps{pxy.get(), rank.get()};

  const auto t_strips = std::chrono::steady_clock::now();
  std::vector<Group> groups(num_strips);
  std::vector<std::vector<std::pair<index_t, index_t>>> strip_dups(num_strips);
  std::atomic<std::size_t> strips_done{0};
  parallelFor(num_strips, threads, [&](std::size_t s) {
    const std::size_t b = start[s], e = start[s + 1];
    Group& g = groups[s];
    g.strip_begin = s;
    g.strip_end = s + 1;
    const index_t base = static_cast<index_t>(2 * b + 2 * s), cap = static_cast<index_t>(2 * (e - b) + 2);
    if (e > b) {
      // Spatial sort, then reorder the strip's coordinates physically so the walk reads memory in order.
      std::vector<index_t> order(e - b);
      for (std::size_t i = b; i < e; ++i) order[i - b] = static_cast<index_t>(i);
      detail::brioHilbertSort(pxy.get(), order);
      {
        std::vector<double> tmp(2 * order.size());
        for (std::size_t i = 0; i < order.size(); ++i) {
          tmp[2 * i] = pxy[2 * std::size_t(order[i])];
          tmp[2 * i + 1] = pxy[2 * std::size_t(order[i]) + 1];
        }
        std::copy(tmp.begin(), tmp.end(), pxy.get() + 2 * b);
        std::vector<index_t> tmpi;
        gather(rank.get(), order, b, tmpi);
      }
      for (std::size_t i = b; i < e; ++i) order[i - b] = static_cast<index_t>(i);
      detail::BowyerWatson kernel(ps, arena, base, cap);
      kernel.run(order.data(), order.size());
      g.num_vertices = kernel.numVertices();
      g.has_triangles = kernel.hasTriangles();
      if (g.has_triangles)
        g.ghost = kernel.anyGhost();
      else
        g.loose = kernel.collinearVertices();
      strip_dups[s] = kernel.duplicates();
      for (index_t t = base + kernel.used(); t < base + cap; ++t) g.free_slots.push_back(t);
    } else {
      for (index_t t = base; t < base + cap; ++t) g.free_slots.push_back(t);
    }
    for (const index_t t : g.free_slots) tv[3 * t] = kDead;
    progress("strips", double(++strips_done) / double(num_strips));
  });
  result.stats.strips_s = secondsSince(t_strips);
  for (const Group& g : groups) result.stats.strips += g.num_vertices > 0;

  // Reduce: merge neighbours pairwise, level by level; the merges of one level run in parallel.
  const auto t_merge = std::chrono::steady_clock::now();
  std::atomic<std::size_t> band{0};
  const std::size_t levels =
      num_strips > 1 ? static_cast<std::size_t>(std::ceil(std::log2(double(num_strips)))) : 0;
  std::size_t level = 0;
  while (groups.size() > 1) {
    const std::size_t pairs = groups.size() / 2;
    std::vector<Group> next(pairs + groups.size() % 2);
    parallelFor(pairs, threads, [&](std::size_t k) {
      Group& l = groups[2 * k];
      Group& r = groups[2 * k + 1];
      const double seam = splits[r.strip_begin - 1];
      std::size_t local = 0;
      next[k] = detail::mergeGroups(ps, arena, axis, seam, std::move(l), std::move(r), &local);
      band += local;
    });
    if (groups.size() % 2) next.back() = std::move(groups.back());
    groups.swap(next);
    progress("merge", double(++level) / double(std::max<std::size_t>(levels, 1)));
  }
  result.stats.merge_s = secondsSince(t_merge);
  result.stats.merge_points = band;

  // Output: compact the live real triangles into input-index triples. The adjacency goes first so the
  // output array replaces it in memory rather than adding to the peak.
  const auto t_out = std::chrono::steady_clock::now();
  tn.reset();
  const Group& all = groups.front();
  result.num_vertices = all.num_vertices;
  result.degenerate = !all.has_triangles;
  if (all.has_triangles) {
    const std::size_t out_chunks =
        std::max<std::size_t>(1, std::min<std::size_t>(4 * threads, total_slots / 65536 + 1));
    auto slotBegin = [&](std::size_t c) { return c * total_slots / out_chunks; };
    auto live = [&](std::size_t t) {
      const index_t* v = tv.get() + 3 * t;
      return !(v[0] == kDead || v[0] == kGhost || v[1] == kGhost || v[2] == kGhost);
    };
    std::vector<std::size_t> offset(out_chunks + 1, 0);
    parallelFor(out_chunks, threads, [&](std::size_t c) {
      std::size_t k = 0;
      for (std::size_t t = slotBegin(c); t < slotBegin(c + 1); ++t) k += live(t);
      offset[c + 1] = k;
    });
    for (std::size_t c = 0; c < out_chunks; ++c) offset[c + 1] += offset[c];
    result.triangles.resize(3 * offset[out_chunks]);
    parallelFor(out_chunks, threads, [&](std::size_t c) {
      index_t* out = result.triangles.data() + 3 * offset[c];
      for (std::size_t t = slotBegin(c); t < slotBegin(c + 1); ++t) {
        if (!live(t)) continue;
        const index_t* v = tv.get() + 3 * t;
        *out++ = rank[v[0]];
        *out++ = rank[v[1]];
        *out++ = rank[v[2]];
      }
    });
  }
  for (const auto& d : strip_dups)
    for (const auto& pr : d) result.duplicates.emplace_back(rank[pr.first], rank[pr.second]);
  std::sort(result.duplicates.begin(), result.duplicates.end());
  result.stats.output_s = secondsSince(t_out);
  return result;
}

}  // namespace tin
}  // namespace dw
