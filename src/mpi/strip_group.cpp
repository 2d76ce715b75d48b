/// \file strip_group.cpp
/// \brief Leaf and merge steps of the distributed TIN (see strip_group.h and docs/mpi.md for the proof).
#include "pcl_delaunay_walk/mpi/strip_group.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

namespace dw {
namespace mpi {
namespace {

constexpr index_t kNoTriangle = ~index_t{0};
constexpr double kEps = 1.1102230246251565e-16;  // 2^-53

std::uint64_t edgeKey(index_t a, index_t b) {
  return (std::uint64_t{a} << 32) | b;
}

/// True when the closed circumdisk of (a, b, c) provably lies inside lo < u < hi. The circumcentre is
/// computed relative to a; the margin bounds the rounding of every step with a constant several times
/// the textbook one, and ill-conditioned (nearly collinear) triangles are simply not sure: a wrong
/// "unsure" only costs merge time, a wrong "sure" would break exactness.
bool sureInStrip(double ax, double ay, double bx_, double by_, double cx_, double cy_, int axis, double lo,
                 double hi) {
  if (std::isinf(lo) && lo < 0 && std::isinf(hi) && hi > 0) return true;
  const double bx = bx_ - ax, by = by_ - ay, cx = cx_ - ax, cy = cy_ - ay;
  const double B = bx * bx + by * by, C = cx * cx + cy * cy;
  const double d = 2.0 * (bx * cy - by * cx);
  const double dmag = 2.0 * (std::fabs(bx * cy) + std::fabs(by * cx));
  if (!(std::fabs(d) > 1e-6 * dmag)) return false;
  const double nx = cy * B - by * C, nxmag = std::fabs(cy) * B + std::fabs(by) * C;
  const double ny = bx * C - cx * B, nymag = std::fabs(bx) * C + std::fabs(cx) * B;
  const double ux = nx / d, uy = ny / d;
  const double ex = 32.0 * kEps * (nxmag + std::fabs(ux) * dmag) / std::fabs(d);
  const double ey = 32.0 * kEps * (nymag + std::fabs(uy) * dmag) / std::fabs(d);
  const double r = std::sqrt(ux * ux + uy * uy);
  const double centre = (axis == 0 ? ax + ux : ay + uy);
  const double err = ex + ey + 8.0 * kEps * (std::fabs(centre) + r + std::fabs(axis == 0 ? ax : ay));
  if (!std::isfinite(centre) || !std::isfinite(r) || !std::isfinite(err)) return false;
  return centre - r - err > lo && centre + r + err < hi;
}

/// Directed edges of a triangle soup grouped by origin (CSR): each row holds (head, triangle).
class EdgeTable {
 public:
  EdgeTable(const std::vector<index_t>& tri, std::size_t num_vertices) : offset_(num_vertices + 1, 0) {
    const std::size_t nt = tri.size() / 3;
    for (index_t v : tri) ++offset_[v + 1];
    for (std::size_t i = 0; i < num_vertices; ++i) offset_[i + 1] += offset_[i];
    head_.resize(tri.size());
    triangle_.resize(tri.size());
    std::vector<std::size_t> fill(offset_.begin(), offset_.end() - 1);
    for (std::size_t t = 0; t < nt; ++t)
      for (int k = 0; k < 3; ++k) {
        const std::size_t at = fill[tri[3 * t + k]]++;
        head_[at] = tri[3 * t + (k + 1) % 3];
        triangle_[at] = static_cast<index_t>(t);
      }
  }
  /// The triangle left of the directed edge a -> b, or kNoTriangle.
  index_t find(index_t a, index_t b) const {
    for (std::size_t i = offset_[a]; i < offset_[a + 1]; ++i)
      if (head_[i] == b) return triangle_[i];
    return kNoTriangle;
  }

