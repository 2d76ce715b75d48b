/// \file delaunay_tin.cpp
/// \brief The map/reduce driver: strips (map), Bowyer-Watson per strip in parallel, greedy merges of
/// adjacent groups (reduce, also parallel), then the compact triangle output. triangulate() reads as
/// its stages; TinBuild holds what one stage hands to the next.
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
#include "core/util/page_memory.h"
#include "merge_scheduler.h"
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
using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// Points per strip aimed at by default. Smaller strips sort and triangulate faster (the strip's arrays
/// stay closer in cache: 10M points take 12 % less CPU time in 8 strips than in one), but every seam
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

/// A slot holding a real triangle of the result (not unused, not a ghost).
inline bool isLive(const index_t* tv, std::size_t t) {
  const index_t* v = tv + 3 * t;
  return !(v[0] == kDead || v[0] == kGhost || v[1] == kGhost || v[2] == kGhost);
}

/// What the scans of one chunk of the input find.
struct ChunkScan {
  std::vector<double> sample[2];     // the sampled points' x and y, each sorted
  std::size_t out_of_range = kNone;  // first finite point the exact predicates cannot handle
  std::vector<index_t> skipped;
  std::vector<std::size_t> count;  // per strip; then where the chunk's points of each strip go
};

/// One call of triangulate(). The stages run in the order they are declared; each member says which
/// stage sets it. Members are destroyed in reverse: the buffers, then the team (stopped), then the
/// zero-fill helper is waited for, before the caller's result, which it writes, can go away.
class TinBuild {
 public:
  TinBuild(std::vector<double>&& x, std::vector<double>&& y, const TinOptions& options, TinResult& result,
           Clock::time_point t_start);

  void sampleInput();
  void cutStrips();
  void countStrips();
  void checkExactRange() const;
  void layOutStrips();
  void scatterIntoStrips();
  void triangulateAndMergeStrips();
  void writeOutput();

 private:
  void progress(const char* stage, double f);
  std::size_t slicesFor(std::size_t bytes) const;
  std::size_t chunkBegin(std::size_t c) const { return c * n_in_ / chunks_; }
  bool finite(std::size_t i) const { return std::isfinite(xin_[i]) && std::isfinite(yin_[i]); }
  void startFill();
  std::size_t chooseLongAxis();
  std::vector<double> mergedSample();
  void triangulateStrip(std::size_t s);
  void sortStrip(std::size_t b, std::size_t e, std::vector<index_t>& order);
  void mergeFrom(detail::MergeScheduler& scheduler, std::size_t b, std::size_t e);
  void recordStripStats();
  void planDuplicateRanges(std::size_t out_chunks);
  void writeDuplicates(std::size_t c);
  std::size_t compactTriangles(std::size_t out_chunks);
  void releaseArena();

  // Set up by the constructor.
  const TinOptions& options_;
  TinResult& result_;
  const Clock::time_point t_start_;
  std::vector<double> xin_, yin_;  // owned (the caller's vectors are left empty), freed on every way out
  const std::size_t n_in_;
  const unsigned threads_;
  const bool parallel_pages_;  // page hints only pay off with several workers and big blocks
  std::mutex progress_mutex_;
  std::size_t arena_slots_ = 0;
  std::vector<index_t>& tn_store_;  // the adjacency array, later the output (result_.triangles)
  std::shared_future<void> tn_ready_;
  struct WaitOnExit {  // joins the zero-fill helper, also when a stage throws
    std::shared_future<void>& f;
    ~WaitOnExit() {
      if (f.valid()) f.wait();
    }
  } wait_on_exit_{tn_ready_};
  ThreadTeam team_;  // one team for every parallel pass of this call (see parallel_for.h)

