// The tetrahedral mesh's slots and structural validation. See tetra_mesh.h for the representation.
#include "core/builder3d/tetra_mesh.h"

#include <algorithm>
#include <array>
#include <string>

namespace dw {
namespace builder3d {

void TetraMesh::clear() {
  tet_v.clear();
  tet_n.clear();
  mark.clear();
  free.clear();
  birth.clear();
}

void TetraMesh::reserveSlots(std::size_t slots) {
  tet_v.reserve(4 * slots);
  // A quarter more address space for the adjacency: its storage becomes the edge extraction's lists
  // (listByRange's donor), which hold each tetrahedron once per range of its three smallest ids, ~1.1
  // to 1.15 times the tetrahedra (the infinite ones included: one per hull facet, few). Without it the
  // dragon's lists (8.2 per point) outgrew the 8 slots per point reserved and went into a new array,
  // 14k pages to map afresh. Untouched pages cost address space only.
  tet_n.reserve(4 * (slots + slots / 4));
  mark.reserve(slots);
}

void TetraMesh::ensureFreeSlots(std::size_t count, std::uint32_t clock) {
  while (free.size() < count) {
    // Grown kNewTetBatch slots at a time, which go on the free list lowest on top (so they are taken
    // in order): one slot at a time, the three arrays' resizes cost 3 % of a build's instructions.
    constexpr std::size_t kNewTetBatch = 64;
    const std::size_t t = slots();
    if (t + kNewTetBatch > (std::size_t(1) << 30))
      throw Error("dw::Triangulation3D: more than 2^30 tetrahedra (neighbour codes are 32-bit)");
    // Grow by a quarter rather than doubling: the arrays are most of the peak memory.
    if (4 * (t + kNewTetBatch) > tet_v.capacity()) reserveSlots(t + t / 4 + kNewTetBatch);
    resizeSlots(t + kNewTetBatch);
    if (track_births) birth.resize(t + kNewTetBatch, clock);
    for (std::size_t k = t + kNewTetBatch; k-- > t;) free.push_back(static_cast<index_t>(k));
  }
}

void TetraMesh::sizeSlotsUnwritten(std::size_t slots) {
  tet_v.resize(4 * slots);
  tet_n.resize(4 * slots);
  mark.resize(slots);
}

void TetraMesh::resizeSlots(std::size_t slots) {
  const std::size_t old = this->slots();
  sizeSlotsUnwritten(slots);
  // No other thread runs here (the sequential insertion, or between passes): plain fills, which the
  // compiler vectorises; slot by slot through clearSlot's atomic stores they were ~230 instructions
  // per inserted point.
  if (slots > old) {
    std::fill(tet_v.begin() + 4 * old, tet_v.end(), kDead);
    std::fill(tet_n.begin() + 4 * old, tet_n.end(), 0u);
    std::fill(mark.begin() + old, mark.end(), Mark::kUnknown);
  }
}

void TetraMesh::clearSlot(std::size_t t) {
  for (unsigned j = 0; j < 4; ++j) {  // atomic like every write another thread may read
    store<true>(tet_v[4 * t + j], kDead);
    store<true>(tet_n[4 * t + j], 0);
  }
  mark[t] = Mark::kUnknown;
}

std::vector<index_t> TetraMesh::hullVertices() const {
  std::vector<index_t> out;
  const std::size_t nt = slots();
  for (std::size_t t = 0; t < nt; ++t) {
    const index_t* tv = &tet_v[4 * t];
    if (tv[0] == kDead) continue;
    if (tv[0] != kInfinite && tv[1] != kInfinite && tv[2] != kInfinite && tv[3] != kInfinite) continue;
    for (unsigned k = 0; k < 4; ++k)
      if (tv[k] != kInfinite) out.push_back(tv[k]);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

void TetraMesh::validate(std::size_t num_points, std::size_t num_inserted) const {
  const std::size_t nt = slots();
  auto fail = [](index_t t, const std::string& what) {
    throw Error("dw::Triangulation3D::validate: tetrahedron " + std::to_string(t) + ": " + what);
  };
  std::vector<char> present(num_points, 0);
  std::size_t live = 0;
  for (index_t t = 0; t < nt; ++t) {
    const index_t* tv = &tet_v[4 * std::size_t(t)];
    if (tv[0] == kDead) continue;
    ++live;
    unsigned count_inf = 0;
    for (unsigned k = 0; k < 4; ++k) {
      if (tv[k] == kInfinite)
        ++count_inf;
      else if (tv[k] >= num_points)
        fail(t, "vertex id out of range");
      else
        present[tv[k]] = 1;
    }
    if (count_inf > 1) fail(t, "more than one infinite vertex");
    for (unsigned f = 0; f < 4; ++f) {
      const std::uint32_t nc = tet_n[4 * std::size_t(t) + f];
      const index_t n = nc >> 2;
      if (n >= nt || tet_v[4 * std::size_t(n)] == kDead) fail(t, "neighbour is not a live tetrahedron");
      if (tet_n[nc] != 4 * t + f) fail(t, "adjacency is not symmetric");
      std::array<index_t, 3> a{}, b{};
      unsigned ia = 0, ib = 0;
      for (unsigned k = 0; k < 4; ++k) {
        if (k != f) a[ia++] = tv[k];
        if (k != (nc & 3u)) b[ib++] = tet_v[4 * std::size_t(n) + k];
      }
      std::sort(a.begin(), a.end());
      std::sort(b.begin(), b.end());
      if (a != b) fail(t, "neighbours do not share the face");
    }
  }
  std::size_t missing = 0;
  for (char c : present) missing += c == 0;
  if (num_points - missing != num_inserted)
    throw Error("dw::Triangulation3D::validate: " + std::to_string(num_points - missing) +
                " vertices in tetrahedra, " + std::to_string(num_inserted) + " inserted");
  if (live != numLive()) throw Error("dw::Triangulation3D::validate: free list out of sync");
}

std::size_t TetraMesh::memoryBytes() const {
  return (tet_v.capacity() + tet_n.capacity() + birth.capacity() + free.capacity()) * sizeof(std::uint32_t) +
         mark.capacity();
}

}  // namespace builder3d
}  // namespace dw
