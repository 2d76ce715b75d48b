/// \file fault_injection.h
/// \brief The testing hook of the distributed builders: make one rank fail (throw) or die (SIGKILL) at
/// a named stage, to check that a failing rank aborts the job and leaves no manifest.
#pragma once

#include <string>

namespace dw {
namespace mpi {

struct FaultInjection {
  std::string stage;  ///< where; empty: no fault
  int rank = -1;      ///< which rank
  bool kill = false;  ///< SIGKILL instead of an exception

  /// From "fail:STAGE:RANK" or "kill:STAGE:RANK" (the apps' --inject); throws std::invalid_argument
  /// on any other form.
  static FaultInjection parse(const std::string& spec);

  /// Fails or dies here when this is the chosen rank and stage; otherwise does nothing.
  void check(int my_rank, const char* at_stage) const;
};

/// FaultInjection::parse(spec).check(my_rank, at_stage), or nothing for an empty spec.
void checkFault(const std::string& spec, int my_rank, const char* at_stage);

}  // namespace mpi
}  // namespace dw