  // sampleInput
  std::size_t chunks_ = 1, sample_size_ = 0;
  std::vector<ChunkScan> scan_;
  // cutStrips
  int axis_ = 0;
  std::vector<double> splits_;
  std::size_t num_strips_ = 1;
  // layOutStrips: strip s holds positions [start_[s], start_[s + 1]) of the n_ finite points
  std::size_t n_ = 0;
  std::vector<std::size_t> start_;
  // scatterIntoStrips
  std::unique_ptr<double[]> pxy_;
  std::unique_ptr<index_t[]> rank_;
  // triangulateAndMergeStrips
  std::size_t total_slots_ = 0;
  std::unique_ptr<index_t[]> tv_;
  detail::PointSet ps_;
  Clock::time_point t_strips_;
  std::vector<Group> groups_;  // groups_[b]: the group whose first strip is b
  std::vector<std::vector<std::pair<index_t, index_t>>> strip_dups_;
  std::vector<double> strip_seconds_, wait_seconds_, last_strip_end_, last_merge_end_, merge_seconds_;
  std::atomic<std::size_t> strips_done_{0}, merges_done_{0}, band_{0};
  // writeOutput: range c of the duplicates starts at dup_at_[c][s] in strip s's list and at
  // dup_offset_[c] in the output
  std::vector<std::vector<std::size_t>> dup_at_;
  std::vector<std::size_t> dup_offset_;
};

TinBuild::TinBuild(std::vector<double>&& x, std::vector<double>&& y, const TinOptions& options,
                   TinResult& result, Clock::time_point t_start)
    : options_(options),
      result_(result),
      t_start_(t_start),
      xin_(std::move(x)),
      yin_(std::move(y)),
      n_in_(xin_.size()),
      threads_(resolveThreads(options.num_threads)),
      parallel_pages_(threads_ > 1 && n_in_ >= (1u << 16)),
      tn_store_(result.triangles),
      team_(threads_) {
  // Corners 3t + i of up to 2n + 2K triangles must fit 32 bits.
  if (n_in_ > 600000000u)
    throw Error("dw::tin::triangulate: too many points (" + std::to_string(n_in_) +
                "); the limit is 600 million");
  // The adjacency array tn of the triangle arena is the storage the output triangles are finally
  // compacted into, so it is the result's own std::vector. A std::vector is value-initialised by one
  // thread; at 24 bytes/point that zero fill, mostly first-touch page faults, would be the largest
  // serial step on many cores. So the storage is reserved first (nothing touched), its pages are
  // mapped by the workers in parallel slices alongside the input scan, and the zero fill proper, then
  // at memory speed, runs on a helper thread while the workers scatter and sort; a strip waits for it
  // only before its first triangle.
  arena_slots_ = 2 * n_in_ + 2 * stripTarget(n_in_, threads_, options_);
  tn_store_.reserve(3 * arena_slots_);
}

void TinBuild::progress(const char* stage, double f) {
  if (!options_.progress) return;
  std::lock_guard<std::mutex> lock(progress_mutex_);
  options_.progress(stage, f);
}

std::size_t TinBuild::slicesFor(std::size_t bytes) const {
  return parallel_pages_ ? dw::detail::pageSlices(bytes, 4 * std::size_t(threads_)) : std::size_t(0);
}

/// Starts the zero fill of the reserved output storage on a helper thread (here if none is to be had).
void TinBuild::startFill() {
  auto fill = [this]() { tn_store_.resize(3 * arena_slots_); };
  if (parallel_pages_) {
    try {
      tn_ready_ = std::async(std::launch::async, fill).share();
    } catch (const std::system_error&) {
      // No thread to be had: filled here below.
    }
  }
  if (!tn_ready_.valid()) {
    fill();
    std::promise<void> done;
    done.set_value();
    tn_ready_ = done.get_future().share();
  }
}

// Input is read in chunks in parallel (on many cores a serial pass here would cap the speed-up):
// sampleInput takes the strip sample (and maps the output array's pages), countStrips checks every
// point and counts the strips, scatterIntoStrips puts the points into strip order.

/// Pass A. The sample: the finite points among input indices k n_in / m, k < m, each chunk taking its
/// range, sorted per chunk and coordinate.
void TinBuild::sampleInput() {
  chunks_ = std::max<std::size_t>(1, std::min<std::size_t>(4 * threads_, n_in_ / 65536 + 1));
  sample_size_ = std::min<std::size_t>(n_in_, 1 << 16);
  auto sampleBegin = [&](std::size_t c) {  // first k with k n_in / m >= chunkBegin(c)
    return n_in_ ? (chunkBegin(c) * sample_size_ + n_in_ - 1) / n_in_ : 0;
  };
  const std::size_t tn_bytes = tn_store_.capacity() * sizeof(index_t);
  const std::size_t prefault_slices = slicesFor(tn_bytes);
  scan_.resize(chunks_);
  team_.forEach(prefault_slices + chunks_, [&](std::size_t task) {
    if (task < prefault_slices) {
      dw::detail::prefaultSlice(tn_store_.data(), tn_bytes, task, prefault_slices);
      return;
    }
    const std::size_t c = task - prefault_slices;
    ChunkScan& cs = scan_[c];
    for (std::size_t k = sampleBegin(c); k < sampleBegin(c + 1); ++k) {
      const std::size_t i = k * n_in_ / sample_size_;
      if (!finite(i)) continue;
      cs.sample[0].push_back(xin_[i]);
      cs.sample[1].push_back(yin_[i]);
    }
    std::sort(cs.sample[0].begin(), cs.sample[0].end());
    std::sort(cs.sample[1].begin(), cs.sample[1].end());
  });
  startFill();
}

