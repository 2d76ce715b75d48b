// Partitioned parallel insertion (geogram's ParallelDelaunay3d): each pass splits the pending points
// into k-d cells of space, one per thread; a thread inserts a point only when everything the insertion
// touches lies in what it owns (Triangulation3D::Cell), and defers it otherwise. A pass reads:
// cut the cells -> deal the points to the threads -> open the slot pool -> find each thread's start
// -> insert, handing on what slow threads have not tried -> merge the threads' slots and counts.
// The perturbed Delaunay triangulation is unique, so the result does not depend on the thread count.
#include "core/builder3d/parallel_insertion.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <numeric>
#include <vector>

#include "core/util/page_memory.h"
#include "core/util/parallel_bucket.h"
#include "core/util/parallel_sort.h"
#include "core/util/process_memory.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {
namespace builder3d {
namespace {

// Pending points sampled for a pass's cuts (at most about this many).
constexpr std::size_t kSplitSample = 1 << 15;

}  // namespace

void Triangulation3D::CellSplit::build(const Vec3f* points, std::size_t m, unsigned count, unsigned pass,
                                       unsigned workers) {
  nodes.assign(1, {-1, 0.0, 0, 0});
  directions = kDirections[pass == 0 ? 0 : 1 + (pass - 1) % 4];
  struct Segment {
    unsigned node;
    std::size_t begin, end;  // of `order`
    unsigned first, count;   // threads
  };
  std::vector<index_t> order(m);
  std::iota(order.begin(), order.end(), index_t(0));
  std::vector<Segment> level{{0, 0, m, 0, count}};
  for (unsigned depth = 0; !level.empty(); ++depth) {
    const int direction = static_cast<int>(depth % 3);
    std::vector<double> at(level.size());
    std::vector<std::size_t> cut(level.size());
    // Small samples stay on this thread: starting threads (no team in scope) would cost more.
    parallelFor(level.size(), m >= 16384 ? workers : 1u, [&](std::size_t b, std::size_t e, unsigned) {
      std::vector<std::pair<double, index_t>> keyed;
      for (std::size_t i = b; i < e; ++i) {
        const Segment& g = level[i];
        const std::size_t n = g.end - g.begin;
        if (g.count <= 1 || n < 2) continue;
        keyed.resize(n);
        for (std::size_t j = 0; j < n; ++j) {
          const index_t v = order[g.begin + j];
          keyed[j] = {coordinate(points[v], direction), v};
        }
        const std::size_t k = n * (g.count / 2) / g.count;
        std::nth_element(keyed.begin(), keyed.begin() + k, keyed.end(),
                         [](const auto& x, const auto& y) { return x.first < y.first; });
        at[i] = keyed[k].first;
        // Below first, then at or above (keeping the counts as even as ties allow).
        std::size_t below = g.begin;
        for (const auto& q : keyed)
          if (q.first < at[i]) order[below++] = q.second;
        cut[i] = below;
        for (const auto& q : keyed)
          if (!(q.first < at[i])) order[below++] = q.second;
      }
    });
    std::vector<Segment> next;
    for (std::size_t i = 0; i < level.size(); ++i) {
      const Segment& g = level[i];
      if (g.count <= 1 || g.end - g.begin < 2) {
        nodes[g.node] = {-1, 0.0, g.first, g.first};
        continue;
      }
      const unsigned left = g.count / 2;
      const unsigned below = static_cast<unsigned>(nodes.size()), above = below + 1;
      nodes.push_back({-1, 0.0, 0, 0});
      nodes.push_back({-1, 0.0, 0, 0});
      nodes[g.node] = {direction, at[i], below, above};
      next.push_back({below, g.begin, cut[i], g.first, left});
      next.push_back({above, cut[i], g.end, g.first + left, g.count - left});
    }
    level.swap(next);
  }
}

// One pass of insertParallel over `threads` cells; run() leaves in `pending` what it deferred.
struct Triangulation3D::ParallelPass {
  ParallelPass(Triangulation3D& triangulation, unsigned thread_count, unsigned pass_index)
      : tri(triangulation),
        threads(thread_count),
        pass(pass_index),
        start(std::chrono::steady_clock::now()) {}

  void run(std::vector<index_t>& pending) {
    cutCells(pending);
    const std::size_t points_in_pass = pending.size();
    dealPoints(pending);
    openSlotPool(points_in_pass);
    findStarts();
    tri.stats_.parallel_setup_seconds += secondsSince(start);
    insertAll();
    merge(pending);
  }

