/// \file exact_arithmetic.h
/// \brief Floating-point expansion arithmetic (Priest; Shewchuk 1997) for the exact fallback of the
/// robust predicates. An expansion is a sum of non-overlapping doubles, stored least significant first;
/// its sign is the sign of its most significant non-zero component. Requires round-to-nearest IEEE
/// double arithmetic without extended precision (x86-64 SSE2 satisfies this).
#pragma once

#include <cmath>
#include <cstddef>

namespace dw {
namespace exact {

/// a + b = s + e exactly, with s = fl(a + b).
inline void twoSum(double a, double b, double& s, double& e) {
  s = a + b;
  const double bv = s - a;
  const double av = s - bv;
  e = (a - av) + (b - bv);
}

/// a - b = s + e exactly.
inline void twoDiff(double a, double b, double& s, double& e) {
  twoSum(a, -b, s, e);
}

/// a * b = p + e exactly (the fused multiply-add gives the rounding error directly).
inline void twoProduct(double a, double b, double& p, double& e) {
  p = a * b;
  e = std::fma(a, b, -p);
}

/// h = e + f; returns the length of h (zero components eliminated). h needs room for elen + flen.
inline std::size_t sum(std::size_t elen, const double* e, std::size_t flen, const double* f, double* h) {
  // Merge by magnitude, then accumulate with twoSum carrying the running sum (Shewchuk's
  // expansion_sum_zeroelim, written as a plain merge for clarity).
  std::size_t i = 0, j = 0, hl = 0;
  double q;
  auto next = [&]() {
    if (j >= flen || (i < elen && std::fabs(e[i]) <= std::fabs(f[j]))) return e[i++];
    return f[j++];
  };
  if (elen + flen == 0) return 0;
  q = next();
  while (i < elen || j < flen) {
    double s, err;
    twoSum(q, next(), s, err);
    if (err != 0.0) h[hl++] = err;
    q = s;
  }
  if (q != 0.0 || hl == 0) h[hl++] = q;
  return hl;
}

/// h = e * b; returns the length of h. h needs room for 2 * elen.
inline std::size_t scale(std::size_t elen, const double* e, double b, double* h) {
  if (elen == 0) return 0;
  std::size_t hl = 0;
  double q, hh;
  twoProduct(e[0], b, q, hh);
  if (hh != 0.0) h[hl++] = hh;
  for (std::size_t i = 1; i < elen; ++i) {
    double p1, p0, s, t;
    twoProduct(e[i], b, p1, p0);
    twoSum(q, p0, s, t);
    if (t != 0.0) h[hl++] = t;
    twoSum(p1, s, q, t);        // p1 and s do not overlap in a way that loses bits: fast-two-sum suffices,
    if (t != 0.0) h[hl++] = t;  // the plain twoSum is used for safety.
  }
  if (q != 0.0 || hl == 0) h[hl++] = q;
  return hl;
}

/// h = e * f (expansion product by distributing over f's components); h needs 2 * elen * flen.
/// `tmp` needs 2 * elen and `acc` needs 2 * elen * flen doubles.
inline std::size_t product(std::size_t elen, const double* e, std::size_t flen, const double* f, double* h,
                           double* tmp, double* acc) {
  std::size_t hl = 0;
  for (std::size_t k = 0; k < flen; ++k) {
    const std::size_t tl = scale(elen, e, f[k], tmp);
    const std::size_t nl = sum(hl, h, tl, tmp, acc);
    for (std::size_t m = 0; m < nl; ++m) h[m] = acc[m];
    hl = nl;
  }
  return hl;
}

/// Sign of an expansion: the sign of its most significant (last) non-zero component.
inline int sign(std::size_t len, const double* e) {
  for (std::size_t i = len; i-- > 0;)
    if (e[i] != 0.0) return e[i] > 0.0 ? 1 : -1;
  return 0;
}

/// Approximate value (sum of components, most significant last).
inline double estimate(std::size_t len, const double* e) {
  double s = 0.0;
  for (std::size_t i = 0; i < len; ++i) s += e[i];
  return s;
}

}  // namespace exact
}  // namespace dw
