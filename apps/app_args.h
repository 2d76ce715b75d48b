/// \file app_args.h
/// \brief Argument parsing shared by the PCL-free command-line tools (dw_lidar_gen, dw_tin_scaling,
/// dw_delaunay3d_scaling): counts with k/M suffixes and comma-separated lists, strict about what
/// follows the number, errors as dw::Error.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw_apps {

/// A positive count, optionally suffixed k/K (10^3) or m/M (10^6): "21M", "1.5k", "4000".
inline std::uint64_t parseCount(const std::string& s, const char* what = "count") {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  double mul = 1;
  if (end && (*end == 'k' || *end == 'K'))
    mul = 1e3, ++end;
  else if (end && (*end == 'm' || *end == 'M'))
    mul = 1e6, ++end;
  if (!end || end == s.c_str() || *end != '\0' || !(v > 0))
    throw dw::Error(std::string("bad ") + what + " '" + s + "'");
  return static_cast<std::uint64_t>(v * mul);
}

/// A finite number >= 0 with nothing after it ("0", "1.5").
inline double parseNonNegative(const std::string& s, const char* what) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (!end || end == s.c_str() || *end != '\0' || !(v >= 0) || v == HUGE_VAL)
    throw dw::Error(std::string("bad ") + what + " '" + s + "'");
  return v;
}

/// Comma-separated integers in [min, max] ("1,2,4,8,16").
inline std::vector<unsigned> parseList(const std::string& s, const char* what, unsigned min, unsigned max) {
  std::vector<unsigned> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) {
    char* end = nullptr;
    const long v = std::strtol(item.c_str(), &end, 10);
    if (item.empty() || !end || *end || v < long(min) || v > long(max))
      throw dw::Error(std::string("bad ") + what + " '" + item + "'");
    out.push_back(unsigned(v));
  }
  if (out.empty()) throw dw::Error(std::string("empty list of ") + what);
  return out;
}

}  // namespace dw_apps