 private:
  static double secondsSince(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  }
  void cutCells(const std::vector<index_t>& pending);
  void dealPoints(std::vector<index_t>& pending);
  void openSlotPool(std::size_t points_in_pass);
  void findStarts();
  void insertAll();
  void merge(std::vector<index_t>& pending);

  Triangulation3D& tri;
  const unsigned threads, pass;
  const std::chrono::steady_clock::time_point start;
  CellSplit split;
  std::vector<std::uint8_t> cell_of;
  std::vector<Cell> own;
  std::vector<Worker> workers;
  // A worker that fails (a duplicate point) stops; the others finish, and the slots and counts of all
  // are merged before the error is passed on, so the triangulation stays valid and consistent.
  std::vector<std::exception_ptr> errors;
};

void Triangulation3D::insertParallel(const index_t* ids, std::size_t m, unsigned num_threads) {
  if (!built()) throw Error("dw::Triangulation3D::insertParallel: build() first");
  if (mesh_.track_births) throw Error("dw::Triangulation3D::insertParallel: not with trackBirths(true)");
  for (std::size_t i = 0; i < m; ++i)
    if (ids[i] >= num_points_) throw Error("dw::Triangulation3D::insertParallel: vertex id out of range");
  insertBatch(std::vector<index_t>(ids, ids + m), num_threads);
}

void Triangulation3D::insertBatch(std::vector<index_t> pending, unsigned num_threads) {
  const std::size_t m = pending.size();
  detail::sortAdaptive(pending);
  // Small batches use fewer threads (min_points_per_thread_, see the header); two threads already
  // share a batch of half that many points. When a pass stalls (under a quarter of the points it tried
  // went in), the rest goes in on this thread: what is left then is held up by cavities that cross
  // cells whatever the cut (halving the threads instead inserted 1-3 % per pass at 16 threads, at four
  // times the sequential cost per point).
  const std::size_t min_per_thread = std::max<std::size_t>(1, min_points_per_thread_);
  constexpr unsigned kMaxPasses = 12;
  const std::size_t by_size = std::max<std::size_t>(m / min_per_thread, m >= min_per_thread / 2 ? 2 : 1);
  constexpr unsigned kMaxCells = 256;  // a pass's cell ids are bytes
  unsigned threads = static_cast<unsigned>(std::min<std::size_t>({num_threads, by_size, kMaxCells}));
  bool passes_ran = false;
  for (unsigned pass = 0; pass < kMaxPasses && threads > 1; ++pass) {
    if (pending.size() < threads * min_per_thread / 4)
      threads = static_cast<unsigned>(pending.size() * 4 / min_per_thread);
    if (threads < 2) break;
    const std::size_t before = pending.size(), handed_before = stats_.handed_on;
    ParallelPass(*this, threads, pass).run(pending);
    passes_ran = true;
    const std::size_t handed = static_cast<std::size_t>(stats_.handed_on - handed_before);
    // The pass threads' heaps (glibc keeps one per thread) hold their freed lists and scratch. Given
    // back after every pass, not once per batch: the dragon's last batch takes 9 passes at 16 threads,
    // and what they kept raised its peak by 3-4 B/pt.
    releaseFreeHeap();
    // Stalled: under a quarter of the points tried went in (those handed on were not tried).
    if ((pending.size() - handed) * 4 > (before - handed) * 3) break;
  }
  // The passes' growth estimate is generous: the untaken tail of their last fresh range, prefaulted,
  // held 0.13 slots per point at 2-8 threads. Its pages go back to the system (later growth maps them
  // again); within a batch, the next pass reuses them as they are.
  detail::releaseUnused(mesh_.tet_v);
  detail::releaseUnused(mesh_.tet_n);
  detail::releaseUnused(mesh_.mark);
  detail::sortAdaptive(pending);
  const auto rest_start = std::chrono::steady_clock::now();
  for (index_t v : pending) insert(v);
  if (passes_ran)
    stats_.rest_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - rest_start).count();
}

