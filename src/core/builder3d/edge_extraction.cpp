// The Delaunay edges of a TetraMesh, each listed once, streamed from the tetrahedra.
//
// Every edge (a, b), a < b, lies in ~5 finite tetrahedra. Rather than walking each vertex's star
// (random access into the tetrahedra: measured 5 s for 1M points), the tetrahedra are streamed:
//  1. cut [first, last) into ranges of a with the same number of vertices, so that each range's edge
//     occurrences (3 per tetrahedron, see below, spread over the vertices) fit a bounded buffer;
//  2. (listByRange) list, per range, the vertex quadruples, sorted, of the tetrahedra that have an
//     edge owned there (a tetrahedron has three possible smaller endpoints; with Morton ids they are
//     nearly always in one range, and such whole quadruples come first in each list);
//  3. (edgesOfRanges) per range, in parallel: count the occurrences per a, bucket the b's by a, drop
//     repeats, and write the range's chunk.
// A tetrahedron gives only those of its edges at which it is an ascent of the edge's ring. The
// tetrahedra around an edge (a, b) form a closed ring, each written positively as (a, b, x, y) with x
// and y consecutive other vertices (consistent orientation: two neighbours in the ring induce opposite
// orientations on their shared face, so every one of them reads the ring in the same direction, x
// before y). A closed ring of distinct ids rises somewhere (x < y), kInfinite counting as the largest
// id, so every edge is given at least once, and about half as often as by all six edges (~2.5 times
// instead of ~5). The test is local: with the quadruple sorted, which of its edges rise is the parity
// of the sort: an even one gives (s0, s1), (s0, s3), (s1, s2) and (s2, s3), an odd one (s0, s2) and
// (s1, s3). The hull's edges lie in infinite tetrahedra too, which are listed for their finite edges.
// The lists hold the quadruples themselves, sorted once, not tetrahedron ids: through ids, stage 3
// fetched every tetrahedron from wherever its slot lay (slots follow the order of the cavities that
// freed them, not the vertex ids) and sorted its vertices, twice per range (100k points on 2
// threads: 17 % more instructions for the extraction). Copies cost 16 bytes a
// tetrahedron instead of 4, so the tetrahedra's pages go back as they are listed (below).
// No thread writes what another writes: each worker fills its own part of the lists' array (a global
// count per vertex needed locked adds).
#include <algorithm>
#include <atomic>
#include <memory>
#include <thread>
#include <type_traits>
#include <vector>

