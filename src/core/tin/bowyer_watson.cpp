/// \file bowyer_watson.cpp
/// \brief Sequential Bowyer-Watson kernel and the Hilbert sort that feeds it.
#include "bowyer_watson.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "core/util/space_filling_curve.h"

namespace dw {
namespace tin {
namespace detail {

namespace {

[[noreturn]] void internalError(const std::string& what) {
  throw Error("dw::tin: internal consistency failure (" + what + "); please report this input");
}

}  // namespace

BowyerWatson::BowyerWatson(const PointSet& points, TriangleArena arena, index_t base, index_t capacity)
    : ps_(points), tv_(arena.tv), tn_(arena.tn), base_(base), cap_(capacity), next_(base) {
  stack_.reserve(64);
  cavity_.reserve(64);
  boundary_.reserve(64);
}

index_t BowyerWatson::alloc() {
  if (next_ - base_ >= cap_) internalError("strip slot range exhausted");
  return next_++;
}

index_t BowyerWatson::anyGhost() const {
  for (index_t t = next_; t-- > base_;)
    if (isGhost(tv_, t)) return t;
  internalError("no ghost triangle");
}

void BowyerWatson::makeFirstTriangle(index_t a, index_t b, index_t c) {
  if (pred::orient2d(ps_.x(a), ps_.y(a), ps_.x(b), ps_.y(b), ps_.x(c), ps_.y(c)) < 0) std::swap(b, c);
  const index_t t = alloc();
  const index_t g[3] = {alloc(), alloc(), alloc()};
  const index_t v[3] = {a, b, c};
  for (index_t i = 0; i < 3; ++i) tv_[3 * t + i] = v[i];
  for (index_t i = 0; i < 3; ++i) {
    // Ghost g_i = (v_{i+2}, v_{i+1}, inf) lies across T's edge opposite v_i; its edge (v_{i+1}, inf)
    // meets ghost g_{i+2}'s edge (inf, v_{(i+2)+2}) = (inf, v_{i+1}).
    const index_t gi = g[i];
    tv_[3 * gi + 0] = v[prev3(i)];
    tv_[3 * gi + 1] = v[next3(i)];
    tv_[3 * gi + 2] = kGhost;
    tn_[3 * t + i] = 3 * gi + 2;
    tn_[3 * gi + 2] = 3 * t + i;
    const index_t gj = g[prev3(i)];
    tn_[3 * gi + 0] = 3 * gj + 1;
    tn_[3 * gj + 1] = 3 * gi + 0;
  }
  last_ = t;
  has_triangles_ = true;
}

index_t BowyerWatson::locate(index_t p, index_t* dup) {
  const double px = ps_.x(p), py = ps_.y(p);
  index_t t = last_;
  if (isGhost(tv_, t)) {
    for (index_t i = 0; i < 3; ++i)
      if (tv_[3 * t + i] == kGhost) {
        t = tn_[3 * t + i] / 3;
        break;
      }
  }
  // Corners reach 3.6e9 at the 600M-point limit, so "none" must be a value no corner takes (not kDead).
  index_t came = ~index_t{0};
  // The visibility walk terminates in any (perturbed) Delaunay triangulation: the "in front of"
  // relation seen from p is acyclic (Edelsbrunner 1990). The step limit only guards against a bug.
  const std::size_t limit = 4 * static_cast<std::size_t>(next_ - base_) + 16;
  for (std::size_t step = 0; step < limit; ++step) {
    const index_t* v = tv_ + 3 * t;
    bool moved = false;
    for (index_t i = 0; i < 3; ++i) {
      const index_t corner = 3 * t + i;
      if (corner == came) continue;
      const index_t a = v[next3(i)], b = v[prev3(i)];
      if (pred::orient2d(ps_.x(a), ps_.y(a), ps_.x(b), ps_.y(b), px, py) < 0) {
        const index_t nc = tn_[corner];
        const index_t n = nc / 3;
        if (isGhost(tv_, n)) return n;  // strictly outside a hull edge: that ghost is in conflict
        came = nc;
        t = n;
        moved = true;
        break;
      }
    }
    if (!moved) {
      for (index_t i = 0; i < 3; ++i)
        if (ps_.x(v[i]) == px && ps_.y(v[i]) == py) {
          *dup = v[i];
          return t;
        }
      return t;
    }
  }
  internalError("point location did not terminate");
}

void BowyerWatson::insert(index_t p) {
  index_t dup = kDead;
  const index_t t0 = locate(p, &dup);
  if (dup != kDead) {
    dups_.emplace_back(p, dup);
    return;
  }
  ++num_vertices_;
  cavity_.clear();
  boundary_.clear();
  stack_.clear();
  tv_[3 * t0] |= kMark;
  stack_.push_back(t0);
  cavity_.push_back(t0);
  while (!stack_.empty()) {
    const index_t c = stack_.back();
    stack_.pop_back();
    for (index_t i = 0; i < 3; ++i) {
      const index_t nc = tn_[3 * c + i];
      const index_t n = nc / 3;
      if (tv_[3 * n] & kMark) continue;
      if (inConflict(ps_, tv_, n, p)) {
        tv_[3 * n] |= kMark;
        stack_.push_back(n);
        cavity_.push_back(n);
      } else {
        boundary_.push_back({tv_[3 * c + next3(i)] & ~kMark, tv_[3 * c + prev3(i)] & ~kMark, nc});
      }
    }
  }
  // The cavity is a topological disc (or, with ghosts, its boundary is one cycle), so its boundary
  // has exactly two more edges than it has triangles: the fan re-uses every cavity slot plus two.
  const std::size_t m = boundary_.size();
  if (m != cavity_.size() + 2) internalError("cavity is not a disc");
  by_u_.clear();
  index_t first_real = kDead;
  for (std::size_t j = 0; j < m; ++j) {
    const BoundaryEdge& e = boundary_[j];
    const index_t s = j < cavity_.size() ? cavity_[j] : alloc();
    tv_[3 * s + 0] = p;
    tv_[3 * s + 1] = e.u;
    tv_[3 * s + 2] = e.v;
    tn_[3 * s + 0] = e.outside;
    tn_[e.outside] = 3 * s + 0;
    by_u_.emplace_back(e.u, s);
    if (first_real == kDead && e.u != kGhost && e.v != kGhost) first_real = s;
  }
  // Link the fan: triangle (p, u, v)'s edge (v, p) meets the triangle whose u equals this v.
  const bool sorted = m > 12;
  if (sorted) std::sort(by_u_.begin(), by_u_.end());
  for (std::size_t j = 0; j < m; ++j) {
    const index_t s = by_u_[j].second;
    const index_t v = tv_[3 * s + 2];
    index_t k = kDead;
    if (sorted) {
      const auto it = std::lower_bound(by_u_.begin(), by_u_.end(), std::make_pair(v, index_t{0}));
      if (it != by_u_.end() && it->first == v) k = it->second;
    } else {
      for (const auto& q : by_u_)
        if (q.first == v) {
          k = q.second;
          break;
        }
    }
    if (k == kDead) internalError("cavity boundary is not a cycle");
    tn_[3 * s + 1] = 3 * k + 2;
    tn_[3 * k + 2] = 3 * s + 1;
  }
  last_ = first_real != kDead ? first_real : by_u_[0].second;
}

void BowyerWatson::run(const index_t* order, std::size_t m) {
  if (m == 0) return;
  const index_t a = order[0];
  num_vertices_ = 1;
  std::size_t j = 1;
  while (j < m && ps_.x(order[j]) == ps_.x(a) && ps_.y(order[j]) == ps_.y(a))
    dups_.emplace_back(order[j++], a);
  if (j == m) {
    collinear_.push_back(a);
    return;
  }
  const index_t b = order[j];
  std::vector<index_t> pending;
  std::size_t k = j + 1;
  for (; k < m; ++k) {
    const index_t c = order[k];
    if (pred::orient2d(ps_.x(a), ps_.y(a), ps_.x(b), ps_.y(b), ps_.x(c), ps_.y(c)) != 0) break;
    pending.push_back(c);
  }
  if (k == m) {
    // Every distinct point is collinear: no triangle. Collapse duplicates onto their first copy.
    std::vector<std::pair<std::size_t, index_t>> line;  // (order index, position)
    line.emplace_back(0, a);
    line.emplace_back(j, b);
    for (std::size_t q = j + 1; q < m; ++q) line.emplace_back(q, order[q]);
    std::sort(line.begin(), line.end(), [&](const auto& l, const auto& r) {
      if (ps_.x(l.second) != ps_.x(r.second)) return ps_.x(l.second) < ps_.x(r.second);
      if (ps_.y(l.second) != ps_.y(r.second)) return ps_.y(l.second) < ps_.y(r.second);
      return l.first < r.first;
    });
    for (std::size_t q = 0; q < line.size(); ++q) {
      const index_t v = line[q].second;
      if (q > 0 && ps_.x(v) == ps_.x(collinear_.back()) && ps_.y(v) == ps_.y(collinear_.back()))
        dups_.emplace_back(v, collinear_.back());
      else
        collinear_.push_back(v);
    }
    num_vertices_ = collinear_.size();
    return;
  }
  makeFirstTriangle(a, b, order[k]);
  num_vertices_ = 3;
  for (const index_t c : pending) insert(c);
  for (std::size_t q = k + 1; q < m; ++q) insert(order[q]);
}

namespace {

/// A well-mixed 64-bit hash of a point's coordinates (splitmix64 finaliser): equal points get equal
/// hashes, so copies of one point land in the same BRIO round and keep their input order.
std::uint64_t coordinateHash(double x, double y) {
  std::uint64_t a, b;
  std::memcpy(&a, &x, 8);
  std::memcpy(&b, &y, 8);
  std::uint64_t z = a ^ (b * 0x9E3779B97F4A7C15ull) ^ (b >> 29);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

}  // namespace

void brioHilbertSort(const double* xy, std::vector<index_t>& positions) {
  const std::size_t n = positions.size();
  if (n < 2) return;
  auto X = [&](index_t p) { return xy[2 * std::size_t(p)]; };
  auto Y = [&](index_t p) { return xy[2 * std::size_t(p) + 1]; };
  double x0 = X(positions[0]), x1 = x0, y0 = Y(positions[0]), y1 = y0;
  for (const index_t p : positions) {
    x0 = std::min(x0, X(p));
    x1 = std::max(x1, X(p));
    y0 = std::min(y0, Y(p));
    y1 = std::max(y1, Y(p));
  }
  // One scale for both axes keeps the curve's cells square on elongated strips.
  const double ext = std::max(x1 - x0, y1 - y0);
  const double inv = ext > 0 ? 1.0 / ext : 0.0;
  // Biased randomised insertion order (Amenta, Choi, Rote 2003): round r holds about n / 2^(R-r) points
  // (the last round half of them), each round in Hilbert order. Pure curve order leaves long thin
  // triangles along the front of the inserted region, which makes cavities ~50% larger.
  int rounds = 1;
  while (rounds < 20 && (n >> rounds) > 1024) ++rounds;
  std::vector<std::uint64_t> a(n), b(n);
  for (std::size_t i = 0; i < n; ++i) {
    const index_t p = positions[i];
    const std::uint64_t h = coordinateHash(X(p), Y(p));
    int tz = 0;
    while (tz < rounds - 1 && !((h >> tz) & 1u)) ++tz;
    const std::uint64_t round = std::uint64_t(rounds - 1 - tz);
    // 13 bits per axis: with 5 bits of round the key fills the upper 32 bits; the lower 32 hold p.
    const std::uint64_t hk = dw::hilbertKey(X(p), Y(p), x0, y0, inv, inv) >> 6;
    a[i] = (((round << 26) | hk) << 32) | p;
  }
  // LSD radix sort on the upper 32 bits, 8 bits per pass: stable, so equal keys keep input order.
  for (int shift = 32; shift < 64; shift += 8) {
    std::size_t count[257] = {0};
    for (std::size_t i = 0; i < n; ++i) ++count[((a[i] >> shift) & 0xFF) + 1];
    if (count[1] == n) continue;  // all digits zero: nothing to move
    for (int d = 0; d < 256; ++d) count[d + 1] += count[d];
    for (std::size_t i = 0; i < n; ++i) b[count[(a[i] >> shift) & 0xFF]++] = a[i];
    a.swap(b);
  }
  for (std::size_t i = 0; i < n; ++i) positions[i] = static_cast<index_t>(a[i] & 0xFFFFFFFFu);
}

}  // namespace detail
}  // namespace tin
}  // namespace dw