void Triangulation3D::ParallelPass::cutCells(const std::vector<index_t>& pending) {
  const Vec3f* const points = tri.points_;
  {
    // The cuts come from an evenly strided sample (ids follow a space-filling curve, so it covers the
    // pending points' extent): the medians of the whole batch, found on one thread, took 0.09 s of a
    // 1M-point build on 16 threads; cells off balance by a fraction of a percent cost far less.
    // The sample's points are copied first: a later pass's points lie scattered over the cloud, and
    // the split, reading them where they lie, took 3-4 ms of such a pass on 16 device threads.
    const std::size_t stride = std::max<std::size_t>(1, pending.size() / kSplitSample);
    std::vector<Vec3f> sample((pending.size() + stride - 1) / stride);
    parallelFor(sample.size(), workerCount(sample.size(), threads, 4096),
                [&](std::size_t b, std::size_t e, unsigned) {
                  for (std::size_t j = b; j < e; ++j) sample[j] = points[pending[j * stride]];
                });
    split.build(sample.data(), sample.size(), threads, pass, threads);
  }
  // Every point's cell, found once: ownership is tested ~40 times per insertion, each a descent of
  // the split tree (4 levels of projections at 16 threads; the device's 16-thread builds of 4M points
  // took 15 % more thread time without it). Not for a pass that inserts few points into many (a
  // sliding window's update), which would pay for a byte per point to test a handful.
  const std::size_t n = tri.num_points_;
  cell_of.resize(pending.size() * 8 >= n ? n : 0);
  parallelFor(cell_of.size(), threads, [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t v = b; v < e; ++v) cell_of[v] = static_cast<std::uint8_t>(split.cellOf(points[v]));
  });
  own.resize(threads);
  workers.resize(threads);
  for (unsigned i = 0; i < threads; ++i)
    own[i] = {&split, points, cell_of.empty() ? nullptr : cell_of.data(), n, i};
}

void Triangulation3D::ParallelPass::dealPoints(std::vector<index_t>& pending) {
  // The to-do lists, sized exactly (no list holds twice its points) and in id order per thread: ids
  // follow a space-filling curve, so consecutive walks are short. Slices of the pending list are
  // counted per cell, then copied to their offsets, both on all threads (one thread took 0.14 s of a
  // 4M-point build on 16).
  const Cell& cells = own[0];  // any thread's view gives every point's cell
  detail::parallelBucket(
      pending.size(), workerCount(pending.size(), threads, 1 << 14), threads,
      [&](std::size_t k) { return cells.cellOf(pending[k]); },
      [&](const std::vector<std::size_t>& sizes) {
        for (unsigned i = 0; i < threads; ++i) workers[i].deferred.resize(sizes[i]);
      },
      [&](std::size_t k, unsigned i, std::size_t rank) { workers[i].deferred[rank] = pending[k]; });
  detail::freeScratch(pending);  // held again by the to-do lists; refilled after the pass
}

void Triangulation3D::ParallelPass::openSlotPool(std::size_t points_in_pass) {
  // Slots: the recycled ones first (sorted, so that a chunk is one part of the arrays and two threads
  // rarely write one cache line), then fresh ones for the rest of the growth (about 6.7 per point).
  // Counting the recycled ones keeps repeated passes from inflating the arrays.
  TetraMesh& mesh = tri.mesh_;
  const std::size_t used = mesh.slots();
  const std::size_t growth = 7 * points_in_pass + 2 * kSlotChunk * threads;
  const std::size_t fresh =
      (growth > mesh.free.size() ? growth - mesh.free.size() : 0) + kSlotChunk * threads;
  if (4 * (used + fresh) > mesh.tet_v.capacity()) mesh.reserveSlots(used + fresh + (used + fresh) / 8);
  // The fresh range is only reserved here: a thread writes (and so maps) a chunk when it takes it
  // (takeSlots). Writing the range here, on one thread, took 0.13 s of a 4M-point build on 16 threads,
  // and faulting it in beforehand made the estimate's unused part resident (about 0.3 slots per point).
  mesh.sizeSlotsUnwritten(used + fresh);
  tri.pool_.swap(mesh.free);
  mesh.free.clear();
  std::sort(tri.pool_.begin(), tri.pool_.end());
  tri.pool_next_ = 0;
  tri.fresh_begin_ = used;
  tri.fresh_end_ = used + fresh;
}

void Triangulation3D::ParallelPass::findStarts() {
  // Each thread starts from an owned tetrahedron holding one of its points, found by walks that only
  // read (this phase ends before any thread writes); its list is rotated to begin at that point.
  // Points at the start of a list lie near a cell's boundary, so the tries are spread over the list.
  parallelFor(threads, threads, [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t i = b; i < e; ++i) {
      Worker& w = workers[i];
      w.rng = 0x9E3779B9u ^ static_cast<std::uint32_t>(i) * 0x85EBCA6Bu;
      w.last_tet = kNoTet;
      std::vector<index_t>& todo = w.deferred;
      constexpr std::size_t kTries = 16;
      index_t t = tri.last_tet_;
      for (std::size_t k = 0; k < kTries && k < todo.size(); ++k) {
        const std::size_t j = (todo.size() / 2 + k * todo.size() / kTries) % todo.size();
        double p[3];
        tri.point(todo[j], p);
        t = tri.walkAnywhere(p, t, w, std::uint64_t(1) << 20);
        if (t == kNoTet) break;
        if (tri.ownsTet(t, own[i])) {
          w.last_tet = t;
          std::rotate(todo.begin(), todo.begin() + j, todo.end());
          break;
        }
      }
    }
  });
}