#include "core/builder3d/triangulation_3d.h"
#include "core/util/page_memory.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {
namespace builder3d {
namespace {

using EdgeChunks = Triangulation3D::EdgeChunks;
constexpr index_t kInfinite = TetraMesh::kInfinite;
constexpr index_t kDead = TetraMesh::kDead;
constexpr std::uint32_t kNoTet = TetraMesh::kNoTet;

struct RangeLists {
  std::size_t first = 0, last = 0;
  unsigned width_bits = 0;  // ranges are 2^width_bits ids wide (a shift, not a 64-bit division)
  std::size_t num_ranges = 0;
  unsigned workers = 0;
  // The lists, worker by worker, each worker's range by range, in one array of quadruples: list (w, r)
  // is quadruples [at[i], at[i + 1]) for i = w * num_ranges + r. A quadruple q is the sorted ids,
  // s0 < s1 < s2 < s3, of a tetrahedron whose sort was even, and (s0, s2, s1, s3) of one whose sort
  // was odd: both give (q0, q1) and (q2, q3), an even one (q1 < q2) also (q0, q3) and (q1, q2).
  SlotArray<index_t> quads;
  std::vector<std::size_t> at;
  // List i's quadruples [at[i], whole[i]) are finite and have s0, s1 and s2 in its range (all their
  // pairs are its occurrences); those from whole[i] on straddle ranges or hold kInfinite, and are
  // checked pair by pair.
  std::vector<std::size_t> whole;
  std::size_t rangeOf(index_t v) const { return static_cast<std::size_t>((v - first) >> width_bits); }
  std::size_t rangeStart(std::size_t r) const { return std::min(last, first + (r << width_bits)); }
  std::size_t list(unsigned w, std::size_t r) const { return std::size_t(w) * num_ranges + r; }
};

// 1. Ranges: `budget` occurrences each, estimated as 3 per tetrahedron slot spread over all points
// (a range holding more only makes its buffer bigger). At least one range per thread. Each thread
// holds one range's buffer, so the budget shrinks with the thread count (a floor of 2^18 gave the
// dragon's 16 threads 38 bytes per point of buffers, and the extraction a peak above the insertion's;
// 4 occurrences per point per thread still put the dragon's 4-16 thread extraction 6-10 B/pt above
// it, so 2, with no change in time measured on 1-2 threads). At most 2^19 (a range's bucket in 2 MiB,
// nearer the core's caches): on one thread, 1M uniform points took 0.385-0.393 s to extract with
// ranges of 2M occurrences and 0.323-0.335 s with 0.3M-0.5M; the dragon (437k) 0.161-0.165 s either way.
void planRanges(RangeLists& out, std::size_t nt, std::size_t n, unsigned num_threads) {
  const std::size_t first = out.first, last = out.last;
  const std::size_t span = last - first;
  const std::size_t budget = std::min<std::size_t>(
      std::size_t(1) << 19, std::max<std::size_t>(std::size_t(1) << 15, 2 * span / num_threads));
  const std::size_t per_vertex = std::max<std::size_t>(1, 3 * nt / std::max<std::size_t>(n, 1));
  const std::size_t wanted =
      std::min(span, std::max<std::size_t>(num_threads, (span * per_vertex + budget - 1) / budget));
  while ((std::size_t(1) << out.width_bits) * wanted < span) ++out.width_bits;
  out.num_ranges = ((span - 1) >> out.width_bits) + 1;
  out.workers = workerCount(nt, num_threads, 1 << 16);
}

// The live tetrahedra's sorted vertex quadruples listed by the range of ids owning their edges.
// The lists hold everything the edges need: `give_back`, when given, is tet_v itself, which the
// caller frees next, and its pages go back to the system as they are listed. `donor`, when given, is
// an array the caller frees next (the adjacency), whose storage the lists take over when it is big
// enough.
RangeLists listByRange(const SlotArray<index_t>& tet_v, std::size_t n, unsigned num_threads,
                       std::size_t first, std::size_t last, SlotArray<index_t>* give_back = nullptr,
                       SlotArray<index_t>* donor = nullptr) {
  if (num_threads == 0) num_threads = 1;
  if (give_back != nullptr && give_back != &tet_v)
    throw Error("dw::Triangulation3D::listByRange: give_back must be the listed array");
  RangeLists out;
  last = std::min(last, n);
  if (tet_v.empty() || first >= last) return out;
  const std::size_t nt = tet_v.size() / 4;
  out.first = first;
  out.last = last;

  planRanges(out, nt, n, num_threads);
  const std::size_t num_ranges = out.num_ranges;

  // 2. Worker w takes the w-th slice of the tetrahedra: per range, it counts the tetrahedra with an
  // edge owned there, then copies their quadruples into its part of the lists, each list sized
  // exactly. Dead slots (one id kDead, which sorts below kInfinite) are skipped.
  // Copying the quadruples would hold the tetrahedra twice (the dragon on 16 device threads peaked at
  // 268 bytes per point, the insertion at 247): with `give_back`, the fill gives back the pages of what
  // it has listed in steps of 1 MiB, whose ends lie on 1 MiB boundaries of the array's addresses, so
  // that consecutive steps give back whole pages, none twice.
  constexpr std::size_t kStepBytes = std::size_t(1) << 20;
  const std::uintptr_t base = reinterpret_cast<std::uintptr_t>(tet_v.data());
  auto stepEnd = [&](std::size_t t) {  // the first tetrahedron at or after a boundary beyond t
    const std::uintptr_t next = ((base + 16 * t) / kStepBytes + 1) * kStepBytes;
    return static_cast<std::size_t>((next - base) / 16);  // base is 16-aligned
  };
  auto forEachEntry = [&](std::size_t from, std::size_t to, auto&& emit) {
    for (std::size_t t = from; t < to; ++t) {
      const index_t* tv = &tet_v[4 * t];
      index_t s[4] = {tv[0], tv[1], tv[2], tv[3]};
      // A network of branch-free swaps: which id is smaller is a coin flip to the branch predictor
      // (GCC 12 compiles std::min and std::max here into branches). `odd` is the sort's parity.
      index_t odd = 0;
      auto order = [&](int i, int j) {
        const index_t swap = index_t(s[j] < s[i]);
        const index_t d = (s[i] ^ s[j]) & (0u - swap);
        s[i] ^= d;
        s[j] ^= d;
        odd ^= swap;
      };
      order(0, 1);
      order(2, 3);
      order(0, 2);
      order(1, 3);
      order(1, 2);
      if (s[3] == kDead || s[2] >= kDead) continue;
      // The ranges of the three possible owners s0 <= s1 <= s2; with Morton ids nearly always one.
      const index_t d = (s[1] ^ s[2]) & (0u - odd);  // odd: stored as (s0, s2, s1, s3), no branch
      const index_t q[4] = {s[0], s[1] ^ d, s[2] ^ d, s[3]};
      if (s[0] >= first && s[2] < last && out.rangeOf(s[0]) == out.rangeOf(s[2]) && s[3] != kInfinite) {
        emit(out.rangeOf(s[0]), q, std::true_type{});
        continue;
      }
      std::size_t previous = num_ranges;
      for (unsigned j = 0; j < 3; ++j) {
        if (s[j] < first || s[j] >= last) continue;
        const std::size_t r = out.rangeOf(s[j]);
        if (r != previous) emit(r, q, std::false_type{});
        previous = r;
      }
    }
  };
  std::vector<std::size_t>& at = out.at;
  at.assign(std::size_t(out.workers) * num_ranges + 1, 0);
  parallelFor(nt, out.workers, [&](std::size_t tb, std::size_t te, unsigned w) {
    std::size_t* count = &at[out.list(w, 0) + 1];
    forEachEntry(tb, te, [&](std::size_t r, const index_t*, auto) { ++count[r]; });
  });
  for (std::size_t i = 1; i < at.size(); ++i) at[i] += at[i - 1];
  // The lists' array: the donor's storage when it is big enough (the adjacency, freed next anyway,
  // whose pages are mapped already; on 1M points the lists are ~104 MB, 26k pages to map afresh), its
  // pages beyond the lists given back; otherwise the donor is freed first and the array is new.
  const std::size_t words = 4 * at.back();
  if (donor != nullptr && donor->capacity() >= words) {
    out.quads.swap(*donor);
    out.quads.resize(words);  // no writes: the allocator leaves growth unwritten, shrinking keeps it
    detail::releaseUnused(out.quads);
  } else {
    if (donor != nullptr) detail::freeScratch(*donor);
    out.quads.resize(words);
  }
  // The fill runs over the same slices as the count (parallelFor's blocks depend on nt and the worker
  // count only). Each list fills from its front with whole quadruples and from its back with
  // straddling ones; where they meet is `whole`.
  out.whole.assign(at.size() - 1, 0);
  parallelFor(nt, out.workers, [&](std::size_t tb, std::size_t te, unsigned w) {
    std::vector<std::size_t> front(at.begin() + out.list(w, 0), at.begin() + out.list(w, 0) + num_ranges);
    std::vector<std::size_t> back(at.begin() + out.list(w, 0) + 1,
                                  at.begin() + out.list(w, 0) + 1 + num_ranges);
    index_t* quads = out.quads.data();
    for (std::size_t b = tb; b < te;) {
      const std::size_t e = std::min(te, stepEnd(b));
      forEachEntry(b, e, [&](std::size_t r, const index_t* s, auto whole) {
        index_t* q = quads + 4 * (decltype(whole)::value ? front[r]++ : --back[r]);
        q[0] = s[0];
        q[1] = s[1];
        q[2] = s[2];
        q[3] = s[3];
      });
      if (give_back != nullptr) detail::releaseSlice(give_back->data() + 4 * b, 16 * (e - b), 0, 1);
      b = e;
    }
    std::copy(front.begin(), front.end(), out.whole.begin() + out.list(w, 0));
  });
  return out;
}

// Scratch of one worker of edgesOfRanges, reused from range to range.
struct RangeScratch {
  std::vector<std::uint32_t> bucket_offset, fill;
  std::vector<index_t> bucket;
  // Repeats of b under one a are dropped through a small open-addressing set of entries
  // (a << 32) | b, in which an entry of another a reads as empty: its size follows a's occurrences,
  // not the point count, so threads need no per-point stamp array (4 bytes per point per thread).
  std::vector<std::uint64_t> seen;
};

// Range r ([lo, hi) of a) bucketed: s.bucket holds each a's b's, repeats included, from
// s.bucket_offset[a - lo]. The range's lists' pages then go back.
inline void bucketRange(RangeLists& in, std::size_t r, std::size_t lo, std::size_t hi, RangeScratch& s) {
  auto& bucket_offset = s.bucket_offset;
  auto& fill = s.fill;
  auto& bucket = s.bucket;
  // Occurrences per a, then the bucket of each a. Each quadruple says which of its pairs it gives
  // and each pair's smaller endpoint (see RangeLists), and the only tests left are whether s0, s1,
  // s2 lie in the range. The listing made them: it put the finite quadruples they all lie in
  // (nearly all, with Morton ids) first in each list, and only the rest is tested pair by pair.
  // fn(a - lo, b, gives): whether an even quadruple's two more pairs are given is a coin flip, so
  // they are passed with the flag rather than branched on.
  auto forEachOccurrence = [&](auto&& fn) {
    for (unsigned w = 0; w < in.workers; ++w) {
      const std::size_t i = in.list(w, r);
      for (std::size_t k = in.at[i]; k < in.whole[i]; ++k) {
        const index_t* q = in.quads.data() + 4 * k;
        const bool even = q[1] < q[2];
        fn(q[0] - lo, q[1], true);
        fn(q[2] - lo, q[3], true);
        fn(q[0] - lo, q[3], even);
        fn(q[1] - lo, q[2], even);
      }
      for (std::size_t k = in.whole[i]; k < in.at[i + 1]; ++k) {
        const index_t* q = in.quads.data() + 4 * k;
        const bool even = q[1] < q[2], finite = q[3] != kInfinite;
        auto here = [&](index_t a) { return a >= lo && a < hi; };
        if (here(q[0])) {
          fn(q[0] - lo, q[1], true);
          if (even && finite) fn(q[0] - lo, q[3], true);
        }
        if (finite && here(q[2])) fn(q[2] - lo, q[3], true);
        if (even && here(q[1])) fn(q[1] - lo, q[2], true);
      }
    }
  };
  bucket_offset.assign(hi - lo + 1, 0);
  forEachOccurrence([&](std::size_t i, index_t, bool gives) { bucket_offset[i + 1] += gives; });
  for (std::size_t i = 0; i < hi - lo; ++i) bucket_offset[i + 1] += bucket_offset[i];
  bucket.resize(bucket_offset.back() + 1);  // the last entry takes the writes of pairs not given
  fill.assign(bucket_offset.begin(), bucket_offset.end() - 1);
  const std::size_t spare = bucket_offset.back();
  forEachOccurrence([&](std::size_t i, index_t b, bool gives) {
    // The select as a mask: written as `gives ? ... : ...`, GCC branched (a coin flip).
    const std::size_t at = fill[i];
    bucket[spare ^ ((at ^ spare) & (0 - std::size_t(gives)))] = b;
    fill[i] = static_cast<std::uint32_t>(at + gives);
  });
  for (unsigned w = 0; w < in.workers; ++w) {  // the range's lists are done with: pages back
    const std::size_t i = in.list(w, r);
    detail::releaseSlice(in.quads.data() + 4 * in.at[i], 16 * (in.at[i + 1] - in.at[i]), 0, 1);
  }
}

// Distinct b's moved to the front of the bucket, a by a; fill[a - lo] becomes the end of a's.
// Returns the range's edge count.
inline std::size_t dropRepeats(std::size_t lo, std::size_t hi, RangeScratch& s) {
  const auto& bucket_offset = s.bucket_offset;
  auto& fill = s.fill;
  auto& bucket = s.bucket;
  auto& seen = s.seen;
  std::size_t distinct = 0;
  for (std::size_t a = lo; a < hi; ++a) {
    const std::uint32_t begin = bucket_offset[a - lo], end = bucket_offset[a - lo + 1];
    const unsigned bits = tableBits(2 * std::size_t(end - begin));
    if (seen.size() < (std::size_t(1) << bits))
      seen.resize(std::size_t(1) << bits, std::uint64_t(kNoTet) << 32);
    const std::size_t mask = (std::size_t(1) << bits) - 1;
    // Branch-free but for collisions: whether b repeats is a coin flip (each edge comes ~5 times),
    // so the entry is always (re)written and the output advances by the flag.
    for (std::uint32_t k = begin; k < end; ++k) {
      const index_t b = bucket[k];
      const std::uint64_t key = std::uint64_t(a) << 32 | b;
      std::size_t h = hashKey(b, bits);
      // x = entry ^ key is 0 for a repeat, below 2^32 but not 0 for a collision (another b of
      // this a: probe on), and at least 2^32 for an empty entry. One compare, rarely true: the
      // boolean form compiled to a jump on "same a", a coin flip.
      std::uint64_t x = seen[h] ^ key;
      while (x - 1 < 0xFFFFFFFFull) {
        h = (h + 1) & mask;
        x = seen[h] ^ key;
      }
      seen[h] = key;
      bucket[distinct] = b;
      distinct += x != 0;
    }
    fill[a - lo] = static_cast<std::uint32_t>(distinct);
  }
  return distinct;
}

// The range's edges (a, b) from the scratch, written from `out` on.
inline void writeRange(std::size_t lo, std::size_t hi, const RangeScratch& s,
                       std::pair<index_t, index_t>* out) {
  std::size_t k = 0;
  for (std::size_t a = lo; a < hi; ++a)
    for (; k < s.fill[a - lo]; ++k) out[k] = {static_cast<index_t>(a), s.bucket[k]};
}

// Each range's edges from its lists. `edge_bound`, when not 0, bounds the edge count: the edges then
// go into one chunk, on any number of threads (each range written where the range before it ends).
EdgeChunks edgesOfRanges(RangeLists&& in, unsigned num_threads, std::size_t edge_bound = 0) {
  if (num_threads == 0) num_threads = 1;
  EdgeChunks chunks;
  const std::size_t num_ranges = in.num_ranges;
  if (num_ranges == 0) return chunks;
  // 3. The edges of each range. The ranges are claimed in order from one counter by the workers;
  // each range's list pages go back once they are bucketed, so the lists shrink as the edges grow.
  // Given a bound on the edge count, every range's edges go straight into one list, so that
  // joinChunks() hands it over as it is:
  //  - on one thread, appended range by range to the list reserved to the bound (the chunks had been
  //    faulted in, then copied into a list faulted in again: 1M points, 62 MB of edges; the bench's
  //    page faults fell from 252k to 222k);
  //  - on several, the list is mapped on all workers and sized to the bound first, and a range's edges
  //    are written at the end of the range before it, published through `end_of` as soon as each range
  //    knows its count (before it writes). The range before was claimed earlier by a worker that is
  //    running it, so the wait is short and cannot deadlock, even when the loop runs on fewer threads.
  //    Per-range chunks joined afterwards took 20 ms of a two-thread 1M-point build.
  // Without a bound, each range goes into a chunk of its own sized exactly (a growing vector per
  // thread held up to twice its edges while reallocating: 2 threads peaked 20 % above the insertion).
  const unsigned parts = static_cast<unsigned>(std::min<std::size_t>(num_threads, num_ranges));
  const bool one_list = edge_bound > 0;
  chunks.assign(one_list ? 1 : num_ranges, {});
  std::vector<std::pair<index_t, index_t>>& list = chunks[0];
  if (one_list) list.reserve(edge_bound);
  constexpr std::size_t kNotYet = ~std::size_t(0), kFailed = kNotYet - 1;
  std::unique_ptr<std::atomic<std::size_t>[]> end_of;
  if (one_list && parts > 1) {
    const std::size_t bytes = edge_bound * sizeof(list[0]), slices = detail::pageSlices(bytes, 4 * parts);
    parallelFor(slices, parts, [&](std::size_t b, std::size_t e, unsigned) {
      for (std::size_t k = b; k < e; ++k) detail::prefaultSlice(list.data(), bytes, k, slices);
    });
    list.resize(edge_bound);
    end_of.reset(new std::atomic<std::size_t>[num_ranges]);
    for (std::size_t r = 0; r < num_ranges; ++r) end_of[r].store(kNotYet, std::memory_order_relaxed);
  }
  // Where range r's edges begin in the one list: the end of range r - 1, once published.
  auto startOf = [&](std::size_t r) {
    if (r == 0) return std::size_t(0);
    std::size_t at = end_of[r - 1].load(std::memory_order_acquire);
    for (unsigned spins = 0; at == kNotYet; at = end_of[r - 1].load(std::memory_order_acquire))
      if (++spins > 64) std::this_thread::yield();
    return at;
  };
  std::atomic<std::size_t> next_range{0};
  auto work = [&]() {
    RangeScratch s;
    for (std::size_t r = next_range++; r < num_ranges; r = next_range++) {
      // A range that fails publishes kFailed, so that the ranges after it stop instead of waiting.
      struct PublishFailure {
        std::atomic<std::size_t>* slot;
        ~PublishFailure() {
          if (slot) slot->store(kFailed, std::memory_order_release);
        }
      } on_failure{end_of ? &end_of[r] : nullptr};
      const std::size_t lo = in.rangeStart(r), hi = in.rangeStart(r + 1);
      bucketRange(in, r, lo, hi, s);
      const std::size_t distinct = dropRepeats(lo, hi, s);
      if (one_list && !end_of) {
        std::size_t k = 0;
        for (std::size_t a = lo; a < hi; ++a)
          for (; k < s.fill[a - lo]; ++k) list.emplace_back(static_cast<index_t>(a), s.bucket[k]);
        continue;
      }
      std::pair<index_t, index_t>* out;
      if (end_of) {
        const std::size_t start = startOf(r);
        if (start == kFailed) return;  // an earlier range failed: its error is passed on
        if (start + distinct > edge_bound)
          throw Error("dw::Triangulation3D: more edges than Euler's bound (a corrupted triangulation)");
        end_of[r].store(start + distinct, std::memory_order_release);
        on_failure.slot = nullptr;
        out = list.data() + start;
      } else {
        chunks[r].resize(distinct);
        out = chunks[r].data();
      }
      writeRange(lo, hi, s, out);
    }
  };
  parallelFor(parts, parts, [&](std::size_t, std::size_t, unsigned) { work(); });
  if (end_of) {
    list.resize(end_of[num_ranges - 1].load(std::memory_order_relaxed));
    detail::releaseUnused(list);
  }
  return chunks;
}

}  // namespace

Triangulation3D::EdgeChunks Triangulation3D::edgeChunks(unsigned num_threads) const {
  return edgesOfRanges(listByRange(mesh_.tet_v, num_points_, num_threads, 0, num_points_), num_threads);
}

std::vector<std::pair<index_t, index_t>> Triangulation3D::edgesFrom(std::size_t first,
                                                                    std::size_t last) const {
  return joinChunks(edgesOfRanges(listByRange(mesh_.tet_v, num_points_, 1, first, last), 1));
}

std::vector<std::pair<index_t, index_t>> Triangulation3D::joinChunks(EdgeChunks&& chunks) {
  if (chunks.size() == 1) return std::move(chunks[0]);
  // Several chunks come only from extractions without an edge bound (edgesFrom, edgeChunks), whose
  // callers join them on one thread: appended chunk by chunk, each freed once copied, so the peak
  // holds the list and one chunk.
  std::size_t total = 0;
  for (const auto& c : chunks) total += c.size();
  std::vector<std::pair<index_t, index_t>> out;
  out.reserve(total);
  for (auto& c : chunks) {
    out.insert(out.end(), c.begin(), c.end());
    detail::freeScratch(c);
  }
  return out;
}

Triangulation3D::EdgeChunks Triangulation3D::releaseIntoEdgeChunks(unsigned num_threads) {
  // Only the vertex quadruples are needed from here on: free the rest before the edges are made,
  // pages first. A plain free left them resident whenever malloc had placed the arrays in its heap
  // rather than in a mapping of their own (after an earlier build had raised glibc's mmap threshold,
  // for arrays below its 32 MiB cap: a second 200k-point build on 2 threads peaked at 285 bytes per
  // point instead of 228, the extraction's buffers landing on fresh pages beside them).
  // Euler's relation for the triangulated ball: edges = V + T + H / 2 - 1 for T finite tetrahedra and
  // H hull triangles (one per infinite tetrahedron), so V + T + H, what is counted here, bounds them.
  const std::size_t edge_bound = num_inserted_ + numLiveTetrahedra();
  // The adjacency's storage, mapped already, becomes the lists' (listByRange's donor).
  SlotArray<index_t> adjacency;
  adjacency.swap(mesh_.tet_n);
  detail::freeScratch(mesh_.mark);
  detail::freeScratch(mesh_.free);
  detail::freeScratch(mesh_.birth);
  seq_ = Worker{};
  SlotArray<index_t> tets;
  tets.swap(mesh_.tet_v);
  num_inserted_ = 0;
  RangeLists lists = listByRange(tets, num_points_, num_threads, 0, num_points_, &tets, &adjacency);
  detail::freeScratch(adjacency);
  detail::freeScratch(tets);
  return edgesOfRanges(std::move(lists), num_threads, edge_bound);
}

}  // namespace builder3d
}  // namespace dw
