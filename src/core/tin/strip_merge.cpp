/// \file strip_merge.cpp
/// \brief Band re-triangulation merge of two adjacent strip groups (see strip_merge.h for the proof).
#include "strip_merge.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "bowyer_watson.h"
#include "circumdisk_side.h"

namespace dw {
namespace tin {
namespace detail {
namespace {

[[noreturn]] void mergeError(const std::string& what) {
  throw Error("dw::tin: strip merge consistency failure (" + what + "); please report this input");
}

/// True only if the closed circumdisk of real triangle t provably lies strictly on the given side of
/// the seam (left: u < seam; right: u > seam). Conservative: an ill-conditioned triangle is "unsure".
bool provablySure(const PointSet& ps, const index_t* tv, index_t t, int axis, double seam, bool left) {
  const index_t a = tv[3 * t] & ~kMark, b = tv[3 * t + 1], c = tv[3 * t + 2];
  return circumdiskProvablyOnSide(ps.x(a), ps.y(a), ps.x(b), ps.y(b), ps.x(c), ps.y(c), axis, seam, left);
}

/// Marks and returns the unsure triangles of a group: the ghosts and every triangle, connected to them
/// through unsure triangles, whose circle may reach across the seam.
std::vector<index_t> collectBand(const PointSet& ps, index_t* tv, const index_t* tn, const Group& g, int axis,
                                 double seam, bool left) {
  std::vector<index_t> band;
  if (!g.has_triangles) return band;
  tv[3 * g.ghost] |= kMark;
  band.push_back(g.ghost);
  // The band's triangles lie scattered over the strips' slot ranges (created in BRIO rounds), so the
  // search waits on memory. The queue shows what comes next: the adjacency of a queued triangle is
  // fetched when it is queued, its neighbours' vertices four steps ahead, their coordinates two ahead.
  auto prefetch = [](const void* p) {
#if defined(__GNUC__)
    __builtin_prefetch(p);
#else
    (void)p;
#endif
  };
  for (std::size_t head = 0; head < band.size(); ++head) {
    if (head + 4 < band.size())
      for (index_t i = 0; i < 3; ++i) prefetch(tv + 3 * (tn[3 * band[head + 4] + i] / 3));
    if (head + 2 < band.size())
      for (index_t i = 0; i < 3; ++i) {
        const index_t* v = tv + 3 * (tn[3 * band[head + 2] + i] / 3);
        for (index_t j = 0; j < 3; ++j)
          if ((v[j] & ~kMark) < kGhost) prefetch(ps.at(v[j] & ~kMark));
      }
    const index_t t = band[head];
    for (index_t i = 0; i < 3; ++i) {
      const index_t n = tn[3 * t + i] / 3;
      if (tv[3 * n] & kMark) continue;
      if (isGhost(tv, n) || !provablySure(ps, tv, n, axis, seam, left)) {
        tv[3 * n] |= kMark;
        band.push_back(n);
        prefetch(tn + 3 * std::size_t(n));
      }
    }
  }
  return band;
}

/// "No corner": corners 3t + i reach 3.6e9 at the 600M-point limit, past kDead (2^31 - 1).
constexpr index_t kNoCorner = ~index_t{0};

inline std::uint64_t edgeKey(index_t a, index_t b) {
  return (static_cast<std::uint64_t>(a) << 32) | b;
}

/// The walls as an open-addressing hash map from directed edge to the corner of the sure triangle
/// across it. Every edge of DT(V_U) is looked up once; with a sorted array and binary search those
/// lookups are half of the merge's own time.
class WallTable {
 public:
  explicit WallTable(std::size_t walls) {
    std::size_t cap = 16;
    while (cap < 2 * walls) cap *= 2;
    mask_ = cap - 1;
    keys_.assign(cap, kEmpty);
    corners_.resize(cap);
  }
  /// False if the edge is already present.
  bool insert(std::uint64_t key, index_t corner) {
    for (std::size_t h = slot(key);; h = (h + 1) & mask_) {
      if (keys_[h] == key) return false;
      if (keys_[h] == kEmpty) {
        keys_[h] = key;
        corners_[h] = corner;
        return true;
      }
    }
  }
  /// The corner stored for the edge, or kNoCorner.
  index_t find(std::uint64_t key) const {
    for (std::size_t h = slot(key);; h = (h + 1) & mask_) {
      if (keys_[h] == key) return corners_[h];
      if (keys_[h] == kEmpty) return kNoCorner;
    }
  }

