// Exact fallbacks of the 3D predicates and insphere under simulation of simplicity.
//
// The exact path evaluates the same determinants as the filters, but on expansions: every coordinate
// difference is an exact two-component expansion (twoDiff), and products/sums are expansion products/
// sums, so the final sign is exact. Degenerate inputs (grids, quantised LiDAR, cospherical sets) land
// here often, so scratch memory comes from a per-thread arena instead of the heap, and expansion
// lengths shrink with zero elimination (exact differences, as on grids, stay one component long).
#include "pcl_delaunay_walk/core/geometry/predicates_3d.h"

#include <algorithm>
#include <cstddef>
#include <memory>

#include "pcl_delaunay_walk/core/geometry/exact_arithmetic.h"
#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace predicates {
namespace {

/// An expansion: `len` non-overlapping components, least significant first, living in the arena.
struct Expansion {
  double* v = nullptr;
  std::size_t len = 0;
};

/// Bump allocator over one per-thread buffer; reset at the start of every exact evaluation. The
/// worst case (insphere with two-component differences everywhere) needs about 170k doubles, a typical
/// call a few hundred. The buffer is left uninitialised, so only the pages a thread's evaluations reach
/// become resident: zero-filled, it made every thread of every 3D-builder pass that met one exact test
/// hold 2 MiB (64 MiB, 147 bytes per point, for the dragon on 16 threads).
class Arena {
 public:
  static constexpr std::size_t kSize = std::size_t(1) << 18;
  Arena() : buf_(new double[kSize]) {}
  void reset() { top_ = 0; }
  double* take(std::size_t n) {
    if (top_ + n > kSize) throw Error("dw::predicates: exact arithmetic arena exhausted");
    double* p = buf_.get() + top_;
    top_ += n;
    return p;
  }

  Expansion diff(double a, double b) {
    Expansion r{take(2), 0};
    double s, e;
    exact::twoDiff(a, b, s, e);
    if (e != 0.0) r.v[r.len++] = e;
    if (s != 0.0 || r.len == 0) r.v[r.len++] = s;
    return r;
  }
  Expansion add(const Expansion& a, const Expansion& b) {
    Expansion r{take(a.len + b.len), 0};
    r.len = exact::sum(a.len, a.v, b.len, b.v, r.v);
    return r;
  }
  Expansion neg(const Expansion& a) {
    Expansion r{take(a.len), a.len};
    for (std::size_t i = 0; i < a.len; ++i) r.v[i] = -a.v[i];
    return r;
  }
  Expansion sub(const Expansion& a, const Expansion& b) { return add(a, neg(b)); }
  Expansion mul(const Expansion& a, const Expansion& b) {
    const Expansion& big = a.len >= b.len ? a : b;
    const Expansion& small = a.len >= b.len ? b : a;
    Expansion r{take(2 * big.len * small.len), 0};
    double* tmp = take(2 * big.len);
    double* acc = take(2 * big.len * small.len);
    r.len = exact::product(big.len, big.v, small.len, small.v, r.v, tmp, acc);
    if (r.len == 0) {
      r.v[0] = 0.0;
      r.len = 1;
    }
    return r;
  }

 private:
  std::unique_ptr<double[]> buf_;
  std::size_t top_ = 0;
};

Arena& arena() {
  thread_local Arena a;
  a.reset();
  return a;
}

double signedEstimate(const Expansion& e) {
  const int s = exact::sign(e.len, e.v);
  // The estimate's magnitude is only indicative; its sign must be the exact one.
  const double est = exact::estimate(e.len, e.v);
  if (s == 0) return 0.0;
  if ((est > 0.0) == (s > 0) && est != 0.0) return est;
  return s > 0 ? 1.0 : -1.0;
}

// det3 of the rows (x_i, y_i, z_i), i = 0..2.
Expansion det3(Arena& A, const Expansion* x, const Expansion* y, const Expansion* z) {
  const Expansion m0 = A.sub(A.mul(y[1], z[2]), A.mul(z[1], y[2]));
  const Expansion m1 = A.sub(A.mul(y[2], z[0]), A.mul(z[2], y[0]));
  const Expansion m2 = A.sub(A.mul(y[0], z[1]), A.mul(z[0], y[1]));
  return A.add(A.add(A.mul(x[0], m0), A.mul(x[1], m1)), A.mul(x[2], m2));
}

}  // namespace

