// Triangulation3D::remove: deletion of one vertex (sliding-window maps). It reads: find the star ->
// its hole (boundary faces and link) -> fill the hole from DT(link), or close a flat link by hull
// facets -> check the fill matches the hole -> write it.
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

#include "core/builder3d/triangulation_3d.h"
#include "core/geometry/affine_span.h"

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

constexpr const char* kWhere = "dw::Triangulation3D::remove: ";
constexpr index_t kInfinite = TetraMesh::kInfinite;
constexpr index_t kDead = TetraMesh::kDead;
using Mark = TetraMesh::Mark;

bool hasVertex(const index_t* tv, index_t v) {
  return tv[0] == v || tv[1] == v || tv[2] == v || tv[3] == v;
}

// The star: tetrahedra around v, connected through the faces that contain v (marks left clear).
std::vector<index_t> starOf(TetraMesh& mesh, index_t v, index_t root) {
  std::vector<index_t> star{root};
  mesh.mark[root] = Mark::kCavity;
  for (std::size_t k = 0; k < star.size(); ++k) {
    const index_t c = star[k];
    for (unsigned f = 0; f < 4; ++f) {
      if (mesh.tet_v[4 * std::size_t(c) + f] == v) continue;
      const index_t n = mesh.tet_n[4 * std::size_t(c) + f] >> 2;
      if (mesh.mark[n] == Mark::kUnknown) {
        mesh.mark[n] = Mark::kCavity;
        star.push_back(n);
      }
    }
  }
  for (index_t c : star) mesh.mark[c] = Mark::kUnknown;
  return star;
}

// The hole the star leaves: its boundary faces (opposite v, oriented with v on their positive side,
// each with the neighbour code of the tetrahedron outside) and its link's finite vertices.
struct Hole {
  std::vector<FaceRecord> faces;
  std::vector<index_t> link;  // sorted, each once
  bool on_hull = false;       // the star has infinite tetrahedra
};

Hole holeOf(const TetraMesh& mesh, const std::vector<index_t>& star, index_t v) {
  Hole hole;
  hole.faces.reserve(star.size());
  hole.link.reserve(3 * star.size());
  for (index_t c : star) {
    const index_t* tv = mesh.vertices(c);
    unsigned iv = 4;
    for (unsigned k = 0; k < 4; ++k) {
      if (tv[k] == v)
        iv = k;
      else if (tv[k] == kInfinite)
        hole.on_hull = true;
      else
        hole.link.push_back(tv[k]);
    }
    if (iv == 4) throw Error(std::string(kWhere) + "corrupted star (a tetrahedron without the vertex)");
    hole.faces.push_back({faceOf(tv, iv), mesh.tet_n[4 * std::size_t(c) + iv]});
  }
  std::sort(hole.link.begin(), hole.link.end());
  hole.link.erase(std::unique(hole.link.begin(), hole.link.end()), hole.link.end());
  return hole;
}

// The new tetrahedra (vertex quadruples in the mesh's orientation convention) and their neighbours:
// an outer neighbour code, or kLocal | (new tetrahedron * 4 + face). `hole_used` counts how often
// each boundary face was matched.
constexpr std::uint32_t kLocal = 0x80000000u;
struct Fill {
  std::vector<index_t> v;
  std::vector<std::uint32_t> neighbour;
  std::vector<std::uint32_t> hole_used;
  std::size_t size() const { return v.size() / 4; }
};