 private:
  std::vector<std::size_t> offset_;
  std::vector<index_t> head_, triangle_;
};

index_t localIndex(const StripPoints& v, index_t gid) {
  const auto it = std::lower_bound(v.gid.begin(), v.gid.end(), gid);
  if (it == v.gid.end() || *it != gid)
    throw Error("dw::mpi: internal inconsistency: fence vertex " + std::to_string(gid) +
                " is not among the band points");
  return static_cast<index_t>(it - v.gid.begin());
}

void checkSorted(const StripPoints& v, const char* who) {
  if (v.x.size() != v.size() || v.y.size() != v.size() || v.z.size() != v.size())
    throw Error(std::string(who) + ": point arrays have different lengths");
  for (std::size_t i = 1; i < v.size(); ++i)
    if (!(v.gid[i - 1] < v.gid[i]))
      throw Error(std::string(who) + ": global indices must be strictly increasing (at " +
                  std::to_string(v.gid[i]) + ")");
}

/// The step shared by leaves and merges: DT(V), minus what the fences say is already emitted, split
/// into the emitted (sure in [lo, hi)) and the rest, whose vertices and hull go up as the new band.
StripGroup processStrip(StripPoints&& v, const std::vector<std::uint64_t>& gid_fences, int axis, double lo,
                        double hi, Emitted& out, const StripOptions& options) {
  const std::size_t n = v.size();
  tin::TinOptions topt;
  topt.num_threads = std::max(1u, options.num_threads);
  // Local indices follow the gid order, so the perturbation ranks agree with the global run.
  tin::TinResult dt = tin::triangulate(v.x.data(), v.y.data(), n, topt);
  if (!dt.skipped.empty()) throw Error("dw::mpi: non-finite point reached the triangulation");
  out.band_points += n;
  std::vector<char> is_duplicate(n, 0);
  for (const auto& d : dt.duplicates) {
    is_duplicate[d.first] = 1;
    out.duplicates.emplace_back(v.gid[d.first], v.gid[d.second]);
  }
  const std::vector<index_t>& tri = dt.triangles;
  const std::size_t nt = tri.size() / 3;
  if (nt == 0 && !gid_fences.empty())
    throw Error("dw::mpi: internal inconsistency: fences left but the band has no triangle");
  const EdgeTable edges(tri, n);
  // across[3t + k]: the triangle right of t's edge k (corner k to k + 1), found once for all passes.
  std::vector<index_t> across(tri.size());
  for (std::size_t c = 0; c < tri.size(); ++c) across[c] = edges.find(tri[c - c % 3 + (c + 1) % 3], tri[c]);

  std::vector<std::uint64_t> fences;  // local keys, sorted
  fences.reserve(gid_fences.size());
  for (std::uint64_t f : gid_fences)
    fences.push_back(edgeKey(localIndex(v, index_t(f >> 32)), localIndex(v, index_t(f & 0xffffffffu))));
  std::sort(fences.begin(), fences.end());
  auto isFence = [&](index_t a, index_t b) {
    return std::binary_search(fences.begin(), fences.end(), edgeKey(a, b));
  };

  // Flood the already emitted region from the left of every fence without crossing one.
  enum : char { kAlive = 0, kDead = 1, kSure = 2 };
  std::vector<char> state(nt, kAlive);
  std::vector<index_t> stack;
  for (std::uint64_t f : fences) {
    const index_t t = edges.find(index_t(f >> 32), index_t(f & 0xffffffffu));
    if (t == kNoTriangle)
      throw Error("dw::mpi: internal inconsistency: a fence edge is not an edge of the band triangulation");
    if (state[t] == kDead) continue;
    state[t] = kDead;
    stack.push_back(t);
    while (!stack.empty()) {
      const index_t s = stack.back();
      stack.pop_back();
      for (int k = 0; k < 3; ++k) {
        const index_t a = tri[3 * s + k], b = tri[3 * s + (k + 1) % 3];
        if (isFence(a, b)) continue;
        const index_t u = across[3 * s + k];
        if (u != kNoTriangle && state[u] != kDead) {
          state[u] = kDead;
          stack.push_back(u);
        }
      }
    }
  }

  // Emit what is sure in the strip.
  out.triangles.reserve(out.triangles.size() + tri.size());
  for (std::size_t t = 0; t < nt; ++t) {
    if (state[t] == kDead) continue;
    const index_t a = tri[3 * t], b = tri[3 * t + 1], c = tri[3 * t + 2];
    if (sureInStrip(v.x[a], v.y[a], v.x[b], v.y[b], v.x[c], v.y[c], axis, lo, hi)) {
      state[t] = kSure;
      out.triangles.insert(out.triangles.end(), {v.gid[a], v.gid[b], v.gid[c]});
    }
  }

  // New fences: old ones whose right side is still open, and emitted-to-open edges.
  StripGroup g;
  g.axis = axis;
  g.lo = lo;
  g.hi = hi;
  // Open: no triangle (outside the hull) or one not emitted yet.
  auto rightIsOpen = [&](index_t a, index_t b) {
    const index_t u = edges.find(b, a);
    return u == kNoTriangle || state[u] == kAlive;
  };
  for (std::uint64_t f : fences) {
    const index_t a = index_t(f >> 32), b = index_t(f & 0xffffffffu);
    const index_t u = edges.find(b, a);
    // The right side of an old fence was open before this step, so the flood cannot have reached it.
    if (u != kNoTriangle && state[u] == kDead)
      throw Error("dw::mpi: internal inconsistency: the flood crossed a fence");
    if (rightIsOpen(a, b)) g.fences.push_back(edgeKey(v.gid[a], v.gid[b]));
  }
  std::vector<char> in_band(n, 0);
  for (std::size_t t = 0; t < nt; ++t) {
    for (int k = 0; k < 3; ++k) {
      const index_t a = tri[3 * t + k], b = tri[3 * t + (k + 1) % 3];
      const index_t u = across[3 * t + k];
      if (u == kNoTriangle) in_band[a] = in_band[b] = 1;  // hull vertices always go up (docs/mpi.md, lemma 2)
      if (state[t] == kAlive) in_band[a] = 1;
      if (state[t] == kSure && (u == kNoTriangle || state[u] == kAlive))
        g.fences.push_back(edgeKey(v.gid[a], v.gid[b]));
    }
  }
  if (nt == 0)
    for (std::size_t i = 0; i < n; ++i) in_band[i] = !is_duplicate[i];
  std::sort(g.fences.begin(), g.fences.end());
  g.fences.erase(std::unique(g.fences.begin(), g.fences.end()), g.fences.end());

  std::size_t keep = 0;
  for (std::size_t i = 0; i < n; ++i) keep += in_band[i] != 0;
  g.band.reserve(keep);
  for (std::size_t i = 0; i < n; ++i)
    if (in_band[i]) g.band.push(v.gid[i], v.x[i], v.y[i], v.z[i]);
  return g;
}

}  // namespace

void StripPoints::reserve(std::size_t n) {
  gid.reserve(n);
  x.reserve(n);
  y.reserve(n);
  z.reserve(n);
}

void StripPoints::push(index_t g, double px, double py, double pz) {
  gid.push_back(g);
  x.push_back(px);
  y.push_back(py);
  z.push_back(pz);
}

StripGroup processLeaf(StripPoints&& points, int axis, double lo, double hi, Emitted& out,
                       const StripOptions& options) {
  if (axis != 0 && axis != 1) throw Error("dw::mpi::processLeaf: axis must be 0 or 1");
  if (!(lo < hi)) throw Error("dw::mpi::processLeaf: empty strip [lo, hi)");
  checkSorted(points, "dw::mpi::processLeaf");
  const std::vector<double>& u = axis == 0 ? points.x : points.y;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!std::isfinite(points.x[i]) || !std::isfinite(points.y[i]))
      throw Error("dw::mpi::processLeaf: point " + std::to_string(points.gid[i]) + " is not finite");
    if (!(u[i] >= lo && u[i] < hi))
      throw Error("dw::mpi::processLeaf: point " + std::to_string(points.gid[i]) + " lies outside its strip");
  }
  return processStrip(std::move(points), {}, axis, lo, hi, out, options);
}

