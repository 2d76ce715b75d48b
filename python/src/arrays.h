/// \file arrays.h
/// \brief How the binding reads NumPy arrays: (n, 3) float32/float64 point sets with any strides, read in
/// place (no copy) wherever the library's access pattern allows, and the checks that turn a bad shape or
/// dtype into ValueError/TypeError before any work starts.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>

#include "pcl_delaunay_walk/core/graph/point_view.h"
#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw_py {

namespace py = pybind11;

/// An (n, cols) float32/float64 array as the binding reads it. `array` keeps the buffer alive for as
/// long as the object lives (also while the GIL is released), so a caller deleting its array mid-call
/// cannot free what a worker thread reads.
struct Points {
  py::array array;
  const char* data = nullptr;
  std::size_t n = 0;
  py::ssize_t row_stride = 0, col_stride = 0;  ///< bytes, may be negative (reversed views)
  bool is_double = false;

  template <typename T>
  double at(std::size_t i, int k) const {
    return static_cast<double>(
        *reinterpret_cast<const T*>(data + static_cast<py::ssize_t>(i) * row_stride + k * col_stride));
  }
};

inline std::string shapeText(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) s += (d ? ", " : "") + std::to_string(a.shape(d));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

/// Reads `obj` as an (n, cols) float array (cols = 3, or 2..3 when min_cols = 2). Python sequences are
/// converted (np.asarray); a float32/float64 array is used as it is, whatever its strides.
/// \throws TypeError for any other dtype, ValueError for another shape.
inline Points pointsArg(py::handle obj, const char* name, int min_cols = 3, int max_cols = 3) {
  Points p;
  p.array = py::array::ensure(obj);
  if (!p.array) throw py::type_error(std::string(name) + " must be an array of points");
  const py::dtype dt = p.array.dtype();
  if (dt.equal(py::dtype::of<double>()))
    p.is_double = true;
  else if (dt.equal(py::dtype::of<float>()))
    p.is_double = false;
  else
    throw py::type_error(std::string(name) + " must be float32 or float64, got dtype " +
                         py::cast<std::string>(dt.attr("name")));
  if (p.array.ndim() != 2 || p.array.shape(1) < min_cols || p.array.shape(1) > max_cols) {
    const std::string want =
        min_cols == max_cols ? "(n, " + std::to_string(max_cols) + ")" : "(n, 2) or (n, 3)";
    throw py::value_error(std::string(name) + " must have shape " + want + ", got " + shapeText(p.array));
  }
  p.data = static_cast<const char*>(p.array.data());
  p.n = static_cast<std::size_t>(p.array.shape(0));
  p.row_stride = p.array.strides(0);
  p.col_stride = p.array.strides(1);
  return p;
}

/// The points as the builders read them (dw::PointView: xyz adjacent, rows a positive stride apart):
/// the caller's buffer itself when its layout is that, else a C-contiguous copy held by `p`.
inline dw::PointView pointView(Points& p) {
  const py::ssize_t item = p.is_double ? 8 : 4;
  if (p.n > 0 && (p.col_stride != item || p.row_stride < 3 * item)) {
    if (p.is_double)
      p.array = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(p.array);
    else
      p.array = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(p.array);
    p.data = static_cast<const char*>(p.array.data());
    p.row_stride = 3 * item;
    p.col_stride = item;
  }
  return p.is_double ? dw::PointView::fromDouble(reinterpret_cast<const double*>(p.data), p.n,
                                                 static_cast<std::size_t>(p.row_stride))
                     : dw::PointView::fromFloat(reinterpret_cast<const float*>(p.data), p.n,
                                                static_cast<std::size_t>(p.row_stride));
}

/// Per-query vertex hints (the caller checks for None first): n integers (-1 or any value >= the vertex
/// count: none). \throws TypeError for a non-integer dtype, ValueError for a wrong length.
inline py::array_t<std::int64_t> hintsArg(py::handle obj, std::size_t n) {
  py::array a = py::array::ensure(obj);
  if (!a || (a.dtype().kind() != 'i' && a.dtype().kind() != 'u'))
    throw py::type_error("hints must be an integer array (the `ends` of an earlier nearest() call)");
  if (a.ndim() != 1 || static_cast<std::size_t>(a.shape(0)) != n)
    throw py::value_error("hints must have shape (" + std::to_string(n) + ",), got " + shapeText(a));
  return py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(a);
}

inline dw::index_t hintVertex(std::int64_t h) {
  return h < 0 || h >= static_cast<std::int64_t>(dw::kInvalidIndex) ? dw::kInvalidIndex
                                                                    : static_cast<dw::index_t>(h);
}

/// A new C-contiguous array that owns a moved-in std::vector (no copy of the payload).
template <typename T>
py::array_t<T> adopt(std::vector<T>&& v, std::vector<py::ssize_t> shape) {
  auto* owned = new std::vector<T>(std::move(v));
  py::capsule free_it(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(shape, owned->data(), free_it);
}

}  // namespace dw_py
