#include "fault_injection.h"

#include <csignal>
#include <stdexcept>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace mpi {

FaultInjection FaultInjection::parse(const std::string& spec) {
  const auto c1 = spec.find(':'), c2 = spec.rfind(':');
  if (c1 == std::string::npos || c1 == c2) throw std::invalid_argument(spec);
  const std::string kind = spec.substr(0, c1);
  if (kind != "kill" && kind != "fail") throw std::invalid_argument(spec);
  FaultInjection f;
  f.kill = kind == "kill";
  f.stage = spec.substr(c1 + 1, c2 - c1 - 1);
  f.rank = std::stoi(spec.substr(c2 + 1));
  return f;
}

void FaultInjection::check(int my_rank, const char* at_stage) const {
  if (rank != my_rank || stage != at_stage) return;
  if (kill) std::raise(SIGKILL);
  throw Error("injected failure on rank " + std::to_string(my_rank) + " at stage '" + at_stage + "'");
}

void checkFault(const std::string& spec, int my_rank, const char* at_stage) {
  if (!spec.empty()) FaultInjection::parse(spec).check(my_rank, at_stage);
}

}  // namespace mpi
}  // namespace dw
