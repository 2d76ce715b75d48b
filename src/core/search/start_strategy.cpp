#include "pcl_delaunay_walk/core/search/start_strategy.h"

#include <algorithm>
#include <cctype>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {

const char* toString(StartStrategy s) {
  switch (s) {
    case StartStrategy::Zero: return "zero";
    case StartStrategy::KdAnn: return "kd-ann";
    case StartStrategy::Pnn: return "pnn";
    case StartStrategy::PnnOptimized: return "pnn-optimized";
  }
  return "unknown";
}

StartStrategy parseStartStrategy(const std::string& name) {
  std::string s = name;
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  std::replace(s.begin(), s.end(), '_', '-');
  if (s == "zero") return StartStrategy::Zero;
  if (s == "kd-ann" || s == "kdann") return StartStrategy::KdAnn;
  if (s == "pnn") return StartStrategy::Pnn;
  if (s == "pnn-optimized" || s == "pnn-opt") return StartStrategy::PnnOptimized;
  throw Error("pcl_delaunay_walk: unknown start strategy '" + name +
              "' (expected zero, kd-ann, pnn or pnn-optimized)");
}

}  // namespace dw