StripGroup mergeStrips(StripGroup&& left, StripGroup&& right, Emitted& out, const StripOptions& options) {
  if (left.axis != right.axis) throw Error("dw::mpi::mergeStrips: the groups use different axes");
  if (!(left.hi == right.lo))
    throw Error("dw::mpi::mergeStrips: the strips are not adjacent (left ends at " + std::to_string(left.hi) +
                ", right starts at " + std::to_string(right.lo) + ")");
  checkSorted(left.band, "dw::mpi::mergeStrips");
  checkSorted(right.band, "dw::mpi::mergeStrips");
  StripPoints v;
  v.reserve(left.band.size() + right.band.size());
  std::size_t i = 0, j = 0;
  const StripPoints &a = left.band, &b = right.band;
  while (i < a.size() || j < b.size()) {
    const bool take_a = j == b.size() || (i < a.size() && a.gid[i] < b.gid[j]);
    if (i < a.size() && j < b.size() && a.gid[i] == b.gid[j])
      throw Error("dw::mpi::mergeStrips: point " + std::to_string(a.gid[i]) + " is in both groups");
    const StripPoints& s = take_a ? a : b;
    std::size_t& k = take_a ? i : j;
    v.push(s.gid[k], s.x[k], s.y[k], s.z[k]);
    ++k;
  }
  std::vector<std::uint64_t> fences = std::move(left.fences);
  fences.insert(fences.end(), right.fences.begin(), right.fences.end());
  const double lo = left.lo, hi = right.hi;
  const int axis = left.axis;
  left = StripGroup();
  right = StripGroup();
  return processStrip(std::move(v), fences, axis, lo, hi, out, options);
}

