// Triangulation3D::remove: deletion of one vertex (issue 8, sliding-window maps).
//
// Method. Removing v from the perturbed Delaunay triangulation DT(P) changes only v's star: every other
// tetrahedron keeps an empty (perturbed) sphere when a point leaves. The hole left by the star is filled
// by DT(P \ v) restricted to the hole. Each of those tetrahedra has only link vertices (the hole holds no
// other point) and a sphere empty of all of P \ v, so it is also a tetrahedron of DT(link), the
// triangulation of the link vertices alone. The perturbation is keyed on the vertex ids, so building
// DT(link) with the same ids over the same point array gives exactly those tetrahedra: the fill is the
// part of DT(link) on the inner side of the hole's boundary faces. With the infinite vertex treated as
// a vertex like any other (both kernels close the hull the same way), the same holds when v is on the
// hull: the infinite tetrahedra of DT(link) inside the hole become the new hull facets.
//
// Degenerate link. A hull vertex whose finite link is coplanar (e.g. a point above a flat roof) has no
// 3D DT(link). Then the finite part of the hole lies outside conv(P \ v): its boundary faces become hull
// facets, each closed by one infinite tetrahedron. If a boundary face has an infinite tetrahedron behind
// it as well, the remaining points are coplanar and no 3D triangulation exists: dw::Error.
//
// Everything is computed and checked (every boundary face matched exactly once; in the flat case every
// inner face paired with its reverse) before the first write, so an error leaves the structure as it was.
#include <algorithm>
#include <string>
#include <vector>

#include "core/geometry/affine_span.h"
#include "triangulation_3d.h"

namespace dw {
namespace builder3d {
namespace {

// Face i of a positively oriented tetrahedron (v0, v1, v2, v3), listed so that v_i lies on its
// positive side (orient3d(face, v_i) > 0; for an infinite tetrahedron the same holds combinatorially).
// Two tetrahedra sharing a face therefore list it in opposite orientations, which is what lets faces
// of different triangulations be matched by their vertex ids alone.
constexpr unsigned kFaceOf[4][3] = {{1, 3, 2}, {0, 2, 3}, {0, 3, 1}, {0, 1, 2}};

// An oriented triangle, rotated so that its smallest id comes first (a rotation keeps the orientation).
struct OrientedFace {
  index_t a, b, c;
  bool operator==(const OrientedFace& o) const { return a == o.a && b == o.b && c == o.c; }
};

OrientedFace canonical(index_t a, index_t b, index_t c) {
  if (a < b && a < c) return {a, b, c};
  if (b < c) return {b, c, a};
  return {c, a, b};
}

OrientedFace faceOf(const index_t* tv, unsigned i) {
  return canonical(tv[kFaceOf[i][0]], tv[kFaceOf[i][1]], tv[kFaceOf[i][2]]);
}

OrientedFace reversed(const OrientedFace& f) {
  return canonical(f.a, f.c, f.b);
}

struct FaceRecord {
  OrientedFace face;
  std::uint32_t code;  // hole face: outer neighbour code; new face: local tetrahedron * 4 + face
};

// Open-addressing index of a few oriented faces (a hole has ~30 on volumetric input; a binary search
// over them was the removal's hottest line).
class FaceTable {
 public:
  static constexpr std::size_t kNone = ~std::size_t(0);
  explicit FaceTable(const std::vector<FaceRecord>& records) : records_(records) {
    std::size_t size = 16;
    while (size < 2 * records.size()) size *= 2;
    mask_ = size - 1;
    slots_.assign(size, kEmpty);
    for (std::size_t k = 0; k < records.size(); ++k) {
      std::size_t s = hash(records[k].face) & mask_;
      while (slots_[s] != kEmpty) {
        if (records_[slots_[s]].face == records[k].face) repeats_ = true;
        s = (s + 1) & mask_;
      }
      slots_[s] = static_cast<std::uint32_t>(k);
    }
  }
  std::size_t find(const OrientedFace& f) const {
    for (std::size_t s = hash(f) & mask_;; s = (s + 1) & mask_) {
      if (slots_[s] == kEmpty) return kNone;
      if (records_[slots_[s]].face == f) return slots_[s];
    }
  }
  bool hasRepeats() const { return repeats_; }

