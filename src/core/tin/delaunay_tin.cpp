/// \file delaunay_tin.cpp
/// \brief The map/reduce driver: strips (map), Bowyer-Watson per strip in parallel, pairwise tree merge
/// (reduce, also parallel), then the compact triangle output.
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <future>
#include <memory>
#include <mutex>
#include <system_error>

#include "bowyer_watson.h"
#include "page_memory.h"
#include "pcl_delaunay_walk/core/parallel_for.h"
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

/// Points per strip aimed at by default. Smaller strips sort and triangulate faster (the strip's arrays
/// stay closer in cache: 10M points took 12 % less CPU time in 8 strips than in one), but every seam
/// costs a merge; around 1M points per strip, the seed's best block size too, the balance is best.
constexpr std::size_t kStripPoints = std::size_t(1) << 20;

/// Strips wanted for n finite points: a multiple of the thread count, at least two per thread (strips
/// are handed out dynamically, so a slow strip does not hold up the others; equal task counts avoid a
/// tail where one thread runs the last strip alone). Non-decreasing in n, so the value for the raw
/// input size bounds the strips actually used (the arena is sized before the finite points are counted).
std::size_t stripTarget(std::size_t n, unsigned threads, const TinOptions& options) {
  std::size_t want = options.num_strips;
  if (want == 0) {
    if (n < 200000) {
      want = 1;
    } else {
      const std::size_t per_thread = (n + kStripPoints * threads - 1) / (kStripPoints * threads);
      want = threads * std::max<std::size_t>(threads > 1 ? 2 : 1, per_thread);
    }
  }
  return std::max<std::size_t>(1, std::min(want, std::max<std::size_t>(1, n / 16)));
}

/// A big block whose pages are given back in parallel slices (see page_memory.h) before it is freed.
struct Release {
  void* p;
  std::size_t bytes, slices;
};

/// Tasks [0, total) releasing the slices of `blocks` in order; returns false for other task numbers.
bool runReleaseTask(const std::vector<Release>& blocks, std::size_t task) {
  for (const Release& r : blocks) {
    if (task < r.slices) {
      detail::releaseSlice(r.p, r.bytes, task, r.slices);
      return true;
    }
    task -= r.slices;
  }
  return false;
}

std::size_t releaseTasks(const std::vector<Release>& blocks) {
  std::size_t total = 0;
  for (const Release& r : blocks) total += r.slices;
  return total;
}

}  // namespace

TinResult triangulate(const double* x, const double* y, std::size_t n, const TinOptions& options) {
  return triangulate(std::vector<double>(x, x + n), std::vector<double>(y, y + n), options);
}