/// The long axis: the wider side of the sample's bounding box (only speed depends on it). Returns the
/// number of finite points sampled.
std::size_t TinBuild::chooseLongAxis() {
  double lo[2] = {0, 0}, hi[2] = {0, 0};
  std::size_t sampled = 0;
  for (const ChunkScan& cs : scan_) {
    if (cs.sample[0].empty()) continue;
    for (int k = 0; k < 2; ++k) {
      lo[k] = sampled ? std::min(lo[k], cs.sample[k].front()) : cs.sample[k].front();
      hi[k] = sampled ? std::max(hi[k], cs.sample[k].back()) : cs.sample[k].back();
    }
    sampled += cs.sample[0].size();
  }
  axis_ = (hi[1] - lo[1]) > (hi[0] - lo[0]) ? 1 : 0;
  return sampled;
}

/// The sample's long-axis coordinates in order: the chunks' sorted runs merged pairwise, the merges of
/// one round in parallel.
std::vector<double> TinBuild::mergedSample() {
  std::vector<double> sample;
  std::vector<std::size_t> run_end;  // ends of the sorted runs in `sample`
  for (const ChunkScan& cs : scan_) {
    sample.insert(sample.end(), cs.sample[axis_].begin(), cs.sample[axis_].end());
    if (!cs.sample[axis_].empty()) run_end.push_back(sample.size());
  }
  for (std::size_t width = 1; width < run_end.size(); width *= 2)
    team_.forEach((run_end.size() + 2 * width - 1) / (2 * width), [&](std::size_t k) {
      const std::size_t r = 2 * width * k;
      if (r + width >= run_end.size()) return;
      const std::size_t b = r ? run_end[r - 1] : 0, m = run_end[r + width - 1];
      const std::size_t e = run_end[std::min(run_end.size(), r + 2 * width) - 1];
      std::inplace_merge(sample.begin() + std::ptrdiff_t(b), sample.begin() + std::ptrdiff_t(m),
                         sample.begin() + std::ptrdiff_t(e));
    });
  return sample;
}

/// Map: equal-count strips from quantiles of the sample's long-axis coordinate, as many as wanted for
/// the finite points the sample predicts.
void TinBuild::cutStrips() {
  const std::size_t sampled = chooseLongAxis();
  const std::size_t want = stripTarget(
      sample_size_ ? n_in_ / sample_size_ * sampled + n_in_ % sample_size_ * sampled / sample_size_ : 0,
      threads_, options_);
  if (want > 1) {
    const std::vector<double> sample = mergedSample();
    for (std::size_t k = 1; k < want && !sample.empty(); ++k) {
      const double s = sample[k * sample.size() / want];
      if (s > sample.front() && (splits_.empty() || s > splits_.back())) splits_.push_back(s);
    }
  }
  num_strips_ = splits_.size() + 1;
}

/// Pass B: every point checked (finite, in the exact predicates' range) and counted in its strip.
void TinBuild::countStrips() {
  team_.forEach(chunks_, [&](std::size_t c) {
    ChunkScan& cs = scan_[c];
    cs.count.assign(num_strips_, 0);
    StripLocator stripOf(splits_);
    const double* const x = xin_.data();
    const double* const y = yin_.data();
    const double* const along = axis_ == 0 ? x : y;
    const std::size_t end = chunkBegin(c + 1);
    for (std::size_t i = chunkBegin(c); i < end; ++i) {
      if (!(std::isfinite(x[i]) && std::isfinite(y[i]))) {
        cs.skipped.push_back(static_cast<index_t>(i));
        continue;
      }
      if (cs.out_of_range == kNone && !(pred::inExactRange(x[i]) && pred::inExactRange(y[i])))
        cs.out_of_range = i;
      ++cs.count[stripOf(along[i])];
    }
  });
}