void Triangulation3D::ParallelPass::insertAll() {
  // The cells hold the same number of points, but the threads do not insert at the same speed (on the
  // 16-core device, one pass's threads were busy 99-184 ms for nearly equal work, and which ones were
  // slow changed from run to run). Once half of the threads that insert are through their lists, the
  // others stop, if they are half through theirs, and hand what they have not tried on to the next
  // pass, whose cells split it among all threads. A point handed on is only inserted later, so the
  // triangulation is the same. (The half-through condition keeps cells that ties in the coordinates
  // left uneven from handing on most of their points, pass after pass.)
  auto inserts = [](const Worker& w) { return w.last_tet != kNoTet && !w.deferred.empty(); };
  unsigned inserting = 0;
  for (const Worker& w : workers) inserting += inserts(w);
  const unsigned hand_on_after = (inserting + 1) / 2;
  std::atomic<unsigned> finished{0};
  errors.assign(threads, nullptr);
  parallelFor(threads, threads, [&](std::size_t b, std::size_t e, unsigned) {
    for (std::size_t i = b; i < e; ++i) {
      Worker& w = workers[i];
      if (!inserts(w)) continue;
      std::vector<index_t> todo;
      todo.swap(w.deferred);
      const auto busy_start = std::chrono::steady_clock::now();
      std::size_t k = 0;
      try {
        for (; k < todo.size(); ++k) {
          if (k % 32 == 0 && 2 * k >= todo.size() &&
              finished.load(std::memory_order_relaxed) >= hand_on_after)
            break;
          if (!tri.insertOnThisCpu(todo[k], w, own[i])) {
            w.deferred.push_back(todo[k]);
            ++w.stats.deferred;
          }
        }
        w.deferred.insert(w.deferred.end(), todo.begin() + k, todo.end());
        w.stats.handed_on += todo.size() - k;
      } catch (...) {
        errors[i] = std::current_exception();
      }
      finished.fetch_add(1, std::memory_order_relaxed);
      w.stats.parallel_busy_sum = secondsSince(busy_start);
      detail::freeScratch(todo);  // freed plainly, its pages stayed in this thread's heap
    }
  });
}

void Triangulation3D::ParallelPass::merge(std::vector<index_t>& pending) {
  TetraMesh& mesh = tri.mesh_;
  pending.clear();
  double busy_max = 0.0;
  for (auto& w : workers) {
    busy_max = std::max(busy_max, w.stats.parallel_busy_sum);
    pending.insert(pending.end(), w.deferred.begin(), w.deferred.end());
    detail::freeScratch(w.deferred);
    for (index_t t : w.free)
      if (t >= tri.fresh_begin_) mesh.clearSlot(t);  // taken from the fresh range but not used (takeSlots)
    mesh.free.insert(mesh.free.end(), w.free.begin(), w.free.end());
    tri.num_inserted_ += w.stats.parallel_inserted;
    tri.stats_.add(w.stats);
    if (w.stats.parallel_inserted > 0) tri.last_tet_ = w.last_tet;
  }
  // What nobody took of the recycled slots goes back to the free list; the fresh range is cut where
  // the last chunk handed out ends (insertBatch gives the pages beyond back once the batch is in).
  const std::size_t recycled = tri.pool_.size(), total = recycled + (tri.fresh_end_ - tri.fresh_begin_);
  const std::size_t taken = std::min(tri.pool_next_, total);
  for (std::size_t k = taken; k < recycled; ++k) mesh.free.push_back(tri.pool_[k]);
  mesh.resizeSlots(tri.fresh_begin_ + (taken > recycled ? taken - recycled : 0));
  std::vector<index_t>().swap(tri.pool_);
  detail::freeScratch(cell_of);
  tri.pool_next_ = tri.fresh_begin_ = tri.fresh_end_ = 0;
  ++tri.stats_.parallel_passes;
  tri.stats_.parallel_busy_max += busy_max;
  tri.stats_.parallel_seconds += secondsSince(start);
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace builder3d
}  // namespace dw
