/// \file query_replay.h
/// \brief Replays an ICP-like query sequence through one NN method, as one ICP run would issue it:
/// PNN hints are reset at the start and carried from iteration to iteration for the same source point.
#pragma once

#include <vector>

#include "icp_sequence.h"

namespace dwb {

/// All iterations' queries, materialised once so that replays time the NN step alone.
struct QueryReplay {
  std::size_t per_iteration = 0;
  std::vector<std::vector<float>> iterations;

  explicit QueryReplay(const IcpSequence& seq) : per_iteration(seq.source.size() / 3) {
    for (std::size_t t = 0; t < seq.poses.size(); ++t) iterations.push_back(seq.queries(t));
  }
  std::size_t numQueries() const { return per_iteration * iterations.size(); }

  /// Runs every iteration through `m`; returns the walk moves of all queries when `steps` is given.
  void run(NnMethod& m, NnBatch& batch, unsigned threads, std::vector<std::uint32_t>* steps = nullptr,
           std::vector<std::vector<int>>* answers = nullptr) const {
    batch.resize(per_iteration);
    batch.resetHints();
    if (steps) steps->clear();
    if (answers) answers->clear();
    for (const auto& q : iterations) {
      m.nearest(q.data(), per_iteration, batch, threads);
      if (steps) steps->insert(steps->end(), batch.steps.begin(), batch.steps.end());
      if (answers) answers->push_back(batch.index);
    }
  }
};

}  // namespace dwb