// DT(link) with the same ids, in a reused scratch triangulation (steady-state removal then allocates
// no tetrahedron arrays). The fill is one face-connected region (the star is a ball), so it is
// found from one seed, the tetrahedron of DT(link) on the inner side of one boundary face, by a
// flood that does not cross boundary faces; DT(link)'s own adjacency links the fill inside.
void fillFromLink(const Vec3f* points, std::size_t num_points, const Hole& hole, const FaceTable& hole_index,
                  Fill& fill) {
  thread_local Triangulation3D small;
  small.setPoints(points, num_points);
  small.build(hole.link.data(), hole.link.size());
  const TetraMesh& mesh = small.mesh();
  const std::size_t small_slots = mesh.slots();
  std::vector<std::uint32_t> local(small_slots, kLocal);  // small slot -> new tetrahedron
  std::vector<index_t> queue;
  for (index_t s = 0; s < small_slots && queue.empty(); ++s) {
    const index_t* sv = mesh.vertices(s);
    if (sv[0] == kDead) continue;
    for (unsigned j = 0; j < 4; ++j)
      if (faceOf(sv, j) == hole.faces[0].face) {
        local[s] = 0;
        queue.push_back(s);
        break;
      }
  }
  if (queue.empty()) throw Error(std::string(kWhere) + "internal: DT(link) misses a boundary face");
  for (std::size_t k = 0; k < queue.size(); ++k) {
    const index_t s = queue[k];
    const index_t* sv = mesh.vertices(s);
    if (!hole.on_hull &&
        (sv[0] == kInfinite || sv[1] == kInfinite || sv[2] == kInfinite || sv[3] == kInfinite))
      throw Error(std::string(kWhere) + "internal: the fill of an interior vertex reached the hull");
    fill.v.insert(fill.v.end(), sv, sv + 4);
    for (unsigned j = 0; j < 4; ++j) {
      const std::size_t h = hole_index.find(faceOf(sv, j));
      if (h != FaceTable::kNone) {
        ++fill.hole_used[h];
        fill.neighbour.push_back(hole.faces[h].code);
        continue;
      }
      const std::uint32_t nc = mesh.tet_n[4 * std::size_t(s) + j];
      if (local[nc >> 2] == kLocal) {
        local[nc >> 2] = static_cast<std::uint32_t>(queue.size());
        queue.push_back(nc >> 2);
      }
      fill.neighbour.push_back(kLocal | (4 * local[nc >> 2] + (nc & 3u)));
    }
  }
}

// A flat link (a hull vertex's): each finite boundary face becomes a hull facet, closed by one
// infinite tetrahedron; those are linked by matching each inner face with its reverse.
void fillFlatLink(const TetraMesh& mesh, index_t v, const Hole& hole, const FaceTable& hole_index,
                  Fill& fill) {
  // An interior vertex's link surrounds it, so it always spans 3D; a flat one means corruption.
  if (!hole.on_hull) throw Error(std::string(kWhere) + "internal: the link of an interior vertex is flat");
  for (const FaceRecord& h : hole.faces) {
    if (h.face.c == kInfinite || h.face.b == kInfinite || h.face.a == kInfinite) continue;
    const index_t* ov = mesh.vertices(h.code >> 2);
    if (ov[0] == kInfinite || ov[1] == kInfinite || ov[2] == kInfinite || ov[3] == kInfinite)
      throw Error(std::string(kWhere) + "removing " + vertexName(v) +
                  " would leave a coplanar set, which has no 3D triangulation");
    fill.v.insert(fill.v.end(), {h.face.a, h.face.b, h.face.c, kInfinite});  // face 3 is h.face, v's side
  }
  // Link them: a face is either a boundary face (same orientation as seen from v) or meets exactly
  // one other new face in the opposite orientation.
  const std::size_t m = fill.size();
  fill.neighbour.assign(4 * m, 0);
  std::vector<FaceRecord> inner;
  for (std::size_t k = 0; k < m; ++k)
    for (unsigned j = 0; j < 4; ++j) {
      const OrientedFace f = faceOf(&fill.v[4 * k], j);
      const std::size_t h = hole_index.find(f);
      if (h != FaceTable::kNone) {
        ++fill.hole_used[h];
        fill.neighbour[4 * k + j] = hole.faces[h].code;
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
    fill.neighbour[r.code] = kLocal | inner[o].code;
  }
}

// Writes the fill: the star's slots first, fresh ones after; the star's leftover slots are recycled.
// Returns the slots written.
std::vector<index_t> writeFill(TetraMesh& mesh, const std::vector<index_t>& star, const Fill& fill,
                               std::uint32_t clock) {
  const std::size_t m = fill.size();
  std::vector<index_t> slot(m);
  std::size_t taken = 0;
  try {
    for (; taken < m; ++taken) slot[taken] = taken < star.size() ? star[taken] : mesh.newTet(clock);
  } catch (...) {
    for (std::size_t k = star.size(); k < taken; ++k) {
      mesh.tet_v[4 * std::size_t(slot[k])] = kDead;
      mesh.free.push_back(slot[k]);
    }
    throw;
  }
  for (std::size_t k = 0; k < m; ++k)
    std::copy(&fill.v[4 * k], &fill.v[4 * k] + 4, &mesh.tet_v[4 * std::size_t(slot[k])]);
  for (std::size_t k = 0; k < m; ++k)
    for (unsigned j = 0; j < 4; ++j) {
      const std::uint32_t code = 4 * slot[k] + j;
      const std::uint32_t n = fill.neighbour[4 * k + j];
      if (n & kLocal) {
        const std::uint32_t local = n & ~kLocal;
        mesh.tet_n[code] = 4 * slot[local >> 2] + (local & 3u);
      } else {
        mesh.tet_n[code] = n;
        mesh.tet_n[n] = code;
      }
    }
  for (std::size_t k = m; k < star.size(); ++k) {
    mesh.tet_v[4 * std::size_t(star[k])] = kDead;
    mesh.free.push_back(star[k]);
  }
  return slot;
}

}  // namespace

