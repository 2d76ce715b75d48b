// The distributed TIN's leaf/merge steps, run in one process over simulated ranks: the union of the
// emitted triangles must equal the single-process dw::tin::triangulate, triangle for triangle, once each.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <random>
#include <set>
#include <string>

#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "pcl_delaunay_walk/mpi/strip_group.h"

namespace {

using dw::index_t;
using Tri = std::array<index_t, 3>;

Tri canonical(index_t a, index_t b, index_t c) {  // rotate so the smallest index is first (keeps ccw)
  if (b < a && b < c) return {b, c, a};
  if (c < a && c < b) return {c, a, b};
  return {a, b, c};
}

std::vector<Tri> canonicalSet(const std::vector<index_t>& t) {
  std::vector<Tri> s;
  for (std::size_t i = 0; i + 2 < t.size(); i += 3) s.push_back(canonical(t[i], t[i + 1], t[i + 2]));
  std::sort(s.begin(), s.end());
  return s;
}

/// Splits by equal-count quantiles along the long axis, runs a leaf per simulated rank, then the same
/// pairwise tree as the MPI driver. Returns every emitted triangle (duplicates kept, to detect them).
std::vector<index_t> simulate(const std::vector<double>& x, const std::vector<double>& y, int ranks,
                              std::size_t* merge_points = nullptr) {
  double lo[2] = {x[0], y[0]}, hi[2] = {x[0], y[0]};
  for (std::size_t i = 0; i < x.size(); ++i) {
    lo[0] = std::min(lo[0], x[i]);
    hi[0] = std::max(hi[0], x[i]);
    lo[1] = std::min(lo[1], y[i]);
    hi[1] = std::max(hi[1], y[i]);
  }
  const int axis = hi[1] - lo[1] > hi[0] - lo[0] ? 1 : 0;
  const std::vector<double>& u = axis ? y : x;
  std::vector<double> sorted(u);
  std::sort(sorted.begin(), sorted.end());
  std::vector<double> split(ranks + 1);
  split[0] = -INFINITY;
  split[ranks] = INFINITY;
  for (int r = 1; r < ranks; ++r) split[r] = sorted[r * sorted.size() / ranks];
  std::vector<dw::mpi::StripGroup> groups;
  std::vector<index_t> all;
  for (int r = 0; r < ranks; ++r) {
    dw::mpi::StripPoints p;
    for (std::size_t i = 0; i < x.size(); ++i)
      if (u[i] >= split[r] && u[i] < split[r + 1]) p.push(index_t(i), x[i], y[i], 0.0);
    dw::mpi::Emitted e;
    // Equal splitters make an empty strip [s, s): the driver gives it an empty leaf too.
    if (split[r] < split[r + 1]) {
      groups.push_back(dw::mpi::processLeaf(std::move(p), axis, split[r], split[r + 1], e));
    } else {
      dw::mpi::StripGroup g;
      g.axis = axis;
      g.lo = split[r];
      g.hi = split[r + 1];
      groups.push_back(g);
    }
    all.insert(all.end(), e.triangles.begin(), e.triangles.end());
  }
  std::size_t merged = 0;
  for (int step = 1; step < ranks; step *= 2)
    for (int r = 0; r + step < ranks; r += 2 * step) {
      dw::mpi::Emitted e;
      groups[r] = dw::mpi::mergeStrips(std::move(groups[r]), std::move(groups[r + step]), e);
      merged += e.band_points;
      all.insert(all.end(), e.triangles.begin(), e.triangles.end());
    }
  EXPECT_TRUE(groups[0].band.size() == 0 || groups[0].fences.size() > 0 || all.empty());
  if (merge_points) *merge_points = merged;
  return all;
}

void expectSameAsSequential(const std::vector<double>& x, const std::vector<double>& y, int ranks) {
  dw::tin::TinOptions opt;
  opt.num_threads = 1;
  opt.num_strips = 1;
  const dw::tin::TinResult ref = dw::tin::triangulate(x.data(), y.data(), x.size(), opt);
  std::size_t merged = 0;
  const std::vector<Tri> got = canonicalSet(simulate(x, y, ranks, &merged));
  const std::vector<Tri> want = canonicalSet(ref.triangles);
  ASSERT_EQ(std::adjacent_find(got.begin(), got.end()), got.end()) << "a triangle was emitted twice";
  ASSERT_EQ(got.size(), want.size()) << ranks << " ranks";
  EXPECT_TRUE(got == want) << ranks << " ranks";
  if (ranks > 1 && x.size() > 10000) {
    EXPECT_LT(merged, x.size()) << "merges should re-triangulate only the bands";
  }
}

TEST(StripGroup, RandomPointsMatchSequential) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> d(-1000.0, 1000.0);
  std::vector<double> x(30000), y(30000);
  for (std::size_t i = 0; i < x.size(); ++i) {
    x[i] = d(rng);
    y[i] = 0.5 * d(rng);
  }
  for (int ranks : {1, 2, 3, 4, 7}) expectSameAsSequential(x, y, ranks);
}