// Layout: magic, axis, lo, hi, n, nf, gid[n], x[n], y[n], z[n], fences[nf].
namespace {
constexpr std::uint32_t kMagic = 0x44574d31;  // "DWM1"
template <typename T>
void put(std::vector<unsigned char>& b, const T* p, std::size_t count) {
  const std::size_t at = b.size();
  b.resize(at + sizeof(T) * count);
  if (count) std::memcpy(b.data() + at, p, sizeof(T) * count);
}
}  // namespace

std::vector<unsigned char> StripGroup::serialize() const {
  std::vector<unsigned char> b;
  const std::uint64_t n = band.size(), nf = fences.size();
  b.reserve(48 + n * 28 + nf * 8);
  const std::int32_t ax = axis;
  put(b, &kMagic, 1);
  put(b, &ax, 1);
  put(b, &lo, 1);
  put(b, &hi, 1);
  put(b, &n, 1);
  put(b, &nf, 1);
  put(b, band.gid.data(), n);
  put(b, band.x.data(), n);
  put(b, band.y.data(), n);
  put(b, band.z.data(), n);
  put(b, fences.data(), nf);
  return b;
}

StripGroup StripGroup::deserialize(const unsigned char* bytes, std::size_t size) {
  std::size_t at = 0;
  auto get = [&](void* p, std::size_t n) {
    if (n > size - at) throw Error("dw::mpi: truncated strip group message");
    if (n) std::memcpy(p, bytes + at, n);
    at += n;
  };
  std::uint32_t magic = 0;
  std::int32_t ax = 0;
  std::uint64_t n = 0, nf = 0;
  StripGroup g;
  get(&magic, 4);
  if (magic != kMagic) throw Error("dw::mpi: corrupt strip group message");
  get(&ax, 4);
  get(&g.lo, 8);
  get(&g.hi, 8);
  get(&n, 8);
  get(&nf, 8);
  if (n > size / 28 || nf > size / 8 || 28 * n + 8 * nf != size - at)
    throw Error("dw::mpi: strip group message has an inconsistent size");
  g.axis = ax;
  g.band.gid.resize(n);
  g.band.x.resize(n);
  g.band.y.resize(n);
  g.band.z.resize(n);
  g.fences.resize(nf);
  get(g.band.gid.data(), 4 * n);
  get(g.band.x.data(), 8 * n);
  get(g.band.y.data(), 8 * n);
  get(g.band.z.data(), 8 * n);
  get(g.fences.data(), 8 * nf);
  return g;
}

}  // namespace mpi
}  // namespace dw