index_t Triangulation3D::starRoot(index_t v) {
  // The visibility walk towards v's own point ends in a tetrahedron whose closure holds the point,
  // which in a valid triangulation has v as a vertex if v is present. If it does not (v absent, or its
  // point repeats another vertex), scan: this error path may cost O(n).
  const std::size_t nt_slots = mesh_.slots();
  try {
    const index_t t = locate(v, last_tet_);
    if (t < nt_slots && !mesh_.isDead(t) && hasVertex(mesh_.vertices(t), v)) return t;
  } catch (const Error&) {
    // A walk that gave up is not evidence of absence: the scan below decides.
  }
  for (index_t t = 0; t < nt_slots; ++t)
    if (!mesh_.isDead(t) && hasVertex(mesh_.vertices(t), v)) return t;
  throw Error(std::string(kWhere) + vertexName(v) + " is not in the triangulation");
}

index_t Triangulation3D::tetOf(index_t v, index_t hint) {
  if (!built()) throw Error("dw::Triangulation3D::tetOf: build() first");
  if (v >= num_points_) throw Error("dw::Triangulation3D::tetOf: " + vertexName(v) + " is out of range");
  const std::size_t nt_slots = mesh_.slots();
  const index_t kept = v < vertex_tet_.size() ? vertex_tet_[v] : kNoVertexTet;
  index_t t = kept;
  if (!(kept < nt_slots && !mesh_.isDead(kept) && hasVertex(mesh_.vertices(kept), v))) {
    if (hint < nt_slots && !mesh_.isDead(hint)) last_tet_ = hint;
    t = starRoot(v);
    if (v < vertex_tet_.size()) vertex_tet_[v] = t;  // the next lookup of v needs no walk
  }
  last_tet_ = t;  // a removal of v that follows finds its star at once
  return t;
}

void Triangulation3D::remove(index_t v) {
  if (!built()) throw Error(std::string(kWhere) + "build() first");
  if (v >= num_points_) throw Error(std::string(kWhere) + vertexName(v) + " is out of range");
  const index_t root = starRoot(v);
  if (num_inserted_ <= 4)
    throw Error(std::string(kWhere) + "removing " + vertexName(v) + " would leave " +
                std::to_string(num_inserted_ - 1) + " vertices; a 3D triangulation needs at least 4");
  const std::vector<index_t> star = starOf(mesh_, v, root);
  const Hole hole = holeOf(mesh_, star, v);
  const FaceTable hole_index(hole.faces);
  if (hole_index.hasRepeats()) throw Error(std::string(kWhere) + "corrupted star (a face twice)");

  Fill fill;
  fill.hole_used.assign(hole.faces.size(), 0);
  if (spans3D(points_, hole.link.data(), hole.link.size()))
    fillFromLink(points_, num_points_, hole, hole_index, fill);
  else
    fillFlatLink(mesh_, v, hole, hole_index, fill);
  for (std::uint32_t used : fill.hole_used)
    if (used != 1)
      throw Error(std::string(kWhere) + "internal: the fill does not match the hole of " + vertexName(v));

  const std::vector<index_t> slot = writeFill(mesh_, star, fill, clock());
  if (mesh_.track_births)
    for (index_t s : slot) mesh_.birth[s] = static_cast<std::uint32_t>(num_inserted_ - 1);
  last_tet_ = slot[0];
  --num_inserted_;
  ++num_removed_;
}

}  // namespace builder3d
}  // namespace dw