TEST(StripGroup, IntegerGridWithTiesAndDuplicatesMatchesSequential) {
  // Every unit square of the grid is cocircular: only the perturbation decides; plus duplicates.
  std::mt19937_64 rng(3);
  std::uniform_int_distribution<int> d(0, 120);
  std::vector<double> x, y;
  for (int i = 0; i < 20000; ++i) {
    x.push_back(d(rng));
    y.push_back(d(rng) % 80);
  }
  for (int ranks : {2, 4, 5}) expectSameAsSequential(x, y, ranks);
}

TEST(StripGroup, SyntheticLidarMatchesSequential) {
  dw::las::LidarGenOptions g;
  g.num_points = 200000;
  g.seed = 11;
  std::vector<double> x, y;
  dw::las::generateLidar(g, [&](const dw::las::LasRecord& r) {
    x.push_back(r.X);
    y.push_back(r.Y);
  });
  for (int ranks : {2, 4}) expectSameAsSequential(x, y, ranks);
}

TEST(StripGroup, RealAirborneTileMatchesSequential) {
  const std::string path = std::string(DW_SHARED_DATA_DIR) + "/airborne/autzen_trim.las";
  if (!std::ifstream(path).good()) GTEST_SKIP() << "shared data absent: " << path;
  const dw::las::LasCloud las = dw::las::readLasFile(path);
  std::vector<double> x(las.size()), y(las.size());
  for (std::size_t i = 0; i < las.size(); ++i) {
    x[i] = las.X[i];
    y[i] = las.Y[i];
  }
  expectSameAsSequential(x, y, 4);
}

TEST(StripGroup, TinyAndCollinearInputsMatchSequential) {
  // Collinear everywhere (no triangle), collinear strips inside a non-collinear set, fewer points than
  // ranks (empty and one-point strips).
  std::vector<double> x, y;
  for (int i = 0; i < 40; ++i) {
    x.push_back(i);
    y.push_back(2.0 * i);
  }
  for (int ranks : {1, 3, 4}) expectSameAsSequential(x, y, ranks);
  x.push_back(20.5);
  y.push_back(-3.0);
  for (int ranks : {2, 3, 4}) expectSameAsSequential(x, y, ranks);
  const std::vector<double> sx = {0, 1, 2, 3, 4}, sy = {0, 3, 1, 4, 2};
  for (int ranks : {2, 4, 7}) expectSameAsSequential(sx, sy, ranks);
}

TEST(StripGroup, SerializationRoundTrips) {
  dw::mpi::StripGroup g;
  g.axis = 1;
  g.lo = -2.5;
  g.hi = 7.0;
  g.band.push(3, 1.0, 2.0, 3.0);
  g.band.push(9, 4.0, 5.0, 6.0);
  g.fences = {(std::uint64_t{3} << 32) | 9};
  const std::vector<unsigned char> b = g.serialize();
  const dw::mpi::StripGroup h = dw::mpi::StripGroup::deserialize(b.data(), b.size());
  EXPECT_EQ(h.axis, 1);
  EXPECT_EQ(h.lo, -2.5);
  EXPECT_EQ(h.hi, 7.0);
  EXPECT_EQ(h.band.gid, g.band.gid);
  EXPECT_EQ(h.band.z, g.band.z);
  EXPECT_EQ(h.fences, g.fences);
  EXPECT_THROW(dw::mpi::StripGroup::deserialize(b.data(), b.size() - 1), dw::Error);
  std::vector<unsigned char> bad(b);
  bad[0] ^= 1;
  EXPECT_THROW(dw::mpi::StripGroup::deserialize(bad.data(), bad.size()), dw::Error);
}

TEST(StripGroup, BadInputThrows) {
  dw::mpi::Emitted e;
  dw::mpi::StripPoints p;
  p.push(5, 0, 0, 0);
  p.push(4, 1, 0, 0);
  EXPECT_THROW(dw::mpi::processLeaf(dw::mpi::StripPoints(p), 0, -1, 2, e), dw::Error);  // unsorted
  dw::mpi::StripPoints q;
  q.push(1, 0, 0, 0);
  q.push(2, 5, 0, 0);
  EXPECT_THROW(dw::mpi::processLeaf(std::move(q), 0, -1, 2, e), dw::Error);  // outside strip
  dw::mpi::StripGroup a, b;
  a.hi = 1;
  b.lo = 2;
  EXPECT_THROW(dw::mpi::mergeStrips(std::move(a), std::move(b), e), dw::Error);  // not adjacent
}

}  // namespace
