/// \file cell_grid.h
/// \brief The halo unit of the block builders (threads: builder3d/block_parallel_builder.cpp, MPI ranks:
/// src/mpi/rank_block.cpp): a uniform grid of cubic cells. A block holds whole cells; it starts with
/// its own cells plus one ring around them, and a tetrahedron is certified once every cell under its
/// rounded circumsphere that may hold a conflicting point is held.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace dw {

struct CellGrid {
  double base[3] = {0, 0, 0};  ///< lower corner of cell 0 (local coordinates)
  double width = 1;            ///< cell edge
  int dims[3] = {1, 1, 1};

  std::size_t numCells() const { return std::size_t(dims[0]) * dims[1] * dims[2]; }
  /// The cell coordinate of v along axis a, clamped into the grid.
  int coord(double v, int a) const {
    const double c = std::floor((v - base[a]) / width);
    return static_cast<int>(std::min(std::max(c, 0.0), double(dims[a] - 1)));
  }
  std::uint32_t index(std::uint32_t x, std::uint32_t y, std::uint32_t z) const {
    return static_cast<std::uint32_t>((std::size_t(x) * dims[1] + y) * dims[2] + z);
  }
  void coords(std::uint32_t c, std::uint32_t xyz[3]) const {
    xyz[2] = c % dims[2];
    xyz[1] = (c / dims[2]) % dims[1];
    xyz[0] = static_cast<std::uint32_t>(c / (std::size_t(dims[1]) * dims[2]));
  }
  /// Calls fn(cell) for c and the (up to 26) cells around it: the ring a block starts with.
  template <class Fn>
  void forRing(std::uint32_t c, Fn&& fn) const {
    std::uint32_t xyz[3];
    coords(c, xyz);
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const long X = long(xyz[0]) + dx, Y = long(xyz[1]) + dy, Z = long(xyz[2]) + dz;
          if (X < 0 || Y < 0 || Z < 0 || X >= dims[0] || Y >= dims[1] || Z >= dims[2]) continue;
          fn(index(std::uint32_t(X), std::uint32_t(Y), std::uint32_t(Z)));
        }
  }
  /// The cells [range[a][0], range[a][1]] under the ball (centre, radius) enlarged by `slack`; every
  /// cell for an unbounded ball (a flat sliver, which may hold any point).
  void cellsUnderBall(const double centre[3], double radius, bool unbounded, double slack,
                      int range[3][2]) const {
    for (int a = 0; a < 3; ++a) {
      if (unbounded) {
        range[a][0] = 0, range[a][1] = dims[a] - 1;
      } else {
        range[a][0] = coord(centre[a] - radius - slack, a);
        range[a][1] = coord(centre[a] + radius + slack, a);
      }
    }
  }
};

}  // namespace dw
