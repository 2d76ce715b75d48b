/// \file start_strategy.h
/// \brief Where a walk starts (seed §4): Zero, KD-ANN, PNN and PNN-optimized, plus a previous-query
/// start for generic search sequences.
#pragma once

#include <string>

namespace dw {

enum class StartStrategy {
  Zero,          ///< a fixed vertex: the one nearest the centroid
  KdAnn,         ///< leaf of a k-d tree descent without backtracking
  Pnn,           ///< the hint (the previous ICP correspondence); Zero when there is no hint
  PnnOptimized,  ///< the hint when there is one, else KD-ANN (seed: KD-ANN first iteration, PNN after)
};

const char* toString(StartStrategy s);
/// Parses "zero", "kd-ann", "pnn", "pnn-optimized" (case-insensitive); throws dw::Error otherwise.
StartStrategy parseStartStrategy(const std::string& name);

}  // namespace dw