void TinBuild::checkExactRange() const {
  for (const ChunkScan& cs : scan_)
    if (cs.out_of_range != kNone) {
      const std::size_t i = cs.out_of_range;
      throw Error("dw::tin::triangulate: point " + std::to_string(i) + " (" + std::to_string(xin_[i]) + ", " +
                  std::to_string(yin_[i]) +
                  ") is outside the range where the exact predicates are exact (each coordinate 0 or "
                  "between 2^-150 ~ 7e-46 and 2^200 ~ 1.6e60 in magnitude); rescale or re-centre the input");
    }
}

/// The skipped points, and where each strip and each chunk's part of it start. Within a strip, chunk
/// c's points follow those of chunks < c (stable order, so positions within a strip increase with the
/// input index, i.e. with the rank).
void TinBuild::layOutStrips() {
  for (const ChunkScan& cs : scan_)
    result_.skipped.insert(result_.skipped.end(), cs.skipped.begin(), cs.skipped.end());
  n_ = n_in_ - result_.skipped.size();
  start_.assign(num_strips_ + 1, 0);
  for (std::size_t s = 0; s < num_strips_; ++s) {
    std::size_t at = start_[s];
    for (ChunkScan& cs : scan_) {
      const std::size_t c = cs.count[s];
      cs.count[s] = at;
      at += c;
    }
    start_[s + 1] = at;
  }
}

/// Pass C: the finite points' coordinates and ranks scattered into strip order.
void TinBuild::scatterIntoStrips() {
  // Not value-initialised: the parallel scatter below is the first touch (a serial zero-fill of
  // 20 bytes/point measurably caps the many-core speed-up).
  pxy_.reset(new double[2 * n_]);
  rank_.reset(new index_t[n_]);
  team_.forEach(chunks_, [&](std::size_t c) {
    std::vector<std::size_t>& fill = scan_[c].count;
    StripLocator stripOf(splits_);
    const double* const x = xin_.data();
    const double* const y = yin_.data();
    const double* const along = axis_ == 0 ? x : y;
    double* const pxy = pxy_.get();
    index_t* const rank = rank_.get();
    const bool all_finite = scan_[c].skipped.empty();
    const std::size_t end = chunkBegin(c + 1);
    for (std::size_t i = chunkBegin(c); i < end; ++i) {
      if (!all_finite && !(std::isfinite(x[i]) && std::isfinite(y[i]))) continue;
      const std::size_t p = fill[stripOf(along[i])]++;
      pxy[2 * p] = x[i];
      pxy[2 * p + 1] = y[i];
      rank[p] = static_cast<index_t>(i);
    }
  });
  std::vector<ChunkScan>().swap(scan_);
  if (!parallel_pages_) {  // else released by the first strip-phase tasks
    std::vector<double>().swap(xin_);
    std::vector<double>().swap(yin_);
  }
  result_.stats.prepare_s = secondsSince(t_start_);
}

