/// \file point_view.h
/// \brief The one narrow interface through which builders read a caller's points (nanoflann's adaptor
/// idea): strided float or double xyz, never copied or owned.
#pragma once

#include <array>
#include <cstddef>
#include <cstring>

namespace dw {

struct PointView {
  const void* data = nullptr;
  std::size_t size = 0;    ///< number of points
  std::size_t stride = 0;  ///< bytes between consecutive points
  bool is_double = false;  ///< components are double (LAS) rather than float (PCL)

  static PointView fromFloat(const float* xyz, std::size_t n, std::size_t stride_bytes = 3 * sizeof(float)) {
    return {xyz, n, stride_bytes, false};
  }
  static PointView fromDouble(const double* xyz, std::size_t n,
                              std::size_t stride_bytes = 3 * sizeof(double)) {
    return {xyz, n, stride_bytes, true};
  }

  std::array<double, 3> operator[](std::size_t i) const {
    const char* p = static_cast<const char*>(data) + i * stride;
    if (is_double) {
      double v[3];
      std::memcpy(v, p, sizeof v);
      return {v[0], v[1], v[2]};
    }
    float v[3];
    std::memcpy(v, p, sizeof v);
    return {v[0], v[1], v[2]};
  }
};

}  // namespace dw
