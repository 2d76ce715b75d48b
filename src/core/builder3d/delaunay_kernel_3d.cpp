// Incremental Bowyer-Watson on flat arrays. See delaunay_kernel_3d.h for the representation.
#include "pcl_delaunay_walk/core/builder3d/delaunay_kernel_3d.h"

#include <algorithm>
#include <array>
#include <string>
#include <thread>

#include "pcl_delaunay_walk/core/predicates_3d.h"

namespace dw {
namespace builder3d {
namespace {

constexpr std::uint32_t kNoTet = 0xFFFFFFFFu;

inline std::uint64_t edgeKey(index_t a, index_t b) {
  return a < b ? (std::uint64_t(a) << 32) | b : (std::uint64_t(b) << 32) | a;
}

inline std::size_t hashKey(std::uint64_t k, unsigned bits) {
  return static_cast<std::size_t>((k * 0x9E3779B97F4A7C15ull) >> (64 - bits));
}

// The two positions other than i and j (i != j) in {0, 1, 2, 3}.
inline void otherTwo(unsigned i, unsigned j, unsigned& p, unsigned& q) {
  static constexpr std::uint8_t table[4][4][2] = {
      {{0, 0}, {2, 3}, {1, 3}, {1, 2}},
      {{2, 3}, {0, 0}, {0, 3}, {0, 2}},
      {{1, 3}, {0, 3}, {0, 0}, {0, 1}},
      {{1, 2}, {0, 2}, {0, 1}, {0, 0}},
  };
  p = table[i][j][0];
  q = table[i][j][1];
}

bool collinear(const double* a, const double* b, const double* c) {
  const double ayz[2] = {a[1], a[2]}, byz[2] = {b[1], b[2]}, cyz[2] = {c[1], c[2]};
  const double azx[2] = {a[2], a[0]}, bzx[2] = {b[2], b[0]}, czx[2] = {c[2], c[0]};
  return predicates::orient2d(a, b, c) == 0.0 && predicates::orient2d(ayz, byz, cyz) == 0.0 &&
         predicates::orient2d(azx, bzx, czx) == 0.0;
}

}  // namespace

void DelaunayKernel3D::setPoints(const Vec3f* points, std::size_t n) {
  if (n > kMaxVertices)
    throw Error("dw::DelaunayKernel3D: " + std::to_string(n) + " points exceed the kernel's limit of " +
                std::to_string(kMaxVertices));
  if (n > 0 && points == nullptr) throw Error("dw::DelaunayKernel3D: null point array");
  points_ = points;
  num_points_ = n;
}

index_t DelaunayKernel3D::newTet() {
  if (!free_.empty()) {
    const index_t t = free_.back();
    free_.pop_back();
    return t;
  }
  const std::size_t t = tet_v_.size() / 4;
  if (t >= (std::size_t(1) << 30))
    throw Error("dw::DelaunayKernel3D: more than 2^30 tetrahedra (neighbour codes are 32-bit)");
  if (tet_v_.size() == tet_v_.capacity()) {
    // Grow by a quarter rather than doubling: the arrays are most of the peak memory.
    const std::size_t cap = tet_v_.capacity() + tet_v_.capacity() / 4 + 64;
    tet_v_.reserve(cap);
    tet_n_.reserve(cap);
    mark_.reserve(cap / 4 + 16);
  }
  tet_v_.resize(tet_v_.size() + 4);
  tet_n_.resize(tet_n_.size() + 4);
  mark_.push_back(0);
  if (track_births_) birth_.push_back(static_cast<std::uint32_t>(num_inserted_));
  return static_cast<index_t>(t);
}

void DelaunayKernel3D::initialTetrahedron(index_t a, index_t b, index_t c, index_t d) {
  double pa[3], pb[3], pc[3], pd[3];
  point(a, pa);
  point(b, pb);
  point(c, pc);
  point(d, pd);
  if (predicates::orient3d(pa, pb, pc, pd) < 0.0) std::swap(a, b);
  const index_t base[4] = {a, b, c, d};
  for (int k = 0; k < 5; ++k) newTet();
  std::copy(base, base + 4, &tet_v_[0]);
  for (unsigned i = 0; i < 4; ++i) {
    // Replace v_i by infinity; swapping two other vertices makes the far side of the facet positive.
    index_t* v = &tet_v_[4 * std::size_t(i + 1)];
    std::copy(base, base + 4, v);
    v[i] = kInfinite;
    std::swap(v[(i + 1) % 4], v[(i + 2) % 4]);
  }
  // Five tetrahedra: match faces by their vertex sets.
  auto faceSet = [&](index_t t, unsigned f) {
    std::array<index_t, 3> s{};
    unsigned k = 0;
    for (unsigned j = 0; j < 4; ++j)
      if (j != f) s[k++] = tet_v_[4 * std::size_t(t) + j];
    std::sort(s.begin(), s.end());
    return s;
  };
  for (index_t t = 0; t < 5; ++t)
    for (unsigned f = 0; f < 4; ++f)
      for (index_t u = 0; u < 5; ++u)
        for (unsigned g = 0; g < 4; ++g)
          if (u != t && faceSet(t, f) == faceSet(u, g)) tet_n_[4 * std::size_t(t) + f] = 4 * u + g;
  last_tet_ = 0;
}

void DelaunayKernel3D::build(const index_t* order, std::size_t n,
                             const std::function<void(double)>& progress) {
  if (points_ == nullptr && n > 0) throw Error("dw::DelaunayKernel3D::build: setPoints() was not called");
  tet_v_.clear();
  tet_n_.clear();
  mark_.clear();
  free_.clear();
  birth_.clear();
  num_inserted_ = 0;
  stats_ = Stats{};
  if (n < 4) throw Error("dw::DelaunayKernel3D::build: a 3D triangulation needs at least 4 points");
  for (std::size_t i = 0; i < n; ++i)
    if (order[i] >= num_points_) throw Error("dw::DelaunayKernel3D::build: vertex id out of range");

  // The first tetrahedron: order[0], order[1] (distinct by contract), then the first point off
  // their line, then the first point off their plane.
  double p0[3], p1[3], q[3];
  point(order[0], p0);
  point(order[1], p1);
  if (p0[0] == p1[0] && p0[1] == p1[1] && p0[2] == p1[2])
    throw Error("dw::DelaunayKernel3D::build: duplicate points (the input must be distinct)");
  std::size_t kc = 2;
  for (; kc < n; ++kc) {
    point(order[kc], q);
    if (!collinear(p0, p1, q)) break;
  }
  if (kc == n) throw Error("dw::DelaunayKernel3D::build: all points are collinear (not a 3D set)");
  double p2[3];
  point(order[kc], p2);
  std::size_t kd = 2;
  for (; kd < n; ++kd) {
    if (kd == kc) continue;
    point(order[kd], q);
    if (predicates::orient3d(p0, p1, p2, q) != 0.0) break;
  }
  if (kd == n) throw Error("dw::DelaunayKernel3D::build: all points are coplanar (not a 3D set)");

  // ~6.75 per vertex on volumetric input; a little more here avoids a late reallocation, which would
  // hold old and new arrays at once (measured 324 B/point at 4M points against 216 at 1M).
  const std::size_t expected_tets = n * 7 + 64;
  tet_v_.reserve(4 * expected_tets);
  tet_n_.reserve(4 * expected_tets);
  mark_.reserve(expected_tets);
  initialTetrahedron(order[0], order[1], order[kc], order[kd]);
  num_inserted_ = 4;

  const std::size_t report_every = std::max<std::size_t>(1, n / 100);
  for (std::size_t i = 2; i < n; ++i) {
    if (i == kc || i == kd) continue;
    insert(order[i]);
    if (progress && i % report_every == 0) progress(static_cast<double>(i) / n);
  }
  if (progress) progress(1.0);
}

index_t DelaunayKernel3D::locate(index_t v, index_t start) {
  double p[3];
  point(v, p);
  index_t t = start;
  if (t >= tet_v_.size() / 4 || tet_v_[4 * std::size_t(t)] == kDead) t = last_tet_;
  {
    const index_t* tv = &tet_v_[4 * std::size_t(t)];
    for (unsigned k = 0; k < 4; ++k)
      if (tv[k] == kInfinite)
        t = tet_n_[4 * std::size_t(t) + k] >> 2;  // start from the finite side of the hull
  }
  index_t prev = kNoTet;
  // The visibility walk terminates in a Delaunay triangulation; the guard only protects against a
  // corrupted structure and falls back to a scan that cannot loop.
  const std::uint64_t guard = 64 + 4 * static_cast<std::uint64_t>(tet_v_.size() / 4);
  std::uint64_t steps = 0;
  for (;;) {
    if (++steps > guard) {
      ++stats_.fallback_locations;
      return locateByScan(v);
    }
    const index_t* tv = &tet_v_[4 * std::size_t(t)];
    if (tv[0] == kInfinite || tv[1] == kInfinite || tv[2] == kInfinite || tv[3] == kInfinite) return t;
    double q[4][3];
    for (unsigned k = 0; k < 4; ++k) point(tv[k], q[k]);
    rng_ ^= rng_ << 13;
    rng_ ^= rng_ >> 17;
    rng_ ^= rng_ << 5;
    const unsigned r = rng_ & 3u;
    bool moved = false;
    for (unsigned k = 0; k < 4; ++k) {
      const unsigned f = (r + k) & 3u;
      const index_t n = tet_n_[4 * std::size_t(t) + f] >> 2;
      if (n == prev) continue;
      const double* a = f == 0 ? p : q[0];
      const double* b = f == 1 ? p : q[1];
      const double* c = f == 2 ? p : q[2];
      const double* d = f == 3 ? p : q[3];
      if (predicates::orient3d(a, b, c, d) < 0.0) {
        prev = t;
        t = n;
        moved = true;
        break;
      }
    }
    stats_.walk_steps += 1;
    if (!moved) return t;
  }
}

index_t DelaunayKernel3D::locateByScan(index_t v) const {
  const std::size_t nt = tet_v_.size() / 4;
  double p[3];
  point(v, p);
  for (index_t t = 0; t < nt; ++t)
    if (tet_v_[4 * std::size_t(t)] != kDead && inConflict(t, v, p)) return t;
  throw Error("dw::DelaunayKernel3D: no tetrahedron conflicts with vertex " + std::to_string(v) +
              " (duplicate point or corrupted triangulation)");
}

bool DelaunayKernel3D::finiteInConflict(index_t t, index_t v, const double* e) const {
  const index_t* tv = &tet_v_[4 * std::size_t(t)];
  double a[3], b[3], c[3], d[3];
  point(tv[0], a);
  point(tv[1], b);
  point(tv[2], c);
  point(tv[3], d);
  const double s = predicates::insphere(a, b, c, d, e);
  if (s != 0.0) return s > 0.0;
  return predicates::insphereSoS(a, b, c, d, e, tv[0], tv[1], tv[2], tv[3], v) > 0;
}

bool DelaunayKernel3D::inConflict(index_t t, index_t v, const double* p) const {
  const index_t* tv = &tet_v_[4 * std::size_t(t)];
  unsigned k = 4;
  for (unsigned j = 0; j < 4; ++j)
    if (tv[j] == kInfinite) k = j;
  if (k == 4) return finiteInConflict(t, v, p);
  // Infinite tetrahedron: in conflict when v lies strictly beyond its hull facet. When v is coplanar
  // with the facet, the facet survives exactly when v is outside the facet's (perturbed) circumcircle,
  // which is the conflict test of the finite tetrahedron behind it; deciding both the same way keeps
  // the cavity connected and never creates a flat tetrahedron.
  double q[4][3];
  for (unsigned j = 0; j < 4; ++j) {
    if (j == k) {
      q[j][0] = p[0];
      q[j][1] = p[1];
      q[j][2] = p[2];
    } else {
      point(tv[j], q[j]);
    }
  }
  const double o = predicates::orient3d(q[0], q[1], q[2], q[3]);
  if (o != 0.0) return o > 0.0;
  return finiteInConflict(tet_n_[4 * std::size_t(t) + k] >> 2, v, p);
}

void DelaunayKernel3D::insert(index_t v) {
  if (!built()) throw Error("dw::DelaunayKernel3D::insert: build() first");
  if (v >= num_points_) throw Error("dw::DelaunayKernel3D::insert: vertex id out of range");
  index_t t = locate(v, last_tet_);
  double p[3];
  point(v, p);
  {
    // A walk that stops in a finite tetrahedron has v in its closed hull, hence strictly inside its
    // circumsphere unless v repeats a vertex. Check instead of trusting: a wrong root corrupts the mesh.
    const index_t* tv = &tet_v_[4 * std::size_t(t)];
    const Vec3f& pv = points_[v];
    for (unsigned k = 0; k < 4; ++k) {
      if (tv[k] == kInfinite) continue;
      const Vec3f& q = points_[tv[k]];
      if (q.x == pv.x && q.y == pv.y && q.z == pv.z)
        throw Error("dw::DelaunayKernel3D::insert: vertex " + std::to_string(v) + " duplicates vertex " +
                    std::to_string(tv[k]));
    }
  }

  // Cavity: every tetrahedron whose (perturbed) circumsphere contains v; connected, found by BFS.
  cavity_.clear();
  stack_.clear();
  outside_.clear();
  boundary_.clear();
  mark_[t] = 1;
  cavity_.push_back(t);
  stack_.push_back(t);
  while (!stack_.empty()) {
    const index_t c = stack_.back();
    stack_.pop_back();
    for (unsigned f = 0; f < 4; ++f) {
      const std::uint32_t nc = tet_n_[4 * std::size_t(c) + f];
      const index_t n = nc >> 2;
      std::uint8_t m = mark_[n];
      if (m == 1) continue;
      if (m == 0) {
        ++stats_.conflict_tests;
        if (inConflict(n, v, p)) {
          mark_[n] = 1;
          cavity_.push_back(n);
          stack_.push_back(n);
          continue;
        }
        mark_[n] = 2;
        outside_.push_back(n);
      }
      BoundaryFace bf;
      std::copy(&tet_v_[4 * std::size_t(c)], &tet_v_[4 * std::size_t(c)] + 4, bf.v);
      bf.v[f] = v;
      bf.outer = nc;
      bf.face = f;
      boundary_.push_back(bf);
    }
  }
  for (index_t o : outside_) mark_[o] = 0;
  for (index_t c : cavity_) mark_[c] = 0;

  // Link table for the faces through v: each cavity-boundary edge (a, b) is shared by exactly two
  // boundary triangles, so the two new tetrahedra on it find each other by the key (a, b).
  const std::size_t edges = boundary_.size() * 3 / 2 + 1;
  unsigned bits = 6;
  while ((std::size_t(1) << bits) < 2 * edges) ++bits;
  if (link_key_.size() < (std::size_t(1) << bits)) {
    link_key_.assign(std::size_t(1) << bits, 0);
    link_val_.assign(std::size_t(1) << bits, 0);
    link_gen_.assign(std::size_t(1) << bits, 0);
    generation_ = 0;
  } else {
    bits = 0;
    while ((std::size_t(1) << bits) < link_key_.size()) ++bits;
  }
  if (++generation_ == 0) {
    std::fill(link_gen_.begin(), link_gen_.end(), 0u);
    generation_ = 1;
  }
  const std::size_t mask = link_key_.size() - 1;

  index_t nt = 0;
  for (std::size_t k = 0; k < boundary_.size(); ++k) {
    const BoundaryFace& bf = boundary_[k];
    nt = k < cavity_.size() ? cavity_[k] : newTet();
    if (track_births_) birth_[nt] = static_cast<std::uint32_t>(num_inserted_ + 1);
    std::copy(bf.v, bf.v + 4, &tet_v_[4 * std::size_t(nt)]);
    tet_n_[4 * std::size_t(nt) + bf.face] = bf.outer;
    tet_n_[bf.outer] = 4 * nt + bf.face;
    for (unsigned j = 0; j < 4; ++j) {
      if (j == bf.face) continue;
      unsigned pa, pb;
      otherTwo(j, bf.face, pa, pb);
      const std::uint64_t key = edgeKey(bf.v[pa], bf.v[pb]);
      std::size_t s = hashKey(key, bits);
      for (;;) {
        if (link_gen_[s] != generation_) {
          link_gen_[s] = generation_;
          link_key_[s] = key;
          link_val_[s] = 4 * nt + j;
          break;
        }
        if (link_key_[s] == key) {
          const std::uint32_t other = link_val_[s];
          tet_n_[4 * std::size_t(nt) + j] = other;
          tet_n_[other] = 4 * nt + j;
          break;
        }
        s = (s + 1) & mask;
      }
    }
  }
  stats_.created_tets += boundary_.size();
  for (std::size_t k = boundary_.size(); k < cavity_.size(); ++k) {
    tet_v_[4 * std::size_t(cavity_[k])] = kDead;
    free_.push_back(cavity_[k]);
  }
  last_tet_ = nt;
  ++num_inserted_;
}

DelaunayKernel3D::EdgeChunks DelaunayKernel3D::edgeChunks(unsigned num_threads) const {
  return extractEdges(tet_v_, num_points_, num_threads, 0, num_points_);
}

std::vector<std::pair<index_t, index_t>> DelaunayKernel3D::edgesFrom(std::size_t first,
                                                                     std::size_t last) const {
  EdgeChunks c = extractEdges(tet_v_, num_points_, 1, first, last);
  return std::move(c[0]);
}

std::vector<index_t> DelaunayKernel3D::hullVertices() const {
  std::vector<index_t> out;
  const std::size_t nt = tet_v_.size() / 4;
  for (std::size_t t = 0; t < nt; ++t) {
    const index_t* tv = &tet_v_[4 * t];
    if (tv[0] == kDead) continue;
    if (tv[0] != kInfinite && tv[1] != kInfinite && tv[2] != kInfinite && tv[3] != kInfinite) continue;
    for (unsigned k = 0; k < 4; ++k)
      if (tv[k] != kInfinite) out.push_back(tv[k]);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

DelaunayKernel3D::EdgeChunks DelaunayKernel3D::releaseIntoEdgeChunks(unsigned num_threads) {
  // Only the vertex quadruples are needed from here on: free the rest before the edges are made.
  std::vector<std::uint32_t>().swap(tet_n_);
  std::vector<std::uint8_t>().swap(mark_);
  std::vector<index_t>().swap(free_);
  std::vector<std::uint32_t>().swap(birth_);
  std::vector<std::uint64_t>().swap(link_key_);
  std::vector<std::uint32_t>().swap(link_val_);
  std::vector<std::uint32_t>().swap(link_gen_);
  std::vector<index_t> tets;
  tets.swap(tet_v_);
  num_inserted_ = 0;
  return extractEdges(tets, num_points_, num_threads, 0, num_points_);
}

DelaunayKernel3D::EdgeChunks DelaunayKernel3D::extractEdges(const std::vector<index_t>& tet_v_, std::size_t n,
                                                            unsigned num_threads, std::size_t first,
                                                            std::size_t last) {
  // Every edge (a, b), a < b, lies in ~5 finite tetrahedra. Rather than walking each vertex's star
  // (random access into the tetrahedra: measured 5 s for 1M points), stream over the tetrahedra once
  // to count, per smaller endpoint a, the edge occurrences, then once per range of a whose occurrences
  // fit a bounded buffer: bucket the b's by a and drop repeats with a stamp. Sequential reads only,
  // memory bounded by the buffer (about 16 bytes per point) instead of all ~40 occurrences per point.
  if (num_threads == 0) num_threads = 1;
  EdgeChunks chunks(num_threads);
  if (tet_v_.empty()) return chunks;
  const std::size_t nt = tet_v_.size() / 4;

  // Pair (i, j) of a tetrahedron's vertices; the smaller endpoint owns the occurrence. min/max
  // compile to conditional moves: a sorting network's branches mispredicted badly here.
  static constexpr unsigned kPairs[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

  // Occurrences per smaller endpoint a in [first, last); edges of infinite tetrahedra also lie in
  // finite ones. `occurrences` is indexed by a - first.
  last = std::min(last, n);
  if (first >= last) return chunks;
  std::vector<std::uint32_t> occurrences(last - first + 1, 0);
  for (index_t t = 0; t < nt; ++t) {
    const index_t* tv = &tet_v_[4 * std::size_t(t)];
    if (std::max(std::max(tv[0], tv[1]), std::max(tv[2], tv[3])) >= kDead) continue;
    for (const auto& pr : kPairs) {
      const index_t a = std::min(tv[pr[0]], tv[pr[1]]);
      if (a >= first && a < last) ++occurrences[a - first];
    }
  }
  // Ranges of a with at most `budget` occurrences each (a single vertex may exceed it alone).
  const std::size_t budget = std::max<std::size_t>(std::size_t(1) << 20, 4 * (last - first) / num_threads);
  std::vector<std::size_t> range_start{first};
  {
    std::size_t acc = 0;
    for (std::size_t a = first; a < last; ++a) {
      if (acc > 0 && acc + occurrences[a - first] > budget) {
        range_start.push_back(a);
        acc = 0;
      }
      acc += occurrences[a - first];
    }
    range_start.push_back(last);
  }
  const std::size_t num_ranges = range_start.size() - 1;

  auto work = [&](unsigned part) {
    auto& out = chunks[part];
    std::vector<index_t> stamp(n, kNoTet);
    std::vector<std::uint32_t> offset;
    std::vector<index_t> bucket;
    for (std::size_t r = part; r < num_ranges; r += num_threads) {
      const std::size_t lo = range_start[r], hi = range_start[r + 1];
      offset.assign(hi - lo + 1, 0);
      for (std::size_t a = lo; a < hi; ++a) offset[a - lo + 1] = offset[a - lo] + occurrences[a - first];
      bucket.resize(offset.back());
      std::vector<std::uint32_t> fill(offset.begin(), offset.end() - 1);
      for (index_t t = 0; t < nt; ++t) {
        const index_t* tv = &tet_v_[4 * std::size_t(t)];
        const index_t vmax = std::max(std::max(tv[0], tv[1]), std::max(tv[2], tv[3]));
        const index_t vmin = std::min(std::min(tv[0], tv[1]), std::min(tv[2], tv[3]));
        if (vmax >= kDead || vmin >= hi || vmax < lo) continue;  // Morton ids: most tetrahedra skip here
        for (const auto& pr : kPairs) {
          const index_t a = std::min(tv[pr[0]], tv[pr[1]]);
          if (a >= lo && a < hi) bucket[fill[a - lo]++] = std::max(tv[pr[0]], tv[pr[1]]);
        }
      }
      for (std::size_t a = lo; a < hi; ++a)
        for (std::uint32_t k = offset[a - lo]; k < offset[a - lo + 1]; ++k) {
          const index_t b = bucket[k];
          if (stamp[b] == a) continue;
          stamp[b] = static_cast<index_t>(a);
          out.emplace_back(static_cast<index_t>(a), b);
        }
    }
  };
  if (num_threads == 1 || num_ranges == 1) {
    work(0);
    for (unsigned p = 1; p < num_threads && num_ranges == 1; ++p) chunks[p].clear();
  } else {
    std::vector<std::thread> pool;
    for (unsigned p = 1; p < num_threads; ++p) pool.emplace_back(work, p);
    work(0);
    for (auto& th : pool) th.join();
  }
  return chunks;
}

void DelaunayKernel3D::validate() const {
  const std::size_t nt = tet_v_.size() / 4;
  auto fail = [](index_t t, const std::string& what) {
    throw Error("dw::DelaunayKernel3D::validate: tetrahedron " + std::to_string(t) + ": " + what);
  };
  std::vector<char> present(num_points_, 0);
  std::size_t live = 0;
  for (index_t t = 0; t < nt; ++t) {
    const index_t* tv = &tet_v_[4 * std::size_t(t)];
    if (tv[0] == kDead) continue;
    ++live;
    unsigned inf = 4, count_inf = 0;
    for (unsigned k = 0; k < 4; ++k) {
      if (tv[k] == kInfinite) {
        inf = k;
        ++count_inf;
      } else if (tv[k] >= num_points_) {
        fail(t, "vertex id out of range");
      } else {
        present[tv[k]] = 1;
      }
    }
    if (count_inf > 1) fail(t, "more than one infinite vertex");
    for (unsigned f = 0; f < 4; ++f) {
      const std::uint32_t nc = tet_n_[4 * std::size_t(t) + f];
      const index_t n = nc >> 2;
      if (n >= nt || tet_v_[4 * std::size_t(n)] == kDead) fail(t, "neighbour is not a live tetrahedron");
      if (tet_n_[nc] != 4 * t + f) fail(t, "adjacency is not symmetric");
      std::array<index_t, 3> a{}, b{};
      unsigned ia = 0, ib = 0;
      for (unsigned k = 0; k < 4; ++k) {
        if (k != f) a[ia++] = tv[k];
        if (k != (nc & 3u)) b[ib++] = tet_v_[4 * std::size_t(n) + k];
      }
      std::sort(a.begin(), a.end());
      std::sort(b.begin(), b.end());
      if (a != b) fail(t, "neighbours do not share the face");
      const index_t opposite = tet_v_[nc];
      if (opposite == kInfinite) continue;
      // Local Delaunay (finite t) or local convexity of the hull (infinite t), same perturbation.
      double po[3];
      point(opposite, po);
      if (inConflict(t, opposite, po)) fail(t, "face " + std::to_string(f) + " is not locally Delaunay");
    }
    double q[4][3];
    if (inf == 4) {
      for (unsigned k = 0; k < 4; ++k) point(tv[k], q[k]);
      if (predicates::orient3d(q[0], q[1], q[2], q[3]) <= 0.0) fail(t, "not positively oriented");
    } else {
      const std::uint32_t nc = tet_n_[4 * std::size_t(t) + inf];
      const index_t inner = tet_v_[nc];
      if (inner == kInfinite) fail(t, "hull facet backed by an infinite tetrahedron");
      for (unsigned k = 0; k < 4; ++k) point(k == inf ? inner : tv[k], q[k]);
      if (predicates::orient3d(q[0], q[1], q[2], q[3]) >= 0.0) fail(t, "hull facet faces inwards");
    }
  }
  std::size_t missing = 0;
  for (char c : present) missing += c == 0;
  if (num_points_ - missing != num_inserted_)
    throw Error("dw::DelaunayKernel3D::validate: " + std::to_string(num_points_ - missing) +
                " vertices in tetrahedra, " + std::to_string(num_inserted_) + " inserted");
  if (live != numLiveTetrahedra()) throw Error("dw::DelaunayKernel3D::validate: free list out of sync");
}

std::size_t DelaunayKernel3D::memoryBytes() const {
  return (tet_v_.capacity() + tet_n_.capacity() + birth_.capacity()) * sizeof(std::uint32_t) +
         mark_.capacity() + free_.capacity() * sizeof(index_t) + link_key_.capacity() * 8 +
         link_val_.capacity() * 4 + link_gen_.capacity() * 4 +
         (cavity_.capacity() + stack_.capacity() + outside_.capacity()) * 4 +
         boundary_.capacity() * sizeof(BoundaryFace);
}

}  // namespace builder3d
}  // namespace dw