/// Map and reduce in one pass of the team: a worker that finishes a strip merges it at once with a
/// neighbouring group that is already complete, and goes on merging while it finds one (see
/// merge_scheduler.h), so merges overlap the remaining strips and, after the last strip, at most a
/// couple remain. The input's pages go back to the system as tasks beside the first strips rather
/// than as a serial step (unmapping 16 bytes/point takes tens of milliseconds).
void TinBuild::triangulateAndMergeStrips() {
  // Arena: strip s owns slots [2 start[s] + 2 s, 2 start[s + 1] + 2 (s + 1)), enough for 2 n_s + 2.
  total_slots_ = 2 * n_ + 2 * num_strips_;
  if (total_slots_ > arena_slots_) throw Error("dw::tin: internal consistency failure (arena too small)");
  tv_.reset(new index_t[3 * total_slots_]);
  ps_ = detail::PointSet{pxy_.get(), rank_.get()};
  const std::vector<Release> input_blocks = {
      {xin_.data(), xin_.size() * sizeof(double), slicesFor(xin_.size() * sizeof(double))},
      {yin_.data(), yin_.size() * sizeof(double), slicesFor(yin_.size() * sizeof(double))}};
  const std::size_t input_tasks = releaseTasks(input_blocks);
  t_strips_ = Clock::now();
  groups_.resize(num_strips_);
  strip_dups_.resize(num_strips_);
  for (std::vector<double>* v :
       {&strip_seconds_, &wait_seconds_, &last_strip_end_, &last_merge_end_, &merge_seconds_})
    v->assign(num_strips_, 0.0);
  detail::MergeScheduler scheduler(num_strips_);
  // Strips are handed out in the order 0, 2, 4, ..., then 1, 3, 5, ...: every strip of the second
  // half finds both neighbours done (or nearly), so the merges follow each strip at once instead of
  // waiting at the end for a run of adjacent strips that finish together, which would take a chain of
  // merges one after the other.
  const std::size_t evens = (num_strips_ + 1) / 2;
  team_.forEach(input_tasks + num_strips_, [&](std::size_t task) {
    if (runReleaseTask(input_blocks, task)) return;
    const std::size_t k = task - input_tasks;
    const std::size_t s = k < evens ? 2 * k : 2 * (k - evens) + 1;
    triangulateStrip(s);
    mergeFrom(scheduler, s, s + 1);
  });
  std::vector<double>().swap(xin_);
  std::vector<double>().swap(yin_);
  tn_ready_.get();
  if (scheduler.endOf(0) != num_strips_)
    throw Error("dw::tin: internal consistency failure (merges incomplete)");
  recordStripStats();
}

/// Spatial sort of strip positions [b, e), then the strip's coordinates and ranks reordered physically
/// so the walk reads memory in order; `order` ends as the positions b .. e - 1.
void TinBuild::sortStrip(std::size_t b, std::size_t e, std::vector<index_t>& order) {
  for (std::size_t i = b; i < e; ++i) order[i - b] = static_cast<index_t>(i);
  detail::brioHilbertSort(pxy_.get(), order);
  {  // scoped: the scratch of the strips in flight adds to the peak memory
    std::vector<double> tmp(2 * order.size());
    for (std::size_t i = 0; i < order.size(); ++i) {
      tmp[2 * i] = pxy_[2 * std::size_t(order[i])];
      tmp[2 * i + 1] = pxy_[2 * std::size_t(order[i]) + 1];
    }
    std::copy(tmp.begin(), tmp.end(), pxy_.get() + 2 * b);
  }
  std::vector<index_t> tmpi(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) tmpi[i] = rank_[order[i]];
  std::copy(tmpi.begin(), tmpi.end(), rank_.get() + b);
  for (std::size_t i = b; i < e; ++i) order[i - b] = static_cast<index_t>(i);
}

/// Strip s triangulated by the sequential kernel into its own slot range of the arena.
void TinBuild::triangulateStrip(std::size_t s) {
  const auto t0 = Clock::now();
  const std::size_t b = start_[s], e = start_[s + 1];
  Group& g = groups_[s];
  g.strip_begin = s;
  g.strip_end = s + 1;
  const index_t base = static_cast<index_t>(2 * b + 2 * s), cap = static_cast<index_t>(2 * (e - b) + 2);
  std::vector<index_t> order(e - b);
  if (e > b) sortStrip(b, e, order);
  const auto t1 = Clock::now();
  tn_ready_.get();  // rethrows the helper's exception (e.g. out of memory)
  wait_seconds_[s] = secondsSince(t1);
  const detail::TriangleArena strip_arena{tv_.get(), tn_store_.data()};
  if (e > b) {
    detail::BowyerWatson kernel(ps_, strip_arena, base, cap);
    kernel.run(order.data(), order.size());
    g.num_vertices = kernel.numVertices();
    g.has_triangles = kernel.hasTriangles();
    if (g.has_triangles)
      g.ghost = kernel.anyGhost();
    else
      g.loose = kernel.collinearVertices();
    // Duplicates as (input index, representative's input index), sorted here in parallel; the
    // output only merges the strips' sorted lists.
    std::vector<std::pair<index_t, index_t>>& d = strip_dups_[s];
    d.reserve(kernel.duplicates().size());
    for (const auto& pr : kernel.duplicates()) d.emplace_back(rank_[pr.first], rank_[pr.second]);
    std::sort(d.begin(), d.end());
    for (index_t t = base + kernel.used(); t < base + cap; ++t) g.free_slots.push_back(t);
  } else {
    for (index_t t = base; t < base + cap; ++t) g.free_slots.push_back(t);
  }
  for (const index_t t : g.free_slots) tv_[3 * t] = kDead;
  strip_seconds_[s] = secondsSince(t0) - wait_seconds_[s];
  last_strip_end_[s] = secondsSince(t_strips_);
  progress("strips", double(++strips_done_) / double(num_strips_));
}

