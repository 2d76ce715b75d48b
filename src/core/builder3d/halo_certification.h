/// \file halo_certification.h
/// \brief The certify-and-grow loop of a block's triangulation, shared by the threads' blocks
/// (block_parallel_builder.cpp) and the MPI ranks (src/mpi/rank_block.h).
///
/// A block triangulates its own vertices plus a halo. A finite tetrahedron with one of the block's own
/// vertices is *certified* once no point of the whole cloud lies inside its (rounding-enlarged)
/// circumsphere: then it is a tetrahedron of the global Delaunay triangulation. Certification passes
/// insert the missing points that the checks find until a pass finds none. Why a pass only looks at
/// the tetrahedra born since the previous pass, plus the conflicting ones it left that still exist: a
/// certified tetrahedron stays certified and alive (points are only added, and none lies in its ball),
/// and a tetrahedron in conflict is destroyed by the insertion of a conflicting point, unless that point
/// lay only within the rounding margin, in which case the tetrahedron is looked at again.
///
/// What differs between threads and ranks is only what a check may find and how the points reach the
/// block: threads read every point of a cell under a failing ball from shared memory; a rank must first
/// fetch a cell from its owners (a collective), so its checks can also answer "waiting for cells", and
/// such tetrahedra are looked at again after the fetch (recheckWaiting()).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "triangulation_3d.h"

namespace dw {
namespace builder3d {

/// What one check of a tetrahedron found.
enum class HaloVerdict {
  kCertified,  ///< no point of the cloud in its ball
  kConflict,   ///< points to insert were found: look again next pass, if it still exists
  kWaiting,    ///< its ball reaches cells not yet fetched: look again after the fetch
};

/// The passes' memory across calls: the clock of the last pass and the tetrahedra to look at again.
class HaloCertification {
 public:
  /// Runs passes over `kernel` until a pass inserts nothing. A pass calls
  /// check(tv, own, pass) -> HaloVerdict for each finite tetrahedron tv with a vertex in [first, last)
  /// (tv[own] is one of them; pass counts the passes of this call from 0), then insert() -> number of
  /// points inserted, which ends the call when 0. An unbuilt kernel has nothing to certify.
  template <class Check, class Insert>
  void run(const Triangulation3D& kernel, index_t first, index_t last, Check&& check, Insert&& insert) {
    if (!kernel.built()) return;
    for (std::size_t pass = 0;; ++pass) {
      still_.clear();
      const std::uint32_t now = kernel.clock();
      auto look = [&](std::size_t t) {
        const index_t* tv = kernel.tetVertices(t);
        if (tv[0] == Triangulation3D::kDead) return;
        int own = -1;
        for (unsigned k = 0; k < 4; ++k) {
          if (tv[k] == Triangulation3D::kInfinite) return;  // settled by the global hull
          if (tv[k] >= first && tv[k] < last) own = static_cast<int>(k);
        }
        if (own < 0) return;
        const HaloVerdict v = check(tv, static_cast<unsigned>(own), pass);
        if (v == HaloVerdict::kConflict) still_.push_back({t, {tv[0], tv[1], tv[2], tv[3]}});
        if (v == HaloVerdict::kWaiting) waiting_.push_back({t, {tv[0], tv[1], tv[2], tv[3]}});
      };
      const bool everything = last_pass_ == kNoPass;
      const std::size_t slots = kernel.tetSlots();
      for (std::size_t t = 0; t < slots; ++t)
        if (everything || kernel.birth(t) > last_pass_) look(t);
      for (const Remembered& p : pending_) {
        const index_t* tv = kernel.tetVertices(p.first);
        if (kernel.birth(p.first) <= last_pass_ && std::equal(tv, tv + 4, p.second.begin())) look(p.first);
      }
      last_pass_ = now;
      pending_.swap(still_);
      if (insert() == 0) return;
      ++rounds_;
    }
  }

  /// The tetrahedra that waited for cells join the next pass (call after the fetch).
  void recheckWaiting() {
    pending_.insert(pending_.end(), waiting_.begin(), waiting_.end());
    waiting_.clear();
  }

  /// Passes that inserted points, over all calls.
  std::size_t rounds() const { return rounds_; }

 private:
  /// A tetrahedron slot and the vertices it held: the slot may be reused by another tetrahedron.
  using Remembered = std::pair<std::size_t, std::array<index_t, 4>>;
  static constexpr std::uint32_t kNoPass = 0xFFFFFFFFu;
  std::uint32_t last_pass_ = kNoPass;  // kernel clock at the last pass
  std::vector<Remembered> pending_, still_, waiting_;
  std::size_t rounds_ = 0;
};

}  // namespace builder3d
}  // namespace dw
