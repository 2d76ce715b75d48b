/// \file merge_scheduler.h
/// \brief Greedy order of the reduce (internal): two adjacent groups of strips are merged as soon as both
/// are complete, by the worker that completed the second one.
///
/// Why not a fixed tree merged level by level: every leaf of a balanced tree over K strips is log2 K
/// merges below the root, so after the last strip finishes, log2 K merges would run one after the other
/// while the other workers idle (docs/tin.md, "Merge order", has the times). Merging greedily, the last
/// strip usually finds both neighbours already merged into one group each: at most two merges remain.
/// The triangles do not depend on the merge order (the perturbed Delaunay triangulation is unique);
/// only the arena slots they land in, hence their order in the output array, may differ between runs.
#pragma once

#include <cstddef>
#include <mutex>
#include <vector>

namespace dw {
namespace tin {
namespace detail {

class MergeScheduler {
 public:
  /// Groups are named by their first strip; initially each strip is its own group, not yet complete.
  explicit MergeScheduler(std::size_t strips) : end_of_(strips), begin_of_(strips + 1, 0), idle_(strips, 0) {
    for (std::size_t s = 0; s < strips; ++s) {
      end_of_[s] = s + 1;
      begin_of_[s + 1] = s;
    }
  }

  /// A pair of adjacent groups claimed for merging: left = [left, right), right = [right, end).
  struct Claim {
    bool valid = false;
    std::size_t left = 0, right = 0;
  };

  /// The caller has just completed group [begin, end) (a strip or a merge). If an adjacent group is
  /// complete and not being merged, both are claimed and returned (the caller merges them, then calls
  /// this again for the result); otherwise the group is left idle for a neighbour to claim later.
  /// Invariant: no two adjacent groups are idle when the lock is released, so once every strip is
  /// complete and no merge is running, one group spans all strips.
  Claim complete(std::size_t begin, std::size_t end) {
    std::lock_guard<std::mutex> lock(mutex_);
    end_of_[begin] = end;
    begin_of_[end] = begin;
    Claim c;
    // begin_of_ of a group being merged may be stale, but that group's first strip is not idle.
    if (begin > 0 && idle_[begin_of_[begin]]) {
      c.valid = true;
      c.left = begin_of_[begin];
      c.right = begin;
    } else if (end < idle_.size() && idle_[end]) {
      c.valid = true;
      c.left = begin;
      c.right = end;
    }
    if (c.valid)
      idle_[c.left] = idle_[c.right] = 0;
    else
      idle_[begin] = 1;
    return c;
  }

  /// End of the group starting at `begin` (valid for complete groups).
  std::size_t endOf(std::size_t begin) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return end_of_[begin];
  }

 private:
  mutable std::mutex mutex_;
  std::vector<std::size_t> end_of_, begin_of_;
  std::vector<unsigned char> idle_;
};

}  // namespace detail
}  // namespace tin
}  // namespace dw