 private:
  static constexpr std::uint32_t kEmpty = ~std::uint32_t(0);
  static std::size_t hash(const OrientedFace& f) {
    const std::uint64_t h = (std::uint64_t(f.a) * 0x9E3779B97F4A7C15ull) ^
                            (std::uint64_t(f.b) * 0xC2B2AE3D27D4EB4Full) ^
                            (std::uint64_t(f.c) * 0x165667B19E3779F9ull);
    return static_cast<std::size_t>(h ^ (h >> 32));
  }
  const std::vector<FaceRecord>& records_;
  std::vector<std::uint32_t> slots_;
  std::size_t mask_ = 0;
  bool repeats_ = false;
};

std::string vertexName(index_t v) {
  return "vertex " + std::to_string(v);
}

}  // namespace

void Triangulation3D::remove(index_t v) {
  static const char* const kWhere = "dw::Triangulation3D::remove: ";
  if (!built()) throw Error(std::string(kWhere) + "build() first");
  if (v >= num_points_) throw Error(std::string(kWhere) + vertexName(v) + " is out of range");
  const std::size_t nt_slots = tet_v_.size() / 4;
  auto contains = [&](index_t t) {
    const index_t* tv = &tet_v_[4 * std::size_t(t)];
    return tv[0] == v || tv[1] == v || tv[2] == v || tv[3] == v;
  };

  // A tetrahedron of v's star. The visibility walk towards v's own point ends in a tetrahedron whose
  // closure holds the point, which in a valid triangulation has v as a vertex if v is present. If it
  // does not (v absent, or its point repeats another vertex), scan: this error path may cost O(n).
  index_t root = kInvalidIndex;
  try {
    const index_t t = locate(v, last_tet_);
    if (t < nt_slots && tet_v_[4 * std::size_t(t)] != kDead && contains(t)) root = t;
  } catch (const Error&) {
    // A walk that gave up is not evidence of absence: the scan below decides.
  }
  if (root == kInvalidIndex) {
    for (index_t t = 0; t < nt_slots && root == kInvalidIndex; ++t)
      if (tet_v_[4 * std::size_t(t)] != kDead && contains(t)) root = t;
    if (root == kInvalidIndex)
      throw Error(std::string(kWhere) + vertexName(v) + " is not in the triangulation");
  }
  if (num_inserted_ <= 4)
    throw Error(std::string(kWhere) + "removing " + vertexName(v) + " would leave " +
                std::to_string(num_inserted_ - 1) + " vertices; a 3D triangulation needs at least 4");

  // The star: tetrahedra around v, connected through the faces that contain v. The hole's boundary
  // faces are the faces opposite v, oriented with v on their positive side, each with the neighbour
  // code of the tetrahedron outside.
  std::vector<index_t> star{root};
  mark_[root] = Mark::kCavity;
  for (std::size_t k = 0; k < star.size(); ++k) {
    const index_t c = star[k];
    for (unsigned f = 0; f < 4; ++f) {
      if (tet_v_[4 * std::size_t(c) + f] == v) continue;
      const index_t n = tet_n_[4 * std::size_t(c) + f] >> 2;
      if (mark_[n] == Mark::kUnknown) {
        mark_[n] = Mark::kCavity;
        star.push_back(n);
      }
    }
  }
  for (index_t c : star) mark_[c] = Mark::kUnknown;

  std::vector<FaceRecord> hole;
  hole.reserve(star.size());
  std::vector<index_t> link;
  link.reserve(3 * star.size());
  bool on_hull = false;
  for (index_t c : star) {
    const index_t* tv = &tet_v_[4 * std::size_t(c)];
    unsigned iv = 4;
    for (unsigned k = 0; k < 4; ++k) {
      if (tv[k] == v)
        iv = k;
      else if (tv[k] == kInfinite)
        on_hull = true;
      else
        link.push_back(tv[k]);
    }
    if (iv == 4) throw Error(std::string(kWhere) + "corrupted star (a tetrahedron without the vertex)");
    hole.push_back({faceOf(tv, iv), tet_n_[4 * std::size_t(c) + iv]});
  }
  const FaceTable hole_index(hole);
  if (hole_index.hasRepeats()) throw Error(std::string(kWhere) + "corrupted star (a face twice)");
  std::sort(link.begin(), link.end());
  link.erase(std::unique(link.begin(), link.end()), link.end());

  // The new tetrahedra (vertex quadruples in the kernel's orientation convention) and their
  // neighbours: an outer neighbour code, or kLocal | (new tetrahedron * 4 + face).
  constexpr std::uint32_t kLocal = 0x80000000u;
  std::vector<index_t> fill;
  std::vector<std::uint32_t> neighbour;
  std::vector<std::uint32_t> hole_used(hole.size(), 0);
  if (spans3D(points_, link.data(), link.size())) {
    // DT(link) with the same ids, in a reused scratch kernel (steady-state removal then allocates
    // no tetrahedron arrays). The fill is one face-connected region (the star is a ball), so it is
    // found from one seed, the tetrahedron of DT(link) on the inner side of one boundary face, by a
    // flood that does not cross boundary faces; DT(link)'s own adjacency links the fill inside.
    thread_local Triangulation3D small;
    small.setPoints(points_, num_points_);
    small.build(link.data(), link.size());
    const std::size_t small_slots = small.tet_v_.size() / 4;
    std::vector<std::uint32_t> local(small_slots, kLocal);  // small slot -> new tetrahedron
    std::vector<index_t> queue;
    for (index_t s = 0; s < small_slots && queue.empty(); ++s) {
      const index_t* sv = &small.tet_v_[4 * std::size_t(s)];
      if (sv[0] == kDead) continue;
      for (unsigned j = 0; j < 4; ++j)
        if (faceOf(sv, j) == hole[0].face) {
          local[s] = 0;
          queue.push_back(s);
          break;
        }
    }
    if (queue.empty()) throw Error(std::string(kWhere) + "internal: DT(link) misses a boundary face");
    for (std::size_t k = 0; k < queue.size(); ++k) {
      const index_t s = queue[k];
      const index_t* sv = &small.tet_v_[4 * std::size_t(s)];
      if (!on_hull && (sv[0] == kInfinite || sv[1] == kInfinite || sv[2] == kInfinite || sv[3] == kInfinite))
        throw Error(std::string(kWhere) + "internal: the fill of an interior vertex reached the hull");
      fill.insert(fill.end(), sv, sv + 4);
      for (unsigned j = 0; j < 4; ++j) {
        const std::size_t h = hole_index.find(faceOf(sv, j));
        if (h != FaceTable::kNone) {
          ++hole_used[h];
          neighbour.push_back(hole[h].code);
          continue;
        }
        const std::uint32_t nc = small.tet_n_[4 * std::size_t(s) + j];
        if (local[nc >> 2] == kLocal) {
          local[nc >> 2] = static_cast<std::uint32_t>(queue.size());
          queue.push_back(nc >> 2);
        }
        neighbour.push_back(kLocal | (4 * local[nc >> 2] + (nc & 3u)));
      }
    }
  } else {
    // An interior vertex's link surrounds it, so it always spans 3D; a flat one means corruption.
    if (!on_hull) throw Error(std::string(kWhere) + "internal: the link of an interior vertex is flat");
    for (const FaceRecord& h : hole) {
      if (h.face.c == kInfinite || h.face.b == kInfinite || h.face.a == kInfinite) continue;
      const index_t* ov = &tet_v_[4 * std::size_t(h.code >> 2)];
      if (ov[0] == kInfinite || ov[1] == kInfinite || ov[2] == kInfinite || ov[3] == kInfinite)
        throw Error(std::string(kWhere) + "removing " + vertexName(v) +
                    " would leave a coplanar set, which has no 3D triangulation");
      fill.insert(fill.end(), {h.face.a, h.face.b, h.face.c, kInfinite});  // face 3 is h.face, v's side
    }
    // Link them: a face is either a boundary face (same orientation as seen from v) or meets exactly
    // one other new face in the opposite orientation.
    const std::size_t m = fill.size() / 4;
    neighbour.assign(4 * m, 0);
    std::vector<FaceRecord> inner;
    for (std::size_t k = 0; k < m; ++k)
      for (unsigned j = 0; j < 4; ++j) {
        const OrientedFace f = faceOf(&fill[4 * k], j);
        const std::size_t h = hole_index.find(f);
        if (h != FaceTable::kNone) {
          ++hole_used[h];
          neighbour[4 * k + j] = hole[h].code;
        } else {
          inner.push_back({f, static_cast<std::uint32_t>(4 * k + j)});
        }
      }
    const FaceTable inner_index(inner);
    if (inner_index.hasRepeats())
      throw Error(std::string(kWhere) + "internal: an inner face of the fill repeats");
    for (const FaceRecord& r : inner) {
      const std::size_t o = inner_index.find(reversed(r.face));
      if (o == FaceTable::kNone)
        throw Error(std::string(kWhere) + "internal: an inner face of the fill is open");
      neighbour[r.code] = kLocal | inner[o].code;
    }
  }
  for (std::uint32_t used : hole_used)
    if (used != 1)
      throw Error(std::string(kWhere) + "internal: the fill does not match the hole of " + vertexName(v));
  const std::size_t m = fill.size() / 4;

  // Write: the star's slots first, fresh ones after; the star's leftover slots are recycled.
  std::vector<index_t> slot(m);
  std::size_t taken = 0;
  try {
    for (; taken < m; ++taken) slot[taken] = taken < star.size() ? star[taken] : newTet();
  } catch (...) {
    for (std::size_t k = star.size(); k < taken; ++k) {
      tet_v_[4 * std::size_t(slot[k])] = kDead;
      free_.push_back(slot[k]);
    }
    throw;
  }
  for (std::size_t k = 0; k < m; ++k)
    std::copy(&fill[4 * k], &fill[4 * k] + 4, &tet_v_[4 * std::size_t(slot[k])]);
  for (std::size_t k = 0; k < m; ++k)
    for (unsigned j = 0; j < 4; ++j) {
      const std::uint32_t code = 4 * slot[k] + j;
      const std::uint32_t n = neighbour[4 * k + j];
      if (n & kLocal) {
        const std::uint32_t local = n & ~kLocal;
        tet_n_[code] = 4 * slot[local >> 2] + (local & 3u);
      } else {
        tet_n_[code] = n;
        tet_n_[n] = code;
      }
    }
  for (std::size_t k = m; k < star.size(); ++k) {
    tet_v_[4 * std::size_t(star[k])] = kDead;
    free_.push_back(star[k]);
  }
  if (track_births_)
    for (std::size_t k = 0; k < m; ++k) birth_[slot[k]] = static_cast<std::uint32_t>(num_inserted_ - 1);
  last_tet_ = slot[0];
  --num_inserted_;
  ++num_removed_;
}

}  // namespace builder3d
}  // namespace dw