TinResult triangulate(std::vector<double>&& x, std::vector<double>&& y, const TinOptions& options) {
  const auto t_start = std::chrono::steady_clock::now();
  if (x.size() != y.size()) throw Error("dw::tin::triangulate: x and y have different lengths");
  // Owned from here (the caller's vectors are left empty), and freed on every way out.
  std::vector<double> xin(std::move(x)), yin(std::move(y));
  const std::size_t n_in = xin.size();
  // Corners 3t + i of up to 2n + 2K triangles must fit 32 bits.
  if (n_in > 600000000u)
    throw Error("dw::tin::triangulate: too many points (" + std::to_string(n_in) +
                "); the limit is 600 million");
  const unsigned threads = resolveThreads(options.num_threads);
  std::mutex progress_mutex;
  auto progress = [&](const char* stage, double f) {
    if (!options.progress) return;
    std::lock_guard<std::mutex> lock(progress_mutex);
    options.progress(stage, f);
  };
  // Page hints only pay off with several workers and big blocks.
  const bool parallel_pages = threads > 1 && n_in >= (1u << 16);
  auto slicesFor = [&](std::size_t bytes) {
    return parallel_pages ? detail::pageSlices(bytes, 4 * std::size_t(threads)) : std::size_t(0);
  };

  TinResult result;
  // The adjacency array tn of the triangle arena is the storage the output triangles are finally
  // compacted into, so it is the result's own std::vector. A std::vector is value-initialised by one
  // thread; at 24 bytes/point that zero fill, mostly first-touch page faults, was the largest serial
  // step left (0.4 s at 21M points on the device). So the storage is reserved first (nothing touched),
  // its pages are mapped by the workers in parallel slices alongside the input scan, and the zero fill
  // proper, then at memory speed, runs on a helper thread while the workers scatter and sort; a strip
  // waits for it only before its first triangle.
  const std::size_t arena_slots = 2 * n_in + 2 * stripTarget(n_in, threads, options);
  std::vector<index_t>& tn_store = result.triangles;
  tn_store.reserve(3 * arena_slots);
  const std::size_t tn_bytes = tn_store.capacity() * sizeof(index_t);
  const std::size_t prefault_slices = slicesFor(tn_bytes);
  std::shared_future<void> tn_ready;
  // Joins the helper before `result` can go away, also when something below throws.
  struct WaitOnExit {
    std::shared_future<void>& f;
    ~WaitOnExit() {
      if (f.valid()) f.wait();
    }
  } wait_on_exit{tn_ready};
  auto startFill = [&]() {
    auto fill = [&tn_store, arena_slots]() { tn_store.resize(3 * arena_slots); };
    if (parallel_pages) {
      try {
        tn_ready = std::async(std::launch::async, fill).share();
      } catch (const std::system_error&) {
        // No thread to be had: filled here below.
      }
    }
    if (!tn_ready.valid()) {
      fill();
      std::promise<void> done;
      done.set_value();
      tn_ready = done.get_future().share();
    }
  };

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
  parallelForDynamic(prefault_slices + chunks, threads, [&](std::size_t task) {
    if (task < prefault_slices) {
      detail::prefaultSlice(tn_store.data(), tn_bytes, task, prefault_slices);
      return;
    }
    const std::size_t c = task - prefault_slices;
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
  startFill();
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
  const std::size_t want = stripTarget(n, threads, options);
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
  parallelForDynamic(chunks, threads, [&](std::size_t c) {
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
  parallelForDynamic(chunks, threads, [&](std::size_t c) {
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
  if (!parallel_pages) {  // else released by the first strip-phase tasks, below
    std::vector<double>().swap(xin);
    std::vector<double>().swap(yin);
  }
  result.stats.prepare_s = secondsSince(t_start);

  // Arena: strip s owns slots [2 start[s] + 2 s, 2 start[s + 1] + 2 (s + 1)), enough for 2 n_s + 2.
  const std::size_t total_slots = 2 * n + 2 * num_strips;
  if (total_slots > arena_slots) throw Error("dw::tin: internal consistency failure (arena too small)");
  std::unique_ptr<index_t[]> tv(new index_t[3 * total_slots]);
  detail::TriangleArena arena{tv.get(), nullptr};  // tn is set once the helper has filled it
  const detail::PointSet ps{pxy.get(), rank.get()};

  // The input's pages go back to the system as tasks beside the first strips rather than as a serial
  // step (unmapping 16 bytes/point took tens of milliseconds on the device).
  const std::vector<Release> input_blocks = {
      {xin.data(), xin.size() * sizeof(double), slicesFor(xin.size() * sizeof(double))},
      {yin.data(), yin.size() * sizeof(double), slicesFor(yin.size() * sizeof(double))}};
  const std::size_t input_tasks = releaseTasks(input_blocks);
  const auto t_strips = std::chrono::steady_clock::now();
  std::vector<Group> groups(num_strips);
  std::vector<std::vector<std::pair<index_t, index_t>>> strip_dups(num_strips);
  std::vector<double> strip_seconds(num_strips, 0.0), wait_seconds(num_strips, 0.0);
  std::atomic<std::size_t> strips_done{0};
  parallelForDynamic(input_tasks + num_strips, threads, [&](std::size_t task) {
    if (runReleaseTask(input_blocks, task)) return;
    const std::size_t s = task - input_tasks;
    const auto t0 = std::chrono::steady_clock::now();
    const std::size_t b = start[s], e = start[s + 1];
    Group& g = groups[s];
    g.strip_begin = s;
    g.strip_end = s + 1;
    const index_t base = static_cast<index_t>(2 * b + 2 * s), cap = static_cast<index_t>(2 * (e - b) + 2);
    std::vector<index_t> order(e - b);
    if (e > b) {
      // Spatial sort, then reorder the strip's coordinates physically so the walk reads memory in order.
      for (std::size_t i = b; i < e; ++i) order[i - b] = static_cast<index_t>(i);
      detail::brioHilbertSort(pxy.get(), order);
      {  // scoped: the scratch of the strips in flight adds to the peak memory
        std::vector<double> tmp(2 * order.size());
        for (std::size_t i = 0; i < order.size(); ++i) {
          tmp[2 * i] = pxy[2 * std::size_t(order[i])];
          tmp[2 * i + 1] = pxy[2 * std::size_t(order[i]) + 1];
        }
        std::copy(tmp.begin(), tmp.end(), pxy.get() + 2 * b);
      }
      std::vector<index_t> tmpi(order.size());
      for (std::size_t i = 0; i < order.size(); ++i) tmpi[i] = rank[order[i]];
      std::copy(tmpi.begin(), tmpi.end(), rank.get() + b);
      for (std::size_t i = b; i < e; ++i) order[i - b] = static_cast<index_t>(i);
    }
    const auto t1 = std::chrono::steady_clock::now();
    tn_ready.get();  // rethrows the helper's exception (e.g. out of memory)
    wait_seconds[s] = secondsSince(t1);
    if (e > b) {
      detail::BowyerWatson kernel(ps, detail::TriangleArena{tv.get(), tn_store.data()}, base, cap);
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
    strip_seconds[s] = secondsSince(t0) - wait_seconds[s];
    progress("strips", double(++strips_done) / double(num_strips));
  });
  std::vector<double>().swap(xin);
  std::vector<double>().swap(yin);
  tn_ready.get();
  arena.tn = tn_store.data();
  result.stats.strips_s = secondsSince(t_strips);
  for (const Group& g : groups) result.stats.strips += g.num_vertices > 0;
  result.stats.strip_max_s = *std::max_element(strip_seconds.begin(), strip_seconds.end());
  result.stats.fill_wait_s = *std::max_element(wait_seconds.begin(), wait_seconds.end());

  // Reduce: merge neighbours pairwise, level by level; the merges of one level run in parallel.
  const auto t_merge = std::chrono::steady_clock::now();
  std::atomic<std::size_t> band{0};
  const std::size_t levels =
      num_strips > 1 ? static_cast<std::size_t>(std::ceil(std::log2(double(num_strips)))) : 0;
  std::size_t level = 0;
  while (groups.size() > 1) {
    const std::size_t pairs = groups.size() / 2;
    std::vector<Group> next(pairs + groups.size() % 2);
    parallelForDynamic(pairs, threads, [&](std::size_t k) {
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

  // Output: compact the live real triangles into input-index triples, in place of the adjacency array
  // (no longer needed): chunk c writes [3 offset[c], 3 offset[c + 1]) of it and reads only tv and rank.
  // The coordinates are not read any more; their pages go back beside the writing.
  const auto t_out = std::chrono::steady_clock::now();
  const Group& all = groups.front();
  result.num_vertices = all.num_vertices;
  result.degenerate = !all.has_triangles;
  const std::vector<Release> xy_block = {
      {pxy.get(), 2 * n * sizeof(double), slicesFor(2 * n * sizeof(double))}};
  const std::size_t xy_tasks = releaseTasks(xy_block);
  std::size_t live_triangles = 0;
  if (all.has_triangles) {
    const std::size_t out_chunks =
        std::max<std::size_t>(1, std::min<std::size_t>(4 * threads, total_slots / 65536 + 1));
    auto slotBegin = [&](std::size_t c) { return c * total_slots / out_chunks; };
    auto live = [&](std::size_t t) {
      const index_t* v = tv.get() + 3 * t;
      return !(v[0] == kDead || v[0] == kGhost || v[1] == kGhost || v[2] == kGhost);
    };
    std::vector<std::size_t> offset(out_chunks + 1, 0);
    parallelForDynamic(out_chunks, threads, [&](std::size_t c) {
      std::size_t k = 0;
      for (std::size_t t = slotBegin(c); t < slotBegin(c + 1); ++t) k += live(t);
      offset[c + 1] = k;
    });
    for (std::size_t c = 0; c < out_chunks; ++c) offset[c + 1] += offset[c];
    live_triangles = offset[out_chunks];
    parallelForDynamic(xy_tasks + out_chunks, threads, [&](std::size_t task) {
      if (runReleaseTask(xy_block, task)) return;
      const std::size_t c = task - xy_tasks;
      index_t* out = tn_store.data() + 3 * offset[c];
      for (std::size_t t = slotBegin(c); t < slotBegin(c + 1); ++t) {
        if (!live(t)) continue;
        const index_t* v = tv.get() + 3 * t;
        *out++ = rank[v[0]];
        *out++ = rank[v[1]];
        *out++ = rank[v[2]];
      }
    });
  }
  // Shrinking keeps the storage; only when duplicates or skipped points left most of it unused is it
  // worth a copy.
  tn_store.resize(3 * live_triangles);
  if (tn_store.size() < tn_store.capacity() / 2) tn_store.shrink_to_fit();
  for (const auto& d : strip_dups)
    for (const auto& pr : d) result.duplicates.emplace_back(rank[pr.first], rank[pr.second]);
  std::sort(result.duplicates.begin(), result.duplicates.end());
  const std::vector<Release> arena_blocks = {
      {tv.get(), 3 * total_slots * sizeof(index_t), slicesFor(3 * total_slots * sizeof(index_t))},
      {rank.get(), n * sizeof(index_t), slicesFor(n * sizeof(index_t))}};
  parallelForDynamic(releaseTasks(arena_blocks), threads,
                     [&](std::size_t task) { runReleaseTask(arena_blocks, task); });
  tv.reset();
  pxy.reset();
  rank.reset();
  result.stats.output_s = secondsSince(t_out);
  return result;
}

}  // namespace tin
}  // namespace dw
