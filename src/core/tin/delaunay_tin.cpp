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

#include "core/util/page_memory.h"
#include "bowyer_watson.h"
#include "merge_scheduler.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
#include "pcl_delaunay_walk/core/geometry/predicates_2d.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"
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

/// Index of the strip holding long-axis coordinate v: the number of splits <= v (std::upper_bound).
/// Consecutive input points usually lie in the same strip (LiDAR comes in scan order), so the last
/// answer is tried first: a predictable test instead of a binary search for most points.
class StripLocator {
 public:
  explicit StripLocator(const std::vector<double>& splits) : splits_(splits) {}
  std::size_t operator()(double v) {
    const std::size_t k = splits_.size();
    if ((last_ == 0 || splits_[last_ - 1] <= v) && (last_ == k || v < splits_[last_])) return last_;
    last_ = static_cast<std::size_t>(std::upper_bound(splits_.begin(), splits_.end(), v) - splits_.begin());
    return last_;
  }

 private:
  const std::vector<double>& splits_;
  std::size_t last_ = 0;
};

/// A big block whose pages are given back in parallel slices (see page_memory.h) before it is freed.
struct Release {
  void* p;
  std::size_t bytes, slices;
};

/// Tasks [0, total) releasing the slices of `blocks` in order; returns false for other task numbers.
bool runReleaseTask(const std::vector<Release>& blocks, std::size_t task) {
  for (const Release& r : blocks) {
    if (task < r.slices) {
      dw::detail::releaseSlice(r.p, r.bytes, task, r.slices);
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
    return parallel_pages ? dw::detail::pageSlices(bytes, 4 * std::size_t(threads)) : std::size_t(0);
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
  // One team of threads for every parallel pass of this call (see parallel_for.h). Declared after the
  // helper's guard, so on the way out the team is stopped before the helper is waited for.
  ThreadTeam team(threads);

  // Input is read in chunks in parallel (on many cores a serial pass here would cap the speed-up):
  // pass A takes the strip sample (and maps the output array's pages), pass B checks every point and
  // counts the strips, pass C scatters the points into strip order.
  const std::size_t chunks = std::max<std::size_t>(1, std::min<std::size_t>(4 * threads, n_in / 65536 + 1));
  auto chunkBegin = [&](std::size_t c) { return c * n_in / chunks; };
  auto finite = [&](std::size_t i) { return std::isfinite(xin[i]) && std::isfinite(yin[i]); };
  // The sample: the finite points among input indices k n_in / m, k < m, each chunk taking its range.
  const std::size_t sample_size = std::min<std::size_t>(n_in, 1 << 16);
  auto sampleBegin = [&](std::size_t c) {  // first k with k n_in / m >= chunkBegin(c)
    return n_in ? (chunkBegin(c) * sample_size + n_in - 1) / n_in : 0;
  };
  struct ChunkScan {
    std::vector<double> sample[2];     // the sampled points' x and y, each sorted
    std::size_t out_of_range = kNone;  // first finite point the exact predicates cannot handle
    std::vector<index_t> skipped;
    std::vector<std::size_t> count;  // per strip
  };
  std::vector<ChunkScan> scan(chunks);
  team.forEach(prefault_slices + chunks, [&](std::size_t task) {
    if (task < prefault_slices) {
      dw::detail::prefaultSlice(tn_store.data(), tn_bytes, task, prefault_slices);
      return;
    }
    ChunkScan& cs = scan[task - prefault_slices];
    for (std::size_t k = sampleBegin(task - prefault_slices); k < sampleBegin(task - prefault_slices + 1);
         ++k) {
      const std::size_t i = k * n_in / sample_size;
      if (!finite(i)) continue;
      cs.sample[0].push_back(xin[i]);
      cs.sample[1].push_back(yin[i]);
    }
    std::sort(cs.sample[0].begin(), cs.sample[0].end());
    std::sort(cs.sample[1].begin(), cs.sample[1].end());
  });
  startFill();
  // The long axis: the wider side of the sample's bounding box (only speed depends on it).
  double lo[2] = {0, 0}, hi[2] = {0, 0};
  std::size_t sampled = 0;
  for (const ChunkScan& cs : scan) {
    if (cs.sample[0].empty()) continue;
    for (int k = 0; k < 2; ++k) {
      lo[k] = sampled ? std::min(lo[k], cs.sample[k].front()) : cs.sample[k].front();
      hi[k] = sampled ? std::max(hi[k], cs.sample[k].back()) : cs.sample[k].back();
    }
    sampled += cs.sample[0].size();
  }
  const int axis = (hi[1] - lo[1]) > (hi[0] - lo[0]) ? 1 : 0;
  const std::vector<double>& along = axis == 0 ? xin : yin;

  // Map: equal-count strips from quantiles of the sample's long-axis coordinate. The chunks' sorted
  // runs are merged pairwise, the merges of one round in parallel. The strip count is chosen for the
  // finite points the sample predicts.
  const std::size_t want =
      stripTarget(sample_size ? n_in / sample_size * sampled + n_in % sample_size * sampled / sample_size : 0,
                  threads, options);
  std::vector<double> splits;
  if (want > 1) {
    std::vector<double> sample;
    std::vector<std::size_t> run_end;  // ends of the sorted runs in `sample`
    for (const ChunkScan& cs : scan) {
      sample.insert(sample.end(), cs.sample[axis].begin(), cs.sample[axis].end());
      if (!cs.sample[axis].empty()) run_end.push_back(sample.size());
    }
    for (std::size_t width = 1; width < run_end.size(); width *= 2)
      team.forEach((run_end.size() + 2 * width - 1) / (2 * width), [&](std::size_t k) {
        const std::size_t r = 2 * width * k;
        if (r + width >= run_end.size()) return;
        const std::size_t b = r ? run_end[r - 1] : 0, m = run_end[r + width - 1];
        const std::size_t e = run_end[std::min(run_end.size(), r + 2 * width) - 1];
        std::inplace_merge(sample.begin() + std::ptrdiff_t(b), sample.begin() + std::ptrdiff_t(m),
                           sample.begin() + std::ptrdiff_t(e));
      });
    for (std::size_t k = 1; k < want && !sample.empty(); ++k) {
      const double s = sample[k * sample.size() / want];
      if (s > sample.front() && (splits.empty() || s > splits.back())) splits.push_back(s);
    }
  }
  const std::size_t num_strips = splits.size() + 1;
  team.forEach(chunks, [&](std::size_t c) {
    ChunkScan& cs = scan[c];
    cs.count.assign(num_strips, 0);
    StripLocator stripOf(splits);
    for (std::size_t i = chunkBegin(c); i < chunkBegin(c + 1); ++i) {
      if (!finite(i)) {
        cs.skipped.push_back(static_cast<index_t>(i));
        continue;
      }
      if (cs.out_of_range == kNone && !(pred::inExactRange(xin[i]) && pred::inExactRange(yin[i])))
        cs.out_of_range = i;
      ++cs.count[stripOf(along[i])];
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
  for (const ChunkScan& cs : scan)
    result.skipped.insert(result.skipped.end(), cs.skipped.begin(), cs.skipped.end());
  const std::size_t n = n_in - result.skipped.size();
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
  team.forEach(chunks, [&](std::size_t c) {
    std::vector<std::size_t>& fill = scan[c].count;
    StripLocator stripOf(splits);
    const bool all_finite = scan[c].skipped.empty();
    for (std::size_t i = chunkBegin(c); i < chunkBegin(c + 1); ++i) {
      if (!all_finite && !finite(i)) continue;
      const std::size_t p = fill[stripOf(along[i])]++;
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
  const detail::PointSet ps{pxy.get(), rank.get()};

  // Map and reduce in one pass of the team: a worker that finishes a strip merges it at once with a
  // neighbouring group that is already complete, and goes on merging while it finds one (see
  // merge_scheduler.h), so merges overlap the remaining strips and, after the last strip, at most a
  // couple remain. The input's pages go back to the system as tasks beside the first strips rather
  // than as a serial step (unmapping 16 bytes/point took tens of milliseconds on the device).
  const std::vector<Release> input_blocks = {
      {xin.data(), xin.size() * sizeof(double), slicesFor(xin.size() * sizeof(double))},
      {yin.data(), yin.size() * sizeof(double), slicesFor(yin.size() * sizeof(double))}};
  const std::size_t input_tasks = releaseTasks(input_blocks);
  const auto t_strips = std::chrono::steady_clock::now();
  std::vector<Group> groups(num_strips);  // groups[b]: the group whose first strip is b
  std::vector<std::vector<std::pair<index_t, index_t>>> strip_dups(num_strips);
  std::vector<double> strip_seconds(num_strips, 0.0), wait_seconds(num_strips, 0.0);
  std::vector<double> last_strip_end(num_strips, 0.0), last_merge_end(num_strips, 0.0);
  std::vector<double> merge_seconds(num_strips, 0.0);
  std::atomic<std::size_t> strips_done{0}, merges_done{0}, band{0};
  detail::MergeScheduler scheduler(num_strips);
  // Merges everything the completion of group [b, e) makes possible; runs on the completing worker.
  auto mergeFrom = [&](std::size_t b, std::size_t e) {
    for (detail::MergeScheduler::Claim c = scheduler.complete(b, e); c.valid;) {
      const auto t0 = std::chrono::steady_clock::now();
      Group& l = groups[c.left];
      Group& r = groups[c.right];
      const std::size_t end = r.strip_end;
      std::size_t local = 0;
      // tn_store is filled: this worker has passed tn_ready.get() before completing its strip.
      const detail::TriangleArena arena{tv.get(), tn_store.data()};
      l = detail::mergeGroups(ps, arena, axis, splits[c.right - 1], std::move(l), std::move(r), &local);
      band += local;
      merge_seconds[c.left] += secondsSince(t0);
      last_merge_end[c.left] = std::max(last_merge_end[c.left], secondsSince(t_strips));
      progress("merge", double(++merges_done) / double(num_strips - 1));
      c = scheduler.complete(c.left, end);
    }
  };
  // Strips are handed out in the order 0, 2, 4, ..., then 1, 3, 5, ...: every strip of the second
  // half finds both neighbours done (or nearly), so the merges follow each strip at once instead of
  // waiting at the end for a run of adjacent strips that finish together, which took a chain of
  // merges one after the other.
  const std::size_t evens = (num_strips + 1) / 2;
  team.forEach(input_tasks + num_strips, [&](std::size_t task) {
    if (runReleaseTask(input_blocks, task)) return;
    const std::size_t k = task - input_tasks;
    const std::size_t s = k < evens ? 2 * k : 2 * (k - evens) + 1;
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
    const detail::TriangleArena strip_arena{tv.get(), tn_store.data()};
    if (e > b) {
      detail::BowyerWatson kernel(ps, strip_arena, base, cap);
      kernel.run(order.data(), order.size());
      g.num_vertices = kernel.numVertices();
      g.has_triangles = kernel.hasTriangles();
      if (g.has_triangles)
        g.ghost = kernel.anyGhost();
      else
        g.loose = kernel.collinearVertices();
      // Duplicates as (input index, representative's input index), sorted here in parallel; the
      // output only merges the strips' sorted lists.
      std::vector<std::pair<index_t, index_t>>& d = strip_dups[s];
      d.reserve(kernel.duplicates().size());
      for (const auto& pr : kernel.duplicates()) d.emplace_back(rank[pr.first], rank[pr.second]);
      std::sort(d.begin(), d.end());
      for (index_t t = base + kernel.used(); t < base + cap; ++t) g.free_slots.push_back(t);
    } else {
      for (index_t t = base; t < base + cap; ++t) g.free_slots.push_back(t);
    }
    for (const index_t t : g.free_slots) tv[3 * t] = kDead;
    strip_seconds[s] = secondsSince(t0) - wait_seconds[s];
    last_strip_end[s] = secondsSince(t_strips);
    progress("strips", double(++strips_done) / double(num_strips));
    mergeFrom(s, s + 1);
  });
  std::vector<double>().swap(xin);
  std::vector<double>().swap(yin);
  tn_ready.get();
  if (scheduler.endOf(0) != num_strips)
    throw Error("dw::tin: internal consistency failure (merges incomplete)");
  const Group& all = groups.front();
  {
    const double strips_end = *std::max_element(last_strip_end.begin(), last_strip_end.end());
    const double merges_end = *std::max_element(last_merge_end.begin(), last_merge_end.end());
    result.stats.strips_s = strips_end;
    result.stats.merge_s = std::max(0.0, merges_end - strips_end);
    for (const double m : merge_seconds) result.stats.merge_work_s += m;
  }
  for (std::size_t s = 0; s < num_strips; ++s) result.stats.strips += start[s + 1] > start[s];
  result.stats.strip_max_s = *std::max_element(strip_seconds.begin(), strip_seconds.end());
  result.stats.fill_wait_s = *std::max_element(wait_seconds.begin(), wait_seconds.end());
  result.stats.merge_points = band;

  // Output: compact the live real triangles into input-index triples, in place of the adjacency array
  // (no longer needed): chunk c writes [3 offset[c], 3 offset[c + 1]) of it and reads only tv and rank.
  // The coordinates are not read any more; their pages go back beside the writing.
  const auto t_out = std::chrono::steady_clock::now();
  result.num_vertices = all.num_vertices;
  result.degenerate = !all.has_triangles;
  const std::vector<Release> xy_block = {
      {pxy.get(), 2 * n * sizeof(double), slicesFor(2 * n * sizeof(double))}};
  const std::size_t xy_tasks = releaseTasks(xy_block);
  std::size_t live_triangles = 0;
  const std::size_t out_chunks =
      std::max<std::size_t>(1, std::min<std::size_t>(4 * threads, total_slots / 65536 + 1));
  // Duplicates: the strips' sorted lists are merged by ranges of the duplicate's input index, range c
  // of dup_chunks written by one task: dup_at[c][s] is where range c starts in strip s's list (the
  // table is kept small when the caller asks for very many strips).
  const std::size_t dup_chunks =
      std::max<std::size_t>(1, std::min<std::size_t>(out_chunks, (std::size_t(1) << 20) / num_strips));
  std::vector<std::vector<std::size_t>> dup_at(dup_chunks + 1, std::vector<std::size_t>(num_strips, 0));
  for (std::size_t c = 0; c <= dup_chunks; ++c)
    for (std::size_t s = 0; s < num_strips; ++s) {
      const auto& d = strip_dups[s];
      const auto bound = std::make_pair(static_cast<index_t>(c * n_in / dup_chunks), index_t{0});
      dup_at[c][s] = c == dup_chunks
                         ? d.size()
                         : static_cast<std::size_t>(std::lower_bound(d.begin(), d.end(), bound) - d.begin());
    }
  std::vector<std::size_t> dup_offset(dup_chunks + 1, 0);
  for (std::size_t c = 0; c < dup_chunks; ++c) {
    dup_offset[c + 1] = dup_offset[c];
    for (std::size_t s = 0; s < num_strips; ++s) dup_offset[c + 1] += dup_at[c + 1][s] - dup_at[c][s];
  }
  result.duplicates.resize(dup_offset[dup_chunks]);
  auto writeDuplicates = [&](std::size_t c) {
    auto out = result.duplicates.begin() + std::ptrdiff_t(dup_offset[c]);
    for (std::size_t s = 0; s < num_strips; ++s)
      out = std::copy(strip_dups[s].begin() + std::ptrdiff_t(dup_at[c][s]),
                      strip_dups[s].begin() + std::ptrdiff_t(dup_at[c + 1][s]), out);
    std::sort(result.duplicates.begin() + std::ptrdiff_t(dup_offset[c]), out);
  };
  if (all.has_triangles) {
    auto slotBegin = [&](std::size_t c) { return c * total_slots / out_chunks; };
    auto live = [&](std::size_t t) {
      const index_t* v = tv.get() + 3 * t;
      return !(v[0] == kDead || v[0] == kGhost || v[1] == kGhost || v[2] == kGhost);
    };
    std::vector<std::size_t> offset(out_chunks + 1, 0);
    team.forEach(out_chunks + dup_chunks, [&](std::size_t task) {
      if (task >= out_chunks) {
        writeDuplicates(task - out_chunks);
        return;
      }
      std::size_t k = 0;
      for (std::size_t t = slotBegin(task); t < slotBegin(task + 1); ++t) k += live(t);
      offset[task + 1] = k;
    });
    for (std::size_t c = 0; c < out_chunks; ++c) offset[c + 1] += offset[c];
    live_triangles = offset[out_chunks];
    team.forEach(xy_tasks + out_chunks, [&](std::size_t task) {
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
  } else {
    team.forEach(dup_chunks, writeDuplicates);
  }
  // Shrinking keeps the storage; only when duplicates or skipped points left most of it unused is it
  // worth a copy.
  tn_store.resize(3 * live_triangles);
  if (tn_store.size() < tn_store.capacity() / 2) tn_store.shrink_to_fit();
  const std::vector<Release> arena_blocks = {
      {tv.get(), 3 * total_slots * sizeof(index_t), slicesFor(3 * total_slots * sizeof(index_t))},
      {rank.get(), n * sizeof(index_t), slicesFor(n * sizeof(index_t))}};
  team.forEach(releaseTasks(arena_blocks), [&](std::size_t task) { runReleaseTask(arena_blocks, task); });
  tv.reset();
  pxy.reset();
  rank.reset();
  result.stats.output_s = secondsSince(t_out);
  return result;
}

}  // namespace tin
}  // namespace dw
