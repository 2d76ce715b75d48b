/// \file test_hilbert_order.cpp
/// \brief The table-driven Hilbert key is a Hilbert curve: on the first 256 x 256 block its keys are a
/// permutation of 0..65535 and consecutive keys are 4-neighbours; the sort is stable.
#include <gtest/gtest.h>

#include <cstdlib>
#include <vector>

#include "core/tin/bowyer_watson.h"
#include "core/util/space_filling_curve.h"

namespace {

TEST(HilbertOrder, ConsecutiveKeysAreNeighbours) {
  // Map integer cells straight to the key's 16-bit grid: box [0, 65535], unit scale.
  const double inv = 1.0 / 65535.0;
  std::vector<int> cell_of(65536, -1);
  for (int x = 0; x < 256; ++x)
    for (int y = 0; y < 256; ++y) {
      const std::uint32_t k = dw::hilbertKey(x + 0.5, y + 0.5, 0.0, 0.0, inv, inv);
      ASSERT_LT(k, 65536u);
      ASSERT_EQ(cell_of[k], -1);
      cell_of[k] = x * 256 + y;
    }
  for (int k = 1; k < 65536; ++k) {
    const int a = cell_of[k - 1], b = cell_of[k];
    EXPECT_EQ(std::abs(a / 256 - b / 256) + std::abs(a % 256 - b % 256), 1) << "key " << k;
  }
}

TEST(HilbertOrder, SortIsStableOnEqualKeys) {
  std::vector<double> xy = {5, 5, 1, 1, 5, 5, 0, 0, 5, 5};
  std::vector<dw::index_t> pos = {0, 1, 2, 3, 4};
  dw::tin::detail::brioHilbertSort(xy.data(), pos);
  std::vector<dw::index_t> copies;
  for (auto p : pos)
    if (xy[2 * p] == 5) copies.push_back(p);
  EXPECT_EQ(copies, (std::vector<dw::index_t>{0, 2, 4}));
}

}  // namespace