/// Merges everything the completion of group [b, e) makes possible; runs on the completing worker.
void TinBuild::mergeFrom(detail::MergeScheduler& scheduler, std::size_t b, std::size_t e) {
  for (detail::MergeScheduler::Claim c = scheduler.complete(b, e); c.valid;) {
    const auto t0 = Clock::now();
    Group& l = groups_[c.left];
    Group& r = groups_[c.right];
    const std::size_t end = r.strip_end;
    std::size_t local = 0;
    // tn_store_ is filled: this worker has passed tn_ready_.get() before completing its strip.
    const detail::TriangleArena arena{tv_.get(), tn_store_.data()};
    l = detail::mergeGroups(ps_, arena, axis_, splits_[c.right - 1], std::move(l), std::move(r), &local);
    band_ += local;
    merge_seconds_[c.left] += secondsSince(t0);
    last_merge_end_[c.left] = std::max(last_merge_end_[c.left], secondsSince(t_strips_));
    progress("merge", double(++merges_done_) / double(num_strips_ - 1));
    c = scheduler.complete(c.left, end);
  }
}

void TinBuild::recordStripStats() {
  TinStats& stats = result_.stats;
  const double strips_end = *std::max_element(last_strip_end_.begin(), last_strip_end_.end());
  const double merges_end = *std::max_element(last_merge_end_.begin(), last_merge_end_.end());
  stats.strips_s = strips_end;
  stats.merge_s = std::max(0.0, merges_end - strips_end);
  for (const double m : merge_seconds_) stats.merge_work_s += m;
  for (std::size_t s = 0; s < num_strips_; ++s) stats.strips += start_[s + 1] > start_[s];
  stats.strip_max_s = *std::max_element(strip_seconds_.begin(), strip_seconds_.end());
  stats.fill_wait_s = *std::max_element(wait_seconds_.begin(), wait_seconds_.end());
  stats.merge_points = band_;
}

/// Output: the live real triangles compacted into input-index triples in place of the adjacency array
/// (no longer needed), the strips' duplicate lists merged, the arena given back.
void TinBuild::writeOutput() {
  const auto t_out = Clock::now();
  const Group& all = groups_.front();
  result_.num_vertices = all.num_vertices;
  result_.degenerate = !all.has_triangles;
  const std::size_t out_chunks =
      std::max<std::size_t>(1, std::min<std::size_t>(4 * threads_, total_slots_ / 65536 + 1));
  planDuplicateRanges(out_chunks);
  std::size_t live_triangles = 0;
  if (all.has_triangles)
    live_triangles = compactTriangles(out_chunks);
  else
    team_.forEach(dup_offset_.size() - 1, [&](std::size_t c) { writeDuplicates(c); });
  // Shrinking keeps the storage; only when duplicates or skipped points left most of it unused is it
  // worth a copy.
  tn_store_.resize(3 * live_triangles);
  if (tn_store_.size() < tn_store_.capacity() / 2) tn_store_.shrink_to_fit();
  releaseArena();
  result_.stats.output_s = secondsSince(t_out);
}

/// Duplicates: the strips' sorted lists are merged by ranges of the duplicate's input index, range c
/// of dup_chunks written by one task (the table is kept small when the caller asks for very many
/// strips).
void TinBuild::planDuplicateRanges(std::size_t out_chunks) {
  const std::size_t dup_chunks =
      std::max<std::size_t>(1, std::min<std::size_t>(out_chunks, (std::size_t(1) << 20) / num_strips_));
  dup_at_.assign(dup_chunks + 1, std::vector<std::size_t>(num_strips_, 0));
  for (std::size_t c = 0; c <= dup_chunks; ++c)
    for (std::size_t s = 0; s < num_strips_; ++s) {
      const auto& d = strip_dups_[s];
      const auto bound = std::make_pair(static_cast<index_t>(c * n_in_ / dup_chunks), index_t{0});
      dup_at_[c][s] = c == dup_chunks
                          ? d.size()
                          : static_cast<std::size_t>(std::lower_bound(d.begin(), d.end(), bound) - d.begin());
    }
  dup_offset_.assign(dup_chunks + 1, 0);
  for (std::size_t c = 0; c < dup_chunks; ++c) {
    dup_offset_[c + 1] = dup_offset_[c];
    for (std::size_t s = 0; s < num_strips_; ++s) dup_offset_[c + 1] += dup_at_[c + 1][s] - dup_at_[c][s];
  }
  result_.duplicates.resize(dup_offset_[dup_chunks]);
}