namespace detail {

double orient2dExact(const double* a, const double* b, const double* c) {
  Arena& A = arena();
  const Expansion acx = A.diff(a[0], c[0]), acy = A.diff(a[1], c[1]);
  const Expansion bcx = A.diff(b[0], c[0]), bcy = A.diff(b[1], c[1]);
  return signedEstimate(A.sub(A.mul(acx, bcy), A.mul(acy, bcx)));
}

double orient3dExact(const double* a, const double* b, const double* c, const double* d) {
  Arena& A = arena();
  const Expansion x[3] = {A.diff(a[0], d[0]), A.diff(b[0], d[0]), A.diff(c[0], d[0])};
  const Expansion y[3] = {A.diff(a[1], d[1]), A.diff(b[1], d[1]), A.diff(c[1], d[1])};
  const Expansion z[3] = {A.diff(a[2], d[2]), A.diff(b[2], d[2]), A.diff(c[2], d[2])};
  return signedEstimate(det3(A, x, y, z));
}

double insphereExact(const double* a, const double* b, const double* c, const double* d, const double* e) {
  // Laplace expansion along the lifted column of det[p - e, |p - e|^2] over p = a, b, c, d, written
  // exactly as the filtered formula: (dlift*abc - clift*dab) + (blift*cda - alift*bcd).
  Arena& A = arena();
  const double* p[4] = {a, b, c, d};
  Expansion x[4], y[4], z[4], lift[4];
  for (int i = 0; i < 4; ++i) {
    x[i] = A.diff(p[i][0], e[0]);
    y[i] = A.diff(p[i][1], e[1]);
    z[i] = A.diff(p[i][2], e[2]);
    lift[i] = A.add(A.add(A.mul(x[i], x[i]), A.mul(y[i], y[i])), A.mul(z[i], z[i]));
  }
  // 2x2 minors in (x, y): m(i, j) = x_i*y_j - x_j*y_i.
  auto m = [&](int i, int j) { return A.sub(A.mul(x[i], y[j]), A.mul(x[j], y[i])); };
  const Expansion ab = m(0, 1), bc = m(1, 2), cd = m(2, 3), da = m(3, 0), ac = m(0, 2), bd = m(1, 3);
  const Expansion abc = A.add(A.sub(A.mul(z[0], bc), A.mul(z[1], ac)), A.mul(z[2], ab));
  const Expansion bcd = A.add(A.sub(A.mul(z[1], cd), A.mul(z[2], bd)), A.mul(z[3], bc));
  const Expansion cda = A.add(A.add(A.mul(z[2], da), A.mul(z[3], ac)), A.mul(z[0], cd));
  const Expansion dab = A.add(A.add(A.mul(z[3], ab), A.mul(z[0], bd)), A.mul(z[1], da));
  const Expansion left = A.sub(A.mul(lift[3], abc), A.mul(lift[2], dab));
  const Expansion right = A.sub(A.mul(lift[1], cda), A.mul(lift[0], bcd));
  return signedEstimate(A.add(left, right));
}

double orient3dTail(const double* a, const double* b, const double* c, const double* d) {
  double unused, permanent;
  const double det = orient3dDeterminant<true>(a, b, c, d, unused, permanent);
  if (std::fabs(det) > kO3dBoundA * permanent) return det;
  return orient3dExact(a, b, c, d);
}

double insphereTail(const double* a, const double* b, const double* c, const double* d, const double* e) {
  double unused, permanent;
  const double det = insphereDeterminant<true>(a, b, c, d, e, unused, permanent);
  if (std::fabs(det) > kIspBoundA * permanent) return det;
  return insphereExact(a, b, c, d, e);
}

}  // namespace detail

int insphereSoS(const double* a, const double* b, const double* c, const double* d, const double* e,
                std::uint64_t ia, std::uint64_t ib, std::uint64_t ic, std::uint64_t id, std::uint64_t ie) {
  const int s = signOf(insphere(a, b, c, d, e));
  if (s != 0) return s;
  // d insphere / d lift(p), from the 5x5 lifted determinant (alternating in its five points):
  //   e: -orient3d(a,b,c,d)   d: orient3d(a,b,c,e)   c: orient3d(a,b,e,d)
  //   b: orient3d(a,e,c,d)    a: orient3d(e,b,c,d)
  // Raising e's lift moves e outwards, hence the minus sign on its own cofactor.
  struct Term {
    std::uint64_t id;
    int which;
  };
  Term t[5] = {{ia, 0}, {ib, 1}, {ic, 2}, {id, 3}, {ie, 4}};
  std::sort(t, t + 5, [](const Term& l, const Term& r) { return l.id > r.id; });
  for (const Term& term : t) {
    double o = 0.0;
    switch (term.which) {
      case 0: o = orient3d(e, b, c, d); break;
      case 1: o = orient3d(a, e, c, d); break;
      case 2: o = orient3d(a, b, e, d); break;
      case 3: o = orient3d(a, b, c, e); break;
      default: o = -orient3d(a, b, c, d); break;
    }
    const int so = signOf(o);
    if (so != 0) return so;
  }
  return 0;
}

}  // namespace predicates
}  // namespace dw