 private:
  // Vertex positions are below kGhost, so no edge has this key.
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::size_t slot(std::uint64_t key) const {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> 32) & mask_;
  }
  std::size_t mask_ = 0;
  std::vector<std::uint64_t> keys_;
  std::vector<index_t> corners_;
};

/// The band vertices V_U (with the loose vertices of groups without triangles) and the band-to-sure
/// boundary edges E_b ("walls"), keyed by their direction as seen from the band side (the side on which
/// DT(V_U) will hold the same directed edge), each with the corner of the sure triangle across it.
struct BandBoundary {
  std::vector<index_t> verts;
  std::vector<std::pair<std::uint64_t, index_t>> walls;
};

BandBoundary bandBoundary(const index_t* tv, const index_t* tn, const Group& a, const Group& b,
                          const std::vector<index_t>& band_a, const std::vector<index_t>& band_b) {
  BandBoundary out;
  std::vector<index_t>& verts = out.verts;
  verts = a.loose;
  verts.insert(verts.end(), b.loose.begin(), b.loose.end());
  for (const std::vector<index_t>* band : {&band_a, &band_b})
    for (const index_t t : *band) {
      for (index_t i = 0; i < 3; ++i) {
        const index_t v = tv[3 * t + i] & ~kMark;
        if (v != kGhost) verts.push_back(v);
        const index_t nc = tn[3 * t + i];
        if (!(tv[3 * (nc / 3)] & kMark)) {
          const index_t u0 = tv[3 * t + next3(i)] & ~kMark, u1 = tv[3 * t + prev3(i)] & ~kMark;
          if (u0 == kGhost || u1 == kGhost) mergeError("ghost edge on the band boundary");
          out.walls.emplace_back(edgeKey(u0, u1), nc);
        }
      }
    }
  std::sort(verts.begin(), verts.end());
  verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
  return out;
}

/// The group of a and b before the band is stitched in: their strips and vertices, and their free
/// slots. The larger list is moved, not copied (the lists hold the strips' unused slots, two per
/// duplicate point, and grow towards the root of the reduce).
Group joinGroups(Group& a, Group& b) {
  Group out;
  out.strip_begin = a.strip_begin;
  out.strip_end = b.strip_end;
  out.num_vertices = a.num_vertices + b.num_vertices;
  if (a.free_slots.size() < b.free_slots.size()) std::swap(a.free_slots, b.free_slots);
  out.free_slots = std::move(a.free_slots);
  out.free_slots.insert(out.free_slots.end(), b.free_slots.begin(), b.free_slots.end());
  return out;
}

/// DT(V_U)'s triangles [0, used) classified: state 2 = band side of a wall (kept), 1 = covered by sure
/// triangles (dropped), 0 = kept, not on a wall; wall_of[corner] = the sure triangle's corner across it.
struct BandClassification {
  std::vector<unsigned char> state;
  std::vector<index_t> wall_of;
};

/// Each wall found in DT(V_U) marks its band side kept and seeds the covered region on its other side;
/// the covered region is then flooded without crossing a wall.
BandClassification classifyBand(const index_t* tv2, const index_t* tn2, index_t used,
                                const WallTable& wall_table, std::size_t walls) {
  BandClassification cls;
  std::vector<unsigned char>& state = cls.state;
  std::vector<index_t>& wall_of = cls.wall_of;
  state.assign(used, 0);
  wall_of.assign(3 * static_cast<std::size_t>(used), kNoCorner);
  std::vector<index_t> flood;
  std::size_t walls_found = 0;
  for (index_t t = 0; t < used; ++t) {
    for (index_t i = 0; i < 3; ++i) {
      const index_t u0 = tv2[3 * t + next3(i)], u1 = tv2[3 * t + prev3(i)];
      if (u0 == kGhost || u1 == kGhost) continue;
      const index_t corner = wall_table.find(edgeKey(u0, u1));
      if (corner == kNoCorner) continue;
      wall_of[3 * t + i] = corner;
      ++walls_found;
      if (state[t] == 1) mergeError("triangle on both sides of the band boundary");
      state[t] = 2;
      const index_t n = tn2[3 * t + i] / 3;
      if (isGhost(tv2, n)) mergeError("sure side of a wall is outside the hull");
      if (state[n] == 2) mergeError("wall between two band triangles");
      if (state[n] == 0) {
        state[n] = 1;
        flood.push_back(n);
      }
    }
  }
  if (walls_found != walls) mergeError("a band boundary edge is not Delaunay in the band");
  while (!flood.empty()) {
    const index_t t = flood.back();
    flood.pop_back();
    for (index_t i = 0; i < 3; ++i) {
      if (wall_of[3 * t + i] != kNoCorner) mergeError("covered triangle on a wall");
      const index_t nc = tn2[3 * t + i];
      if (wall_of[nc] != kNoCorner) continue;  // a wall seen from its sure side
      const index_t n = nc / 3;
      if (state[n] == 1) continue;
      if (state[n] == 2 || isGhost(tv2, n)) mergeError("covered region leaks into the band");
      state[n] = 1;
      flood.push_back(n);
    }
  }
  return cls;
}

/// The kept triangles of DT(V_U) copied into the arena and linked to each other and, across the walls,
/// to the sure triangles. They go into the band's own slots first (just read, so in cache, and near the
/// seam), then (Euler: two more than the band had) into free slots taken from the back of out's list;
/// band slots left over become free.
void stitchKept(index_t* tv, index_t* tn, const index_t* tv2, const index_t* tn2, index_t used,
                const BandClassification& cls, const std::vector<index_t>& band_a,
                const std::vector<index_t>& band_b, Group& out) {
  const std::vector<unsigned char>& state = cls.state;
  const std::vector<index_t>& wall_of = cls.wall_of;
  std::vector<index_t> slot(used, kDead);
  std::size_t next = 0;
  const std::size_t band_slots = band_a.size() + band_b.size();
  auto takeSlot = [&]() {
    const std::size_t k = next++;
    if (k < band_a.size()) return band_a[k];
    if (k < band_slots) return band_b[k - band_a.size()];
    const index_t f = out.free_slots.back();
    out.free_slots.pop_back();
    return f;
  };
  for (index_t t = 0; t < used; ++t)
    if (state[t] != 1) slot[t] = takeSlot();
  for (index_t t = 0; t < used; ++t) {
    if (state[t] == 1) continue;
    const index_t s = slot[t];
    for (index_t i = 0; i < 3; ++i) tv[3 * s + i] = tv2[3 * t + i];
    if (isGhost(tv2, t)) out.ghost = s;
    for (index_t i = 0; i < 3; ++i) {
      const index_t w = wall_of[3 * t + i];
      if (w != kNoCorner) {
        tn[3 * s + i] = w;
        tn[w] = 3 * s + i;
        continue;
      }
      const index_t nc = tn2[3 * t + i];
      if (state[nc / 3] == 1) mergeError("kept triangle next to a covered one");
      tn[3 * s + i] = 3 * slot[nc / 3] + nc % 3;
    }
  }
  for (std::size_t k = next; k < band_slots; ++k) {  // band slots left over
    const index_t f = k < band_a.size() ? band_a[k] : band_b[k - band_a.size()];
    tv[3 * f] = kDead;
    out.free_slots.push_back(f);
  }
}

}  // namespace

Group mergeGroups(const PointSet& ps, TriangleArena arena, int axis, double seam, Group&& a, Group&& b,
                  std::size_t* band_points) {
  if (a.num_vertices == 0) {
    b.strip_begin = a.strip_begin;
    return std::move(b);
  }
  if (b.num_vertices == 0) {
    a.strip_end = b.strip_end;
    return std::move(a);
  }
  index_t* tv = arena.tv;
  index_t* tn = arena.tn;
  const std::vector<index_t> band_a = collectBand(ps, tv, tn, a, axis, seam, true);
  const std::vector<index_t> band_b = collectBand(ps, tv, tn, b, axis, seam, false);
  BandBoundary boundary = bandBoundary(tv, tn, a, b, band_a, band_b);
  std::vector<index_t>& verts = boundary.verts;
  WallTable wall_table(boundary.walls.size());
  for (const auto& w : boundary.walls)
    if (!wall_table.insert(w.first, w.second)) mergeError("band boundary edge seen twice");
  if (band_points) *band_points += verts.size();

  // DT(V_U) in a private arena, on the same global positions and ranks.
  detail::brioHilbertSort(ps.xy, verts);
  const std::size_t cap = 2 * verts.size() + 2;
  std::vector<index_t> tv2(3 * cap), tn2(3 * cap);
  BowyerWatson kernel(ps, TriangleArena{tv2.data(), tn2.data()}, 0, static_cast<index_t>(cap));
  kernel.run(verts.data(), verts.size());
  if (!kernel.duplicates().empty()) mergeError("duplicate band vertices");

  Group out = joinGroups(a, b);
  if (!kernel.hasTriangles()) {
    if (a.has_triangles || b.has_triangles) mergeError("band lost its triangles");
    out.free_slots.insert(out.free_slots.end(), band_a.begin(), band_a.end());
    out.free_slots.insert(out.free_slots.end(), band_b.begin(), band_b.end());
    out.loose = kernel.collinearVertices();
    return out;
  }
  const index_t used = kernel.used();
  const BandClassification cls =
      classifyBand(tv2.data(), tn2.data(), used, wall_table, boundary.walls.size());

  // Euler: the merged triangulation (ghosts included) has 2V - 2 triangles; the sure ones stay.
  std::size_t keep = 0;
  for (index_t t = 0; t < used; ++t) keep += cls.state[t] != 1;
  const std::size_t sure_a = a.has_triangles ? 2 * a.num_vertices - 2 - band_a.size() : 0;
  const std::size_t sure_b = b.has_triangles ? 2 * b.num_vertices - 2 - band_b.size() : 0;
  if (keep + sure_a + sure_b != 2 * out.num_vertices - 2) mergeError("triangle count (Euler) mismatch");
  if (keep > band_a.size() + band_b.size() + out.free_slots.size()) mergeError("not enough slots");

  stitchKept(tv, tn, tv2.data(), tn2.data(), used, cls, band_a, band_b, out);
  out.has_triangles = true;
  if (out.ghost == kDead) mergeError("merged triangulation has no hull");
  return out;
}

}  // namespace detail
}  // namespace tin
}  // namespace dw
