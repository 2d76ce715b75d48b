/// \file predicates_2d.cpp
/// \brief Exact stages of orient2d/incircle in expansion arithmetic, and the perturbed incircle.
#include "pcl_delaunay_walk/core/geometry/predicates_2d.h"

#include <atomic>
#include <cstddef>

#include "pcl_delaunay_walk/core/geometry/exact_arithmetic.h"

namespace dw {
namespace pred {
namespace {

std::atomic<std::uint64_t> g_orient_exact{0};
std::atomic<std::uint64_t> g_incircle_exact{0};
std::atomic<std::uint64_t> g_ties{0};

/// a - b as an expansion of at most two components (the difference of two doubles is exactly
/// representable as a rounded value plus its error).
std::size_t diff(double a, double b, double* out) {
  double s, e;
  exact::twoDiff(a, b, s, e);
  std::size_t n = 0;
  if (e != 0.0) out[n++] = e;
  out[n++] = s;
  return n;
}

/// h = e * f for expansions of at most 16 components each (h needs 2 * elen * flen).
std::size_t mul(std::size_t elen, const double* e, std::size_t flen, const double* f, double* h) {
  double tmp[64];
  double acc[1024];
  return exact::product(elen, e, flen, f, h, tmp, acc);
}

void negate(std::size_t n, double* e) {
  for (std::size_t i = 0; i < n; ++i) e[i] = -e[i];
}

/// u * v' - u' * v for two-component differences (the 2x2 minors of both predicates), <= 16 terms.
std::size_t cross(const double* u, std::size_t ul, const double* vp, std::size_t vpl, const double* up,
                  std::size_t upl, const double* v, std::size_t vl, double* out) {
  double p[8], q[8];
  const std::size_t pl = mul(ul, u, vpl, vp, p);
  std::size_t ql = mul(upl, up, vl, v, q);
  negate(ql, q);
  return exact::sum(pl, p, ql, q, out);
}

}  // namespace

int orient2dExact(double ax, double ay, double bx, double by, double cx, double cy) {
  g_orient_exact.fetch_add(1, std::memory_order_relaxed);
  double acx[2], acy[2], bcx[2], bcy[2], det[16];
  const std::size_t l1 = diff(ax, cx, acx), l2 = diff(ay, cy, acy);
  const std::size_t l3 = diff(bx, cx, bcx), l4 = diff(by, cy, bcy);
  const std::size_t n = cross(acx, l1, bcy, l4, acy, l2, bcx, l3, det);
  return exact::sign(n, det);
}

int incircleExact(double ax, double ay, double bx, double by, double cx, double cy, double dx, double dy) {
  g_incircle_exact.fetch_add(1, std::memory_order_relaxed);
  double adx[2], ady[2], bdx[2], bdy[2], cdx[2], cdy[2];
  const std::size_t la = diff(ax, dx, adx), lay = diff(ay, dy, ady);
  const std::size_t lb = diff(bx, dx, bdx), lby = diff(by, dy, bdy);
  const std::size_t lc = diff(cx, dx, cdx), lcy = diff(cy, dy, cdy);

  // Minors bc = bdx*cdy - cdx*bdy, ca = cdx*ady - adx*cdy, ab = adx*bdy - bdx*ady (<= 16 terms each).
  double bc[16], ca[16], ab[16];
  const std::size_t lbc = cross(bdx, lb, cdy, lcy, cdx, lc, bdy, lby, bc);
  const std::size_t lca = cross(cdx, lc, ady, lay, adx, la, cdy, lcy, ca);
  const std::size_t lab = cross(adx, la, bdy, lby, bdx, lb, ady, lay, ab);

  // Lifts |p - d|^2 (<= 16 terms each).
  auto lift = [](const double* u, std::size_t ul, const double* v, std::size_t vl, double* out) {
    double uu[8], vv[8];
    const std::size_t l1 = mul(ul, u, ul, u, uu);
    const std::size_t l2 = mul(vl, v, vl, v, vv);
    return exact::sum(l1, uu, l2, vv, out);
  };
  double al[16], bl[16], cl[16];
  const std::size_t lal = lift(adx, la, ady, lay, al);
  const std::size_t lbl = lift(bdx, lb, bdy, lby, bl);
  const std::size_t lcl = lift(cdx, lc, cdy, lcy, cl);

  static thread_local double ta[512], tb[512], tc[512], tab[1024], det[1536];
  const std::size_t na = mul(lal, al, lbc, bc, ta);
  const std::size_t nb = mul(lbl, bl, lca, ca, tb);
  const std::size_t nc = mul(lcl, cl, lab, ab, tc);
  const std::size_t nab = exact::sum(na, ta, nb, tb, tab);
  const std::size_t n = exact::sum(nab, tab, nc, tc, det);
  return exact::sign(n, det);
}

int incirclePerturbed(const double* a, std::uint32_t ra, const double* b, std::uint32_t rb, const double* c,
                      std::uint32_t rc, const double* d, std::uint32_t rd) {
  const int s = incircle(a[0], a[1], b[0], b[1], c[0], c[1], d[0], d[1]);
  if (s != 0) return s;
  g_ties.fetch_add(1, std::memory_order_relaxed);
  // The perturbed determinant is det + sum_i eps_i * dDet/dz_i; the cofactor of point i's lift is
  // +-orient2d of the other three: a: +o(b,c,d), b: -o(a,c,d), c: +o(a,b,d), d: -o(a,b,c).
  // The point with the largest rank has the dominant eps; the first non-zero cofactor decides.
  struct Term {
    std::uint32_t rank;
    int which;
  } t[4] = {{ra, 0}, {rb, 1}, {rc, 2}, {rd, 3}};
  for (int i = 1; i < 4; ++i)  // four elements: insertion sort by descending rank
    for (int j = i; j > 0 && t[j].rank > t[j - 1].rank; --j) {
      const Term tmp = t[j];
      t[j] = t[j - 1];
      t[j - 1] = tmp;
    }
  for (const Term& term : t) {
    int o = 0;
    switch (term.which) {
      case 0: o = orient2d(b[0], b[1], c[0], c[1], d[0], d[1]); break;
      case 1: o = -orient2d(a[0], a[1], c[0], c[1], d[0], d[1]); break;
      case 2: o = orient2d(a[0], a[1], b[0], b[1], d[0], d[1]); break;
      default: o = -orient2d(a[0], a[1], b[0], b[1], c[0], c[1]); break;
    }
    if (o != 0) return o;
  }
  return 0;
}

PredicateStats predicateStats() {
  PredicateStats s;
  s.orient_exact = g_orient_exact.load(std::memory_order_relaxed);
  s.incircle_exact = g_incircle_exact.load(std::memory_order_relaxed);
  s.perturbed_ties = g_ties.load(std::memory_order_relaxed);
  return s;
}

void resetPredicateStats() {
  g_orient_exact.store(0);
  g_incircle_exact.store(0);
  g_ties.store(0);
}

}  // namespace pred
}  // namespace dw
