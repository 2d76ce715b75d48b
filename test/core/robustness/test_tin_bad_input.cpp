// dw::tin::triangulate on hostile 2D input: a certified Delaunay TIN or a clear dw::Error, never a
// wrong triangulation. The certificate (certifyDelaunay) is the independent judge.
#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "pcl_delaunay_walk/core/tin/certificate.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"

using namespace dw;

namespace {

/// Triangulates with one strip and with three; each must be certified, or the call must throw.
void expectCertifiedOrRefused(const std::vector<double>& x, const std::vector<double>& y,
                              const std::string& what) {
  for (unsigned strips : {1u, 3u}) {
    tin::TinOptions o;
    o.num_threads = 2;
    o.num_strips = strips;
    tin::TinResult r;
    try {
      r = tin::triangulate(x.data(), y.data(), x.size(), o);
    } catch (const Error&) {
      continue;  // a clear refusal is acceptable
    }
    for (index_t t : r.triangles) ASSERT_LT(t, x.size()) << what;
    if (r.degenerate) {
      EXPECT_EQ(r.numTriangles(), 0u) << what;
      continue;
    }
    const tin::Certificate c =
        tin::certifyDelaunay(x.data(), y.data(), x.size(), r.triangles, r.num_vertices);
    EXPECT_TRUE(c.ok) << what << ", " << strips << " strips: " << c.message;
  }
}

std::pair<std::vector<double>, std::vector<double>> randomPoints(std::size_t n, double scale, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> x(n), y(n);
  for (std::size_t i = 0; i < n; ++i) x[i] = scale * u(rng), y[i] = scale * u(rng);
  return {x, y};
}

}  // namespace

TEST(TinBadInput, EmptyTinyAndNonFinite) {
  expectCertifiedOrRefused({}, {}, "empty");
  expectCertifiedOrRefused({1}, {2}, "one point");
  expectCertifiedOrRefused({1, 1, 1}, {2, 2, 2}, "three copies");
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  expectCertifiedOrRefused({nan, 0, 1, 0, inf}, {0, 0, 0, 1, 5}, "NaN and Inf beside a triangle");
  const tin::TinResult r = tin::triangulate(std::vector<double>{nan, 0, 1, 0, inf}.data(),
                                            std::vector<double>{0, 0, 0, 1, 5}.data(), 5);
  EXPECT_EQ(r.skipped, (std::vector<index_t>{0, 4}));
  EXPECT_EQ(r.numTriangles(), 1u);
}

TEST(TinBadInput, ModerateScalesAreCertified) {
  for (double scale : {1e-30, 1e-6, 1.0, 1e6, 1e30}) {
    const auto p = randomPoints(300, scale, 3);
    expectCertifiedOrRefused(p.first, p.second, "scale " + std::to_string(scale));
  }
}

TEST(TinBadInput, HugeCoordinatesAreRejectedOrExact) {
  // Regression guard for B8 (docs/robustness.md; found by fuzz/fuzz_tin, fixed by refusing magnitudes
  // the exact predicates cannot take): with |x| ~ 1e308 the predicates overflowed and triangulate
  // returned triangles that were not even counter-clockwise.
  for (double scale : {1e200, 1.7e308}) {
    const auto p = randomPoints(21, scale, 5);
    expectCertifiedOrRefused(p.first, p.second, "scale " + std::to_string(scale));
  }
  // The fuzzer's input (mode 2, 21 raw doubles), as it printed them.
  const std::vector<double> x{2.6163911868687542e+307,  1.3749329070571346e+308,  1.3363942974559923e+307,
                              3.567850331245008e+307,   4.8914623838994189e+306,  1.6790799318499784e+307,
                              4.3732808242901966e+307,  1.1096692361441215e+308,  1.6022789574231765e+308,
                              1.1232952537445545e+308,  6.8107933889997736e+307,  -1.03166439782379e+308,
                              1.0118778617166571e+308,  -2.9329975400447091e+307, 1.3300138041331324e+308,
                              1.8831433850080664e+307,  1.5546522461638524e+307,  7.4835118415773005e+307,
                              -7.1392934459124565e+307, 8.1969758984040764e+307,  1.428018957690597e+307};
  const std::vector<double> y{-1.2196557456670019e+307, 1.0467805372838046e+308,  5.2027338952931302e+306,
                              8.5583387940365728e+307,  -1.6979289843630131e+308, -1.4005483170141676e+308,
                              -1.7230319780262419e+308, -5.8433551544530365e+307, 3.805157189752858e+307,
                              -3.5970085388219904e+307, -6.0743138123809881e+307, -1.6879376015088134e+308,
                              -2.6117497456449444e+306, -1.2804078119386345e+308, 1.6903551270271693e+308,
                              -1.0235840906395389e+308, 1.683727428280648e+308,   1.7635833644198513e+308,
                              1.3069339135589389e+308,  -5.259252313826051e+307,  1.5377636948510348e+303};
  expectCertifiedOrRefused(x, y, "fuzz_tin crash input");
}

TEST(TinBadInput, SubnormalCoordinatesAreRejectedOrExact) {
  // Products of differences underflow below ~1e-160; exact expansion arithmetic assumes they do not.
  for (double scale : {1e-160, 1e-300, 4.9e-324 * 1000}) {
    const auto p = randomPoints(40, scale, 6);
    expectCertifiedOrRefused(p.first, p.second, "scale " + std::to_string(scale));
  }
}
