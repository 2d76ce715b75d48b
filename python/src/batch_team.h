/// \file batch_team.h
/// \brief The worker threads of NeighbourSearch's batch calls, kept by the module between calls.
#pragma once

#include <unistd.h>

#include <memory>
#include <mutex>
#include <optional>

#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw_py {

/// While it lives, the calling thread's parallel loops (dw::parallelFor) run on a thread team that the
/// module keeps between calls. A worker sizes its search scratch at its first kNN or radius query
/// that needs it (one visit stamp per graph vertex: 20 MB on a 5M-point graph); on fresh threads
/// every call paid that again. One batch at a time uses the team; a batch from another Python thread
/// meanwhile runs on threads of its own, as without a team. (ThreadTeam wants one calling thread at a
/// time; the mutex makes the batches that use it take turns.)
class BatchTeam {
 public:
  explicit BatchTeam(unsigned workers) {
    if (workers < 2) return;
    lock_ = std::unique_lock<std::mutex>(mutex(), std::try_to_lock);
    if (!lock_.owns_lock()) return;
    Shared& s = shared();
    // A forked child has the team object but not its threads: it must neither use nor join them.
    if (s.team && s.pid != getpid()) static_cast<void>(s.team.release());
    if (!s.team || s.team->size() < workers) {
      s.team.reset();  // the old threads end before the new ones start
      s.team = std::make_unique<dw::ThreadTeam>(workers);
      s.pid = getpid();
    }
    scope_.emplace(*s.team);
  }

 private:
  struct Shared {
    std::unique_ptr<dw::ThreadTeam> team;
    pid_t pid = 0;
  };
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  static Shared& shared() {
    static Shared s;
    return s;
  }

  std::unique_lock<std::mutex> lock_;           // released last
  std::optional<dw::ThreadTeam::Scope> scope_;  // the loops' runner restored first
};

}  // namespace dw_py