void TinBuild::writeDuplicates(std::size_t c) {
  auto out = result_.duplicates.begin() + std::ptrdiff_t(dup_offset_[c]);
  for (std::size_t s = 0; s < num_strips_; ++s)
    out = std::copy(strip_dups_[s].begin() + std::ptrdiff_t(dup_at_[c][s]),
                    strip_dups_[s].begin() + std::ptrdiff_t(dup_at_[c + 1][s]), out);
  std::sort(result_.duplicates.begin() + std::ptrdiff_t(dup_offset_[c]), out);
}

/// Chunk c of the slots writes [3 offset[c], 3 offset[c + 1]) of the output and reads only tv and
/// rank; the coordinates are not read any more, so their pages go back beside the writing. The
/// duplicates are written beside the count. Returns the number of triangles written.
std::size_t TinBuild::compactTriangles(std::size_t out_chunks) {
  const std::size_t dup_chunks = dup_offset_.size() - 1;
  const std::vector<Release> xy_block = {
      {pxy_.get(), 2 * n_ * sizeof(double), slicesFor(2 * n_ * sizeof(double))}};
  const std::size_t xy_tasks = releaseTasks(xy_block);
  const index_t* const tv = tv_.get();
  const std::size_t total_slots = total_slots_;
  auto slotBegin = [&](std::size_t c) { return c * total_slots / out_chunks; };
  std::vector<std::size_t> offset(out_chunks + 1, 0);
  team_.forEach(out_chunks + dup_chunks, [&](std::size_t task) {
    if (task >= out_chunks) {
      writeDuplicates(task - out_chunks);
      return;
    }
    std::size_t k = 0;
    for (std::size_t t = slotBegin(task); t < slotBegin(task + 1); ++t) k += isLive(tv, t);
    offset[task + 1] = k;
  });
  for (std::size_t c = 0; c < out_chunks; ++c) offset[c + 1] += offset[c];
  team_.forEach(xy_tasks + out_chunks, [&](std::size_t task) {
    if (runReleaseTask(xy_block, task)) return;
    const std::size_t c = task - xy_tasks;
    const index_t* const rank = rank_.get();
    index_t* out = tn_store_.data() + 3 * offset[c];
    for (std::size_t t = slotBegin(c); t < slotBegin(c + 1); ++t) {
      if (!isLive(tv, t)) continue;
      const index_t* v = tv + 3 * t;
      *out++ = rank[v[0]];
      *out++ = rank[v[1]];
      *out++ = rank[v[2]];
    }
  });
  return offset[out_chunks];
}

void TinBuild::releaseArena() {
  const std::vector<Release> arena_blocks = {
      {tv_.get(), 3 * total_slots_ * sizeof(index_t), slicesFor(3 * total_slots_ * sizeof(index_t))},
      {rank_.get(), n_ * sizeof(index_t), slicesFor(n_ * sizeof(index_t))}};
  team_.forEach(releaseTasks(arena_blocks), [&](std::size_t task) { runReleaseTask(arena_blocks, task); });
  tv_.reset();
  pxy_.reset();
  rank_.reset();
}

}  // namespace

TinResult triangulate(const double* x, const double* y, std::size_t n, const TinOptions& options) {
  return triangulate(std::vector<double>(x, x + n), std::vector<double>(y, y + n), options);
}

TinResult triangulate(std::vector<double>&& x, std::vector<double>&& y, const TinOptions& options) {
  const auto t_start = Clock::now();
  if (x.size() != y.size()) throw Error("dw::tin::triangulate: x and y have different lengths");
  TinResult result;
  TinBuild build(std::move(x), std::move(y), options, result, t_start);
  build.sampleInput();
  build.cutStrips();
  build.countStrips();
  build.checkExactRange();
  build.layOutStrips();
  build.scatterIntoStrips();
  build.triangulateAndMergeStrips();
  build.writeOutput();
  return result;
}

}  // namespace tin
}  // namespace dw
