/// \file distributed_graph.cpp
/// \brief The distributed 3D graph builder: range read, Morton sample sort across ranks, the single-
/// process input preparation replayed on the distributed points, then one certified block per rank
/// whose halo cells are fetched from their owners round by round (distributed_graph.h, docs/mpi.md).
#include "pcl_delaunay_walk/mpi/distributed_graph.h"
#include "mpi/fault_injection.h"

#include <sys/mman.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstring>
#include <deque>
#include <limits>
#include <numeric>
#include <unordered_map>

#include "core/builder3d/triangulation_3d.h"
#include "core/geometry/rounded_circumsphere.h"
#include "pcl_delaunay_walk/core/geometry/predicates_3d.h"
#include "core/util/space_filling_curve.h"
#include "core/geometry/vec3d.h"

namespace dw {
namespace mpi {
namespace {

using builder3d::Triangulation3D;
using builder3d::RoundedCircumsphere;
using builder3d::roundedCircumsphere;

double since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

int toInt(std::size_t n, const char* what) {
  if (n > static_cast<std::size_t>(INT_MAX))
    throw Error(std::string("dw::mpi: ") + what + " exceeds 2 GiB for one message; use more ranks");
  return static_cast<int>(n);
}

/// Alltoallv of plain bytes; send[r] goes to rank r, the result holds what rank r sent at recv[r].
std::vector<std::vector<unsigned char>> exchangeBytes(MPI_Comm comm,
                                                      const std::vector<std::vector<unsigned char>>& send) {
  const int P = static_cast<int>(send.size());
  std::vector<int> sc(P), sd(P, 0), rc(P), rd(P, 0);
  std::size_t total = 0;
  for (int r = 0; r < P; ++r) sc[r] = toInt(send[r].size(), "a halo message"), total += send[r].size();
  toInt(total, "one rank's halo messages");
  for (int r = 1; r < P; ++r) sd[r] = sd[r - 1] + sc[r - 1];
  MPI_Alltoall(sc.data(), 1, MPI_INT, rc.data(), 1, MPI_INT, comm);
  std::size_t rtotal = 0;
  for (int r = 0; r < P; ++r) rd[r] = toInt(rtotal, "one rank's halo messages"), rtotal += rc[r];
  toInt(rtotal, "one rank's halo messages");
  std::vector<unsigned char> sbuf(total), rbuf(rtotal);
  for (int r = 0; r < P; ++r)
    if (!send[r].empty()) std::memcpy(sbuf.data() + sd[r], send[r].data(), send[r].size());
  MPI_Alltoallv(sbuf.data(), sc.data(), sd.data(), MPI_BYTE, rbuf.data(), rc.data(), rd.data(), MPI_BYTE,
                comm);
  std::vector<std::vector<unsigned char>> out(P);
  for (int r = 0; r < P; ++r) out[r].assign(rbuf.begin() + rd[r], rbuf.begin() + rd[r] + rc[r]);
  return out;
}

template <class T>
void put(std::vector<unsigned char>& b, const T& v) {
  const unsigned char* c = reinterpret_cast<const unsigned char*>(&v);
  b.insert(b.end(), c, c + sizeof(T));
}
template <class T>
T get(const std::vector<unsigned char>& b, std::size_t& at) {
  if (at + sizeof(T) > b.size()) throw Error("dw::mpi: internal inconsistency: short halo message");
  T v;
  std::memcpy(&v, b.data() + at, sizeof(T));
  at += sizeof(T);
  return v;
}

/// Gathers variable-length arrays of T from every rank onto every rank (rank order).
template <class T>
std::vector<T> allGather(MPI_Comm comm, const std::vector<T>& mine) {
  int P = 1;
  MPI_Comm_size(comm, &P);
  const int bytes = toInt(mine.size() * sizeof(T), "a gathered array");
  std::vector<int> counts(P), displs(P, 0);
  MPI_Allgather(&bytes, 1, MPI_INT, counts.data(), 1, MPI_INT, comm);
  std::size_t total = 0;
  for (int r = 0; r < P; ++r) displs[r] = toInt(total, "a gathered array"), total += counts[r];
  toInt(total, "a gathered array");
  std::vector<T> all(total / sizeof(T));
  MPI_Allgatherv(mine.data(), bytes, MPI_BYTE, all.data(), counts.data(), displs.data(), MPI_BYTE, comm);
  return all;
}

/// Gathers variable-length arrays onto rank 0 only.
template <class T>
std::vector<T> gatherTo0(MPI_Comm comm, const std::vector<T>& mine) {
  int P = 1, me = 0;
  MPI_Comm_size(comm, &P);
  MPI_Comm_rank(comm, &me);
  const int bytes = toInt(mine.size() * sizeof(T), "a gathered array");
  std::vector<int> counts(P), displs(P, 0);
  MPI_Gather(&bytes, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm);
  std::vector<T> all;
  if (me == 0) {
    std::size_t total = 0;
    for (int r = 0; r < P; ++r) displs[r] = toInt(total, "a gathered array"), total += counts[r];
    toInt(total, "the gathered graph");
    all.resize(total / sizeof(T));
  }
  MPI_Gatherv(mine.data(), bytes, MPI_BYTE, all.data(), counts.data(), displs.data(), MPI_BYTE, 0, comm);
  return all;
}

/// Vertex coordinates indexed by GLOBAL vertex id, in anonymous memory that is only committed where
/// written: the kernel's symbolic perturbation ranks points by id, so a block must address its points
/// by their global ids to decide every tie as the single-process build does, while holding physically
/// only its own vertices and halo (Morton ids keep both in few pages).
class SparsePoints {
 public:
  explicit SparsePoints(std::size_t n) : n_(n) {
    if (n == 0) return;
    bytes_ = n * sizeof(Vec3f);
    void* p =
        mmap(nullptr, bytes_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    if (p == MAP_FAILED) throw Error("dw::mpi: cannot reserve address space for the vertex array");
    data_ = static_cast<Vec3f*>(p);
  }
  ~SparsePoints() {
    if (data_) munmap(data_, bytes_);
  }
  SparsePoints(const SparsePoints&) = delete;
  SparsePoints& operator=(const SparsePoints&) = delete;
  Vec3f* data() { return data_; }
  Vec3f& operator[](std::size_t i) { return data_[i]; }
  std::size_t size() const { return n_; }

 private:
  Vec3f* data_ = nullptr;
  std::size_t n_ = 0, bytes_ = 0;
};

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/// Biased randomised insertion order of ids that are already in Morton order (global vertex ids are):
/// rounds of doubling size chosen by a hash of the id, ascending ids inside a round. The order changes
/// only the speed, never the triangulation (it is unique under the perturbation).
std::vector<index_t> brio(std::vector<index_t> ids) {
  unsigned rounds = 1;
  while (rounds < 15 && (ids.size() >> rounds) > 512) ++rounds;
  auto roundOf = [rounds](index_t i) {
    const std::uint64_t h = splitmix64(i);
    unsigned tz = 0;
    while (tz + 1 < rounds && ((h >> tz) & 1u) == 0) ++tz;
    return rounds - 1 - tz;
  };
  std::sort(ids.begin(), ids.end(), [&](index_t a, index_t b) {
    const unsigned ra = roundOf(a), rb = roundOf(b);
    return ra != rb ? ra < rb : a < b;
  });
  return ids;
}

/// One point between ranks during the Morton sort (the single-process sort key and payload).
struct Item {
  std::uint64_t key;
  Vec3f p;
  index_t input;
};
static_assert(sizeof(Item) == 24, "Item travels as bytes");

bool itemLess(const Item& a, const Item& b) {
  if (a.key != b.key) return a.key < b.key;
  if (a.p.x != b.p.x) return a.p.x < b.p.x;
  if (a.p.y != b.p.y) return a.p.y < b.p.y;
  if (a.p.z != b.p.z) return a.p.z < b.p.z;
  return a.input < b.input;
}

/// Global (first occurrence) argmax of a per-vertex value: each rank offers its best value, the global
/// id of its first occurrence and that vertex; the smallest id among equal maxima wins, as in a
/// sequential scan in id order.
struct Best {
  double value;
  std::uint64_t id;
  Vec3f p;
  float pad;
};
Best globalBest(MPI_Comm comm, const Best& mine) {
  const std::vector<Best> all = allGather(comm, std::vector<Best>{mine});
  Best b = all[0];
  for (const Best& o : all)
    if (o.value > b.value || (o.value == b.value && o.id < b.id)) b = o;
  return b;
}

/// The Morton quantisation of graph_builder.cpp: a float local position, back in world coordinates,
/// scaled onto 21 bits per axis over the bounding box [lo, ...].
void quantise(const double origin[3], const double lo[3], double qscale, const Vec3f& lp,
              std::uint32_t q[3]) {
  const double fp[3] = {double(lp.x) + origin[0], double(lp.y) + origin[1], double(lp.z) + origin[2]};
  for (int a = 0; a < 3; ++a)
    q[a] = static_cast<std::uint32_t>(std::clamp((fp[a] - lo[a]) * qscale, 0.0, double((1u << 21) - 1)));
}

/// The halo unit: cubic cells of 2^k Morton quantisation steps, so that a cell is one contiguous run of
/// Morton keys, hence of global vertex ids, and its owners are the ranks whose key ranges meet that run.
struct CellGrid {
  int k = 0;
  int dims[3] = {1, 1, 1};
  double base[3] = {0, 0, 0};  // local (origin-relative) coordinate of cell 0's lower corner
  double width = 1;            // cell edge in local units
  double slack = 0;            // enlarges cell boxes: covers the rounding of the quantisation
  double origin[3] = {0, 0, 0}, lo[3] = {0, 0, 0}, qscale = 0;  // the Morton quantisation

  /// The cell of a vertex, from its quantised position computed exactly as its Morton key was, so every
  /// rank puts a point in the cell its owner did.
  std::uint32_t cellOfPoint(const Vec3f& lp) const {
    std::uint32_t q[3];
    quantise(origin, lo, qscale, lp, q);
    return linear(q[0] >> k, q[1] >> k, q[2] >> k);
  }

  std::size_t numCells() const { return std::size_t(dims[0]) * dims[1] * dims[2]; }
  std::uint32_t linear(std::uint32_t x, std::uint32_t y, std::uint32_t z) const {
    return static_cast<std::uint32_t>((std::size_t(x) * dims[1] + y) * dims[2] + z);
  }
  void coords(std::uint32_t c, std::uint32_t xyz[3]) const {
    xyz[2] = c % dims[2];
    xyz[1] = (c / dims[2]) % dims[1];
    xyz[0] = static_cast<std::uint32_t>(c / (std::size_t(dims[1]) * dims[2]));
  }
  /// Morton key range [lo, hi) of the points of cell c.
  std::pair<std::uint64_t, std::uint64_t> keyRange(std::uint32_t c) const {
    std::uint32_t xyz[3];
    coords(c, xyz);
    const std::uint64_t code = mortonKey(xyz[0], xyz[1], xyz[2]);
    return {code << (3 * k), (code + 1) << (3 * k)};
  }
  int coord(double v, int a) const {
    const double c = std::floor((v - base[a]) / width);
    return static_cast<int>(std::min(std::max(c, 0.0), double(dims[a] - 1)));
  }
};

/// One rank's block: its own vertices [first, last) (global ids), the cells it holds completely, the
/// halo points it fetched, and its kernel. The certification is that of block_parallel_builder.cpp;
/// what differs is that a cell's points must be fetched from its owners before they can be tested.
class RankBlock {
 public:
  RankBlock(MPI_Comm comm, const CellGrid& grid, const std::vector<std::uint64_t>& occupied,
            const std::vector<std::uint64_t>& splitters, SparsePoints& pts,
            const std::vector<std::uint64_t>& keys, index_t first, index_t last)
      : comm_(comm),
        grid_(grid),
        occupied_(occupied),
        split_(splitters),
        pts_(pts),
        keys_(keys),
        first_(first),
        last_(last),
        state_(grid.numCells(), kUnknown),
        inserted_((pts.size() + 63) / 64, 0),
        open_slot_(grid.numCells(), 0) {
    for (int a = 0; a < 3; ++a) cdims_[a] = (grid.dims[a] + 3) / 4;
    open_.assign(std::size_t(cdims_[0]) * cdims_[1] * cdims_[2], 0);
    for (std::uint32_t c = 0; c < grid.numCells(); ++c)
      if (occupiedCell(c)) ++open_[coarseOf(c)];
    MPI_Comm_rank(comm, &me_);
    MPI_Comm_size(comm, &P_);
  }

  /// Collective. Own cells plus one ring, fetched and triangulated.
  void triangulate() {
    std::vector<std::uint32_t> want;
    std::vector<std::uint8_t> seen(grid_.numCells(), 0);
    for (index_t v = first_; v < last_; ++v) {
      const std::uint32_t c = cellOfKey(keys_[v - first_]);
      if (seen[c] & 1) continue;  // bit 1: ring added; bit 2: in `want`
      seen[c] |= 1;
      std::uint32_t xyz[3];
      grid_.coords(c, xyz);
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            const long X = long(xyz[0]) + dx, Y = long(xyz[1]) + dy, Z = long(xyz[2]) + dz;
            if (X < 0 || Y < 0 || Z < 0 || X >= grid_.dims[0] || Y >= grid_.dims[1] || Z >= grid_.dims[2])
              continue;
            const std::uint32_t nc = grid_.linear(std::uint32_t(X), std::uint32_t(Y), std::uint32_t(Z));
            if (occupiedCell(nc) && !(seen[nc] & 2)) {
              seen[nc] |= 2;
              want.push_back(nc);
            }
          }
    }
    std::vector<std::uint8_t>().swap(seen);
    fetch(want);
    std::vector<index_t> ids;
    for (std::uint32_t c : want) {
      setCovered(c);
      members(c, ids);
    }
    halo_points_ = ids.size() - (last_ - first_);
    for (index_t v : ids) markInserted(v);
    if (first_ == last_) return;  // no own vertices: this rank only answers requests
    kernel_.setPoints(pts_.data(), pts_.size());
    kernel_.trackBirths(true);
    const std::vector<index_t> order = brio(std::move(ids));
    kernel_.build(order.data(), order.size());
  }

  std::vector<index_t> hullVertices() const {
    return kernel_.built() ? kernel_.hullVertices() : std::vector<index_t>();
  }

  /// Collective. Grow the halo until every tetrahedron around the own vertices is certified, insert the
  /// global hull boundary points not yet present (their coordinates are already in pts_), grow again.
  void certify(const std::vector<index_t>& hull) {
    grow();
    for (index_t h : hull)
      if (kernel_.built() && !isInserted(h)) {
        kernel_.insert(h);
        markInserted(h);
        ++halo_points_;
      }
    grow();
  }

  std::vector<std::pair<index_t, index_t>> edges() const {
    return kernel_.built() ? kernel_.edgesFrom(first_, last_) : std::vector<std::pair<index_t, index_t>>();
  }
  std::size_t haloPoints() const { return halo_points_; }
  std::size_t fetchedPoints() const { return fetched_points_; }
  std::size_t rounds() const { return rounds_; }
  std::size_t exchanges() const { return exchanges_; }
  double exchangeSeconds() const { return exchange_s_; }

 private:
  enum : std::uint8_t { kUnknown = 0, kRequested = 1, kFetched = 2, kCovered = 3 };

  std::uint32_t cellOfKey(std::uint64_t key) const {
    const std::uint64_t code = key >> (3 * grid_.k);
    std::uint32_t xyz[3] = {0, 0, 0};
    for (int b = 0; b < 21; ++b)
      for (int a = 0; a < 3; ++a) xyz[a] |= static_cast<std::uint32_t>((code >> (3 * b + a)) & 1u) << b;
    return grid_.linear(xyz[0], xyz[1], xyz[2]);
  }
  bool occupiedCell(std::uint32_t c) const { return (occupied_[c >> 6] >> (c & 63)) & 1u; }
  std::size_t coarse(int bx, int by, int bz) const {
    return (std::size_t(bx) * cdims_[1] + by) * cdims_[2] + bz;
  }
  std::size_t coarseOf(std::uint32_t c) const {
    std::uint32_t xyz[3];
    grid_.coords(c, xyz);
    return coarse(int(xyz[0] >> 2), int(xyz[1] >> 2), int(xyz[2] >> 2));
  }
  void setCovered(std::uint32_t c) {
    if (state_[c] != kCovered && occupiedCell(c)) --open_[coarseOf(c)];
    state_[c] = kCovered;
  }
  bool isInserted(index_t v) const { return (inserted_[v >> 6] >> (v & 63)) & 1u; }
  void markInserted(index_t v) { inserted_[v >> 6] |= std::uint64_t{1} << (v & 63); }
  /// Ranks whose Morton key range meets cell c's: [lo_rank, hi_rank].
  std::pair<int, int> owners(std::uint32_t c) const {
    const auto kr = grid_.keyRange(c);
    auto rankOf = [&](std::uint64_t key) {
      return static_cast<int>(std::upper_bound(split_.begin() + 1, split_.end(), key) - split_.begin()) - 1;
    };
    return {rankOf(kr.first), rankOf(kr.second - 1)};
  }
  /// The points of a known cell (fetched, or owned by this rank alone) not yet in the kernel, with their
  /// bounding box; inserted points are dropped lazily.
  struct OpenPoints {
    float lo[3], hi[3];
    std::vector<index_t> ids;
  };
  OpenPoints& openPoints(std::uint32_t c) {
    std::uint32_t& slot = open_slot_[c];
    bool rebox = false;
    if (slot == 0) {
      open_lists_.emplace_back();
      slot = static_cast<std::uint32_t>(open_lists_.size());
      members(c, open_lists_.back().ids);
      rebox = true;
    }
    OpenPoints& L = open_lists_[slot - 1];
    const std::size_t before = L.ids.size();
    L.ids.erase(std::remove_if(L.ids.begin(), L.ids.end(), [&](index_t v) { return isInserted(v); }),
                L.ids.end());
    if (rebox || L.ids.size() != before) {
      for (int k = 0; k < 3; ++k) L.lo[k] = INFINITY, L.hi[k] = -INFINITY;
      for (index_t v : L.ids) {
        const float p[3] = {pts_[v].x, pts_[v].y, pts_[v].z};
        for (int k = 0; k < 3; ++k) L.lo[k] = std::min(L.lo[k], p[k]), L.hi[k] = std::max(L.hi[k], p[k]);
      }
    }
    return L;
  }

  /// Appends the ids of cell c's points (the cell must be held or fetched, or owned by this rank alone).
  void members(std::uint32_t c, std::vector<index_t>& out) const {
    const auto kr = grid_.keyRange(c);
    const auto lo = std::lower_bound(keys_.begin(), keys_.end(), kr.first);
    const auto hi = std::lower_bound(lo, keys_.end(), kr.second);
    for (auto it = lo; it != hi; ++it) out.push_back(first_ + static_cast<index_t>(it - keys_.begin()));
    const auto f = fetched_.find(c);
    if (f != fetched_.end()) out.insert(out.end(), f->second.begin(), f->second.end());
  }

  /// Collective: every rank asks the other owners of the cells in `cells` for their points; cells owned
  /// by this rank alone need no message. Marks the cells fetched.
  void fetch(const std::vector<std::uint32_t>& cells) {
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<std::vector<unsigned char>> req(P_);
    for (std::uint32_t c : cells) {
      const auto o = owners(c);
      for (int r = o.first; r <= o.second; ++r)
        if (r != me_) put(req[r], c);
    }
    const std::vector<std::vector<unsigned char>> asked = exchangeBytes(comm_, req);
    // Answer: per requested cell, the count and then (id, point) records of this rank's part.
    std::vector<std::vector<unsigned char>> answer(P_);
    std::vector<index_t> ids;
    for (int r = 0; r < P_; ++r) {
      for (std::size_t at = 0; at < asked[r].size();) {
        const std::uint32_t c = get<std::uint32_t>(asked[r], at);
        if (c >= grid_.numCells()) throw Error("dw::mpi: internal inconsistency: request for a foreign cell");
        const auto kr = grid_.keyRange(c);
        const auto lo = std::lower_bound(keys_.begin(), keys_.end(), kr.first);
        const auto hi = std::lower_bound(lo, keys_.end(), kr.second);
        put(answer[r], static_cast<std::uint32_t>(hi - lo));
        for (auto it = lo; it != hi; ++it) {
          const index_t v = first_ + static_cast<index_t>(it - keys_.begin());
          put(answer[r], v);
          put(answer[r], pts_[v]);
        }
      }
    }
    const std::vector<std::vector<unsigned char>> got = exchangeBytes(comm_, answer);
    for (int r = 0; r < P_; ++r) {
      std::size_t at = 0, q = 0;
      while (q < req[r].size()) {
        std::uint32_t c;
        std::memcpy(&c, req[r].data() + q, 4);
        q += 4;
        const std::uint32_t n = get<std::uint32_t>(got[r], at);
        std::vector<index_t>& list = fetched_[c];
        for (std::uint32_t i = 0; i < n; ++i) {
          const index_t v = get<index_t>(got[r], at);
          const Vec3f p = get<Vec3f>(got[r], at);
          if (v >= pts_.size()) throw Error("dw::mpi: internal inconsistency: a fetched vertex out of range");
          pts_[v] = p;
          list.push_back(v);
          ++fetched_points_;
        }
      }
      if (at != got[r].size()) throw Error("dw::mpi: internal inconsistency: long halo answer");
    }
    for (std::uint32_t c : cells)
      if (state_[c] != kCovered) state_[c] = kFetched;
    exchange_s_ += since(t0);
  }

  /// Collective certification passes (see block_parallel_builder.cpp for why only tetrahedra born since
  /// the last pass, plus the pending ones, need a look). A tetrahedron whose ball reaches a cell not yet
  /// fetched stays pending until the next pass, after the fetch.
  void grow() {
    std::vector<index_t> adds;
    std::vector<std::uint32_t> need;
    std::vector<std::pair<std::size_t, std::array<index_t, 4>>> pending, still, waiting;
    bool first = last_pass_ == kNoPass;
    for (;;) {
      // Tetrahedra that waited for cells are looked at again once, after the fetch.
      pending.insert(pending.end(), waiting.begin(), waiting.end());
      waiting.clear();
      // Local passes: insert what the known points say is missing until nothing local is left; the cells
      // still to fetch accumulate in `need` (one message round for all of them, not one per pass).
      need.clear();
      std::size_t local_passes = 0;
      for (;;) {
        // A long tail of passes that each add a few points (a creeping seam) ends sooner with more
        // points per tetrahedron; the first passes keep it small to keep the halo small.
        per_tet_ = kPerTetrahedron << std::min<std::size_t>(local_passes / 16, 6);
        adds.clear();
        still.clear();
        const std::uint32_t now = kernel_.clock();
        auto check = [&](std::size_t t) {
          const index_t* tv = kernel_.tetVertices(t);
          if (tv[0] == Triangulation3D::kDead) return;
          int mine = -1;
          for (unsigned k = 0; k < 4; ++k) {
            if (tv[k] == Triangulation3D::kInfinite) return;  // settled by the global hull
            if (tv[k] >= first_ && tv[k] < last_) mine = static_cast<int>(k);
          }
          if (mine < 0) return;
          const Ball b = conflictsInBall(tv, static_cast<unsigned>(mine), adds, need);
          if (b == Ball::kConflict) still.push_back({t, {tv[0], tv[1], tv[2], tv[3]}});
          if (b == Ball::kWaiting) waiting.push_back({t, {tv[0], tv[1], tv[2], tv[3]}});
        };
        if (kernel_.built()) {
          const std::size_t slots = kernel_.tetSlots();
          for (std::size_t t = 0; t < slots; ++t) {
            if (first || kernel_.birth(t) > last_pass_) check(t);
          }
          for (const auto& p : pending) {
            const index_t* tv = kernel_.tetVertices(p.first);
            if (kernel_.birth(p.first) <= last_pass_ && std::equal(tv, tv + 4, p.second.begin()))
              check(p.first);
          }
        }
        last_pass_ = now;
        first = false;
        pending.swap(still);
        ++local_passes;
        if (adds.empty()) break;
        ++rounds_;
        std::sort(adds.begin(), adds.end());  // Morton order: short walks between insertions
        for (index_t id : adds) kernel_.insert(id);
        halo_points_ += adds.size();
      }
      // Everyone takes part in every exchange until no rank has cells left to ask for.
      int busy = need.empty() ? 0 : 1;
      MPI_Allreduce(MPI_IN_PLACE, &busy, 1, MPI_INT, MPI_MAX, comm_);
      if (!busy) return;
      fetch(need);
      ++exchanges_;
    }
  }

  /// Looks for points not in the kernel inside the rounding-enlarged circumsphere of the finite
  /// tetrahedron tv (tv[own] is one of this rank's vertices). Cells under the ball that are not fetched
  /// yet go to `need`; of the known points inside the ball, the one nearest to tv[own] goes to `adds`
  /// (it is likely a true Delaunay neighbour, while a whole cell or every point of a large ball would
  /// drag in points no final tetrahedron uses; the tetrahedron is re-checked after the insertion).
  /// Says whether the tetrahedron is certified, conflicts with known points (re-checked next pass, if
  /// it survives), or waits for cells to arrive (re-checked after the next fetch).
  enum class Ball { kCertified, kConflict, kWaiting };
  Ball conflictsInBall(const index_t* tv, unsigned own, std::vector<index_t>& adds,
                       std::vector<std::uint32_t>& need) {
    double P[4][3];  // the vertices in double, for the exact insphere test below
    for (unsigned k = 0; k < 4; ++k) {
      const Vec3f& q = pts_[tv[k]];
      P[k][0] = q.x, P[k][1] = q.y, P[k][2] = q.z;
    }
    // The same generous bound on the rounding of centre and radius as the threaded builder.
    const RoundedCircumsphere ball =
        roundedCircumsphere(pts_[tv[0]], pts_[tv[1]], pts_[tv[2]], pts_[tv[3]], grid_.width);
    const double R = ball.radius;
    const bool all = ball.unbounded();  // a flat sliver: every cell may hold a point of its ball
    const double* centre = ball.centre;
    int range[3][2];
    for (int k = 0; k < 3; ++k) {
      if (all) {
        range[k][0] = 0, range[k][1] = grid_.dims[k] - 1;
      } else {
        range[k][0] = grid_.coord(centre[k] - R - grid_.slack, k);
        range[k][1] = grid_.coord(centre[k] + R + grid_.slack, k);
      }
    }
    const double R2 = R * R;
    bool waiting = false;
    const Vec3f& ov = pts_[tv[own]];
    near_.clear();
    // Blocks of 4^3 cells without an open cell are skipped whole: the balls of tetrahedra that span a
    // surface scan's empty interior cover thousands of cells, nearly all empty or done.
    for (int bx = range[0][0] >> 2; bx <= range[0][1] >> 2; ++bx)
      for (int by = range[1][0] >> 2; by <= range[1][1] >> 2; ++by)
        for (int bz = range[2][0] >> 2; bz <= range[2][1] >> 2; ++bz) {
          if (open_[coarse(bx, by, bz)] == 0) continue;
          for (int x = std::max(range[0][0], 4 * bx); x <= std::min(range[0][1], 4 * bx + 3); ++x)
            for (int y = std::max(range[1][0], 4 * by); y <= std::min(range[1][1], 4 * by + 3); ++y)
              for (int z = std::max(range[2][0], 4 * bz); z <= std::min(range[2][1], 4 * bz + 3); ++z) {
                const std::uint32_t c = grid_.linear(std::uint32_t(x), std::uint32_t(y), std::uint32_t(z));
                if (state_[c] == kCovered || !occupiedCell(c)) continue;
                if (!all) {
                  // Skip cells whose (slack-enlarged) box misses the ball.
                  const int xyz[3] = {x, y, z};
                  double d2 = 0.0;
                  for (int k = 0; k < 3; ++k) {
                    const double b0 = grid_.base[k] + xyz[k] * grid_.width - grid_.slack;
                    const double b1 = grid_.base[k] + (xyz[k] + 1) * grid_.width + grid_.slack;
                    const double d =
                        centre[k] < b0 ? b0 - centre[k] : (centre[k] > b1 ? centre[k] - b1 : 0.0);
                    d2 += d * d;
                  }
                  if (d2 > R2 * (1.0 + 1e-12)) continue;
                }
                if (state_[c] == kRequested) {
                  waiting = true;
                  continue;
                }
                if (state_[c] == kUnknown) {
                  const auto o = owners(c);
                  if (!(o.first == me_ && o.second == me_)) {
                    state_[c] = kRequested;
                    need.push_back(c);
                    waiting = true;
                    continue;
                  }
                }
                OpenPoints& L = openPoints(c);
                if (L.ids.empty()) {  // all its points are in: later balls skip it at once
                  setCovered(c);
                  continue;
                }
                if (!all) {  // the tight box of its open points (surface scans fill a fraction of a cell)
                  double d2 = 0.0;
                  for (int k = 0; k < 3; ++k) {
                    const double d = centre[k] < L.lo[k] ? L.lo[k] - centre[k]
                                                         : (centre[k] > L.hi[k] ? centre[k] - L.hi[k] : 0.0);
                    d2 += d * d;
                  }
                  if (d2 > R2 * (1.0 + 1e-12)) continue;
                }
                for (index_t q : L.ids) {
                  const Vec3f& pq = pts_[q];
                  if (!all) {
                    const double dx = pq.x - centre[0], dy = pq.y - centre[1], dz = pq.z - centre[2];
                    if (dx * dx + dy * dy + dz * dz > R2) continue;
                  }
                  // Inside the enlarged ball: decide exactly, with the kernel's own perturbed predicate. Only
                  // a point in conflict destroys the tetrahedron when inserted; one in the rounding margin
                  // would not, and inserting such points one after another crept across whole clouds.
                  const double e[3] = {pq.x, pq.y, pq.z};
                  const double sign = predicates::insphere(P[0], P[1], P[2], P[3], e);
                  if (sign < 0.0 || (sign == 0.0 && predicates::insphereSoS(P[0], P[1], P[2], P[3], e, tv[0],
                                                                            tv[1], tv[2], tv[3], q) <= 0))
                    continue;
                  const double ex = double(pq.x) - ov.x, ey = double(pq.y) - ov.y, ez = double(pq.z) - ov.z;
                  near_.push_back({ex * ex + ey * ey + ez * ez, q});
                }
              }
        }
    if (!near_.empty()) {
      const std::size_t k = std::min(near_.size(), per_tet_);
      std::partial_sort(near_.begin(), near_.begin() + static_cast<std::ptrdiff_t>(k), near_.end());
      for (std::size_t i = 0; i < k; ++i) {
        markInserted(near_[i].second);
        adds.push_back(near_[i].second);
      }
      return Ball::kConflict;
    }
    return waiting ? Ball::kWaiting : Ball::kCertified;
  }

  MPI_Comm comm_;
  int me_ = 0, P_ = 1;
  const CellGrid& grid_;
  const std::vector<std::uint64_t>& occupied_;
  const std::vector<std::uint64_t>& split_;
  SparsePoints& pts_;
  const std::vector<std::uint64_t>& keys_;  // Morton keys of the own vertices (ascending)
  index_t first_, last_;
  std::vector<std::uint8_t> state_;  // per cell
  int cdims_[3] = {1, 1, 1};
  std::vector<std::uint32_t> open_;  // per block of 4^3 cells: occupied cells not yet covered
  std::unordered_map<std::uint32_t, std::vector<index_t>> fetched_;  // other ranks' points of a cell
  std::vector<std::uint64_t> inserted_;   // per global vertex id: in the kernel (or queued for it)
  std::vector<std::uint32_t> open_slot_;  // per cell: 1 + index into open_lists_, 0 if not built
  std::deque<OpenPoints> open_lists_;
  std::vector<std::pair<double, index_t>> near_;
  /// Conflicting points inserted per uncertified tetrahedron and pass, nearest to its own vertex first.
  /// Measured (4 ranks): all of them inflates the halo (dragon 2.4x the minimum), one at a time creeps
  /// (uniform: 1,500 passes); 4 keeps the halo near the minimum in a few dozen passes.
  static constexpr std::size_t kPerTetrahedron = 4;
  std::size_t per_tet_ = kPerTetrahedron;
  static constexpr std::uint32_t kNoPass = 0xFFFFFFFFu;
  std::uint32_t last_pass_ = kNoPass;
  Triangulation3D kernel_;
  std::size_t halo_points_ = 0, fetched_points_ = 0, rounds_ = 0, exchanges_ = 0;
  double exchange_s_ = 0;
};

/// The single-process affine-dimension test (graph_builder.cpp) on the distributed vertices, with the
/// same operations in the same order, so that it decides the same way: returns the dimension at
/// relative tolerances 1e-9 and 1e-6.
std::pair<int, int> distributedDimension(MPI_Comm comm, const std::vector<Vec3f>& p, std::uint64_t first) {
  // Vertex 0 lives on the first rank with vertices (the only one with vertices and first id 0).
  const bool has0 = !p.empty() && first == 0;
  const Best b0{has0 ? 1.0 : -INFINITY, 0, has0 ? p[0] : Vec3f{0, 0, 0}, 0};
  const auto p0 = toVec3d(globalBest(comm, b0).p);
  Best m{-1.0, ~0ull, {0, 0, 0}, 0};
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto d = sub(toVec3d(p[i]), p0);
    const double l = dot(d, d);
    if (l > m.value) m = {l, first + i, p[i], 0};
  }
  const Best i1 = globalBest(comm, m);
  if (!(i1.value > 0)) return {0, 0};
  const double extent = std::sqrt(i1.value);
  auto dir = sub(toVec3d(i1.p), p0);
  for (double& c : dir) c /= extent;
  m = {-1.0, ~0ull, {0, 0, 0}, 0};
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto c = cross(dir, sub(toVec3d(p[i]), p0));
    const double l = dot(c, c);
    if (l > m.value) m = {l, first + i, p[i], 0};
  }
  const Best i2 = globalBest(comm, m);
  const double best2 = std::max(0.0, i2.value);
  auto w = sub(toVec3d(i2.p), p0);
  const double t = dot(w, dir);
  for (int a = 0; a < 3; ++a) w[a] -= t * dir[a];
  const double wl = std::sqrt(dot(w, w));
  for (double& c : w) c /= wl;
  const auto nrm = cross(dir, w);
  double off = 0;
  for (const Vec3f& q : p) off = std::max(off, std::fabs(dot(sub(toVec3d(q), p0), nrm)));
  MPI_Allreduce(MPI_IN_PLACE, &off, 1, MPI_DOUBLE, MPI_MAX, comm);
  auto dim = [&](double rel) {
    const double tol = rel * extent;
    if (std::sqrt(best2) <= tol) return 1;
    return off <= tol ? 2 : 3;
  };
  return {dim(1e-9), dim(1e-6)};
}

}  // namespace

RankGraph buildGraphDistributed(MPI_Comm comm, const PointInputSet& input, const DistributedGraphOptions& o) {
  RankGraph g;
  MPI_Comm_rank(comm, &g.rank);
  MPI_Comm_size(comm, &g.size);
  const int P = g.size, me = g.rank;
  auto progress = [&](const std::string& s) {
    if (me == 0 && o.progress) o.progress(s);
  };

  // 1. Read this rank's share of the input sequence.
  auto t0 = std::chrono::steady_clock::now();
  const std::uint64_t n_in = input.size();
  if (n_in >= static_cast<std::uint64_t>(kInvalidIndex))
    throw Error("pcl_delaunay_walk: at most 2^32-2 input points are supported");
  g.input_points = n_in;
  const std::uint64_t in_first = n_in * me / P, in_last = n_in * (me + 1) / P;
  const std::vector<double> xyz = input.read(in_first, in_last);
  if (xyz.size() != 3 * (in_last - in_first)) throw Error(input.describe() + ": short read");
  g.timings.read_s = since(t0);
  checkFault(o.inject_fault, g.rank, "read");
  progress("read " + std::to_string(n_in) + " points on " + std::to_string(P) + " ranks");

  // 2. The single-process preparation (graph_builder.cpp), replayed: bounding box of the finite points,
  // origin at its centre, float local coordinates, Morton keys from the float positions.
  t0 = std::chrono::steady_clock::now();
  const std::size_t n_mine = in_last - in_first;
  auto finite = [&](std::size_t i) {
    return std::isfinite(xyz[3 * i]) && std::isfinite(xyz[3 * i + 1]) && std::isfinite(xyz[3 * i + 2]);
  };
  double ext[6] = {-INFINITY, -INFINITY, -INFINITY, -INFINITY, -INFINITY, -INFINITY};  // -lo, hi
  for (std::size_t i = 0; i < n_mine; ++i)
    if (finite(i))
      for (int a = 0; a < 3; ++a)
        ext[a] = std::max(ext[a], -xyz[3 * i + a]), ext[3 + a] = std::max(ext[3 + a], xyz[3 * i + a]);
  MPI_Allreduce(MPI_IN_PLACE, ext, 6, MPI_DOUBLE, MPI_MAX, comm);
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) lo[a] = -ext[a], hi[a] = ext[3 + a];
  const bool any_finite = lo[0] <= hi[0];
  double scale = 0;
  if (any_finite)
    for (int a = 0; a < 3; ++a) {
      g.origin[a] = 0.5 * (lo[a] + hi[a]);
      if (!(hi[a] - lo[a] <= 1e18))
        throw Error("pcl_delaunay_walk: the finite points span " + std::to_string(hi[a] - lo[a]) +
                    " along an axis; at most 1e18 is supported (float squared distances)");
      scale = std::max(scale, hi[a] - lo[a]);
    }
  const double cell = scale > 0 ? double((1u << 21) - 1) / scale : 0.0;
  std::vector<Item> items;
  items.reserve(n_mine);
  for (std::size_t i = 0; i < n_mine; ++i) {
    if (!finite(i)) continue;
    Item it;
    it.p = {static_cast<float>(xyz[3 * i] - g.origin[0]), static_cast<float>(xyz[3 * i + 1] - g.origin[1]),
            static_cast<float>(xyz[3 * i + 2] - g.origin[2])};
    it.input = static_cast<index_t>(in_first + i);
    std::uint32_t q[3];
    quantise(g.origin.data(), lo, cell, it.p, q);
    it.key = mortonKey(q[0], q[1], q[2]);
    items.push_back(it);
  }

  // 3. Sample sort by Morton key across ranks: rank r receives keys in [split[r], split[r + 1]), so
  // equal keys (and with them exact duplicates) meet on one rank, and concatenating the ranks' sorted
  // items in rank order is the single-process vertex order.
  std::vector<std::uint64_t> split(P + 1, 0);
  split[P] = ~0ull;
  if (P > 1) {
    const std::size_t m = std::min<std::size_t>(items.size(), 4096);
    std::vector<std::uint64_t> sample(m);
    for (std::size_t k = 0; k < m; ++k) sample[k] = items[k * items.size() / m].key;
    std::vector<std::uint64_t> all = allGather(comm, sample);
    std::sort(all.begin(), all.end());
    for (int r = 1; r < P; ++r) split[r] = all.empty() ? ~0ull : all[r * all.size() / P];
  }
  {
    std::vector<std::vector<unsigned char>> send(P);
    std::vector<int> dest(items.size());
    std::vector<std::size_t> cnt(P, 0);
    for (std::size_t i = 0; i < items.size(); ++i) {
      dest[i] = static_cast<int>(std::upper_bound(split.begin() + 1, split.end() - 1, items[i].key) -
                                 split.begin()) -
                1;
      ++cnt[dest[i]];
    }
    for (int r = 0; r < P; ++r) send[r].reserve(cnt[r] * sizeof(Item));
    for (std::size_t i = 0; i < items.size(); ++i) put(send[dest[i]], items[i]);
    std::vector<Item>().swap(items);
    const std::vector<std::vector<unsigned char>> got = exchangeBytes(comm, send);
    send.clear();
    std::size_t total = 0;
    for (const auto& b : got) total += b.size() / sizeof(Item);
    items.resize(total);
    std::size_t at = 0;
    for (const auto& b : got) {
      if (!b.empty()) std::memcpy(&items[at], b.data(), b.size());
      at += b.size() / sizeof(Item);
    }
  }
  std::sort(items.begin(), items.end(), itemLess);
  // Duplicates (equal float positions) collapse onto their first item, as in the single-process run.
  std::vector<std::uint64_t> keys;
  g.originals_offsets.push_back(0);
  for (std::size_t k = 0; k < items.size(); ++k) {
    const bool dup = k > 0 && items[k].p.x == items[k - 1].p.x && items[k].p.y == items[k - 1].p.y &&
                     items[k].p.z == items[k - 1].p.z;
    if (!dup) {
      if (!g.points.empty()) g.originals_offsets.push_back(static_cast<index_t>(g.originals.size()));
      g.points.push_back(items[k].p);
      keys.push_back(items[k].key);
    }
    g.originals.push_back(items[k].input);
  }
  if (!g.points.empty()) g.originals_offsets.push_back(static_cast<index_t>(g.originals.size()));
  std::vector<Item>().swap(items);
  std::uint64_t mine_v = g.points.size(), base = 0, nv = 0;
  MPI_Exscan(&mine_v, &base, 1, MPI_UINT64_T, MPI_SUM, comm);
  if (me == 0) base = 0;
  MPI_Allreduce(&mine_v, &nv, 1, MPI_UINT64_T, MPI_SUM, comm);
  g.first_vertex = static_cast<index_t>(base);
  g.vertices = nv;
  g.timings.sort_s = since(t0);
  checkFault(o.inject_fault, g.rank, "sort");
  progress("sorted " + std::to_string(nv) + " distinct points along the Morton curve");

  // 4. Degenerate or tiny inputs take the single-process path on rank 0 (they are small or flat, and
  // the block method needs a proper 3D triangulation in every block).
  const auto dims = distributedDimension(comm, g.points, base);
  if (nv < 64u * unsigned(P) || dims.second < 3) {
    progress("degenerate input (" + std::to_string(nv) + " vertices, dimension " +
             std::to_string(dims.first) + "): rank 0 builds it alone");
    std::vector<double> all = gatherTo0(comm, xyz);
    g.gathered_fallback = true;
    g.points.clear(), g.originals.clear(), g.originals_offsets.clear(), keys.clear();
    if (me == 0) g.fallback = buildDelaunayGraph(PointView::fromDouble(all.data(), all.size() / 3));
    g.dimension = g.fallback.dimension;
    MPI_Bcast(&g.dimension, 1, MPI_INT, 0, comm);
    return g;
  }

  // 5. The halo grid: cells of 2^k quantisation steps, about 4 points each on volumetric data before
  // options.cell_shift (each step doubles the edge).
  t0 = std::chrono::steady_clock::now();
  CellGrid grid;
  {
    double vol = 1.0;
    for (int a = 0; a < 3; ++a) vol *= std::max(hi[a] - lo[a], scale * 1e-3);
    const double ideal = std::cbrt(vol / std::max(1.0, double(nv) / 4.0)) * cell;  // in quantisation steps
    grid.k = std::clamp(static_cast<int>(std::lround(std::log2(std::max(ideal, 1.0)))), 0, 20);
    grid.k = std::clamp(grid.k + o.cell_shift, 0, 20);
    for (;;) {
      for (int a = 0; a < 3; ++a) {
        const std::uint32_t qmax =
            static_cast<std::uint32_t>(std::clamp((hi[a] - lo[a]) * cell, 0.0, double((1u << 21) - 1)));
        grid.dims[a] = static_cast<int>(qmax >> grid.k) + 1;
      }
      if (grid.numCells() <= (std::size_t(1) << 31) || grid.k == 20) break;
      ++grid.k;
    }
    grid.width = std::ldexp(1.0, grid.k) / cell;
    for (int a = 0; a < 3; ++a) grid.origin[a] = g.origin[a], grid.lo[a] = lo[a];
    grid.qscale = cell;
    for (int a = 0; a < 3; ++a) grid.base[a] = lo[a] - g.origin[a];
    // Quantisation rounds (fp - lo) * cell once and the float-to-world conversion once: far below this.
    grid.slack = 1e-9 * (scale + std::fabs(g.origin[0]) + std::fabs(g.origin[1]) + std::fabs(g.origin[2])) +
                 1e-6 * grid.width;
  }
  g.cells = grid.numCells();
  std::vector<std::uint64_t> occupied((grid.numCells() + 63) / 64, 0);
  for (std::uint64_t key : keys) {
    const std::uint64_t code = key >> (3 * grid.k);
    std::uint32_t xyzc[3] = {0, 0, 0};
    for (int b = 0; b < 21; ++b)
      for (int a = 0; a < 3; ++a) xyzc[a] |= static_cast<std::uint32_t>((code >> (3 * b + a)) & 1u) << b;
    const std::uint32_t c = grid.linear(xyzc[0], xyzc[1], xyzc[2]);
    occupied[c >> 6] |= std::uint64_t{1} << (c & 63);
  }
  MPI_Allreduce(MPI_IN_PLACE, occupied.data(), toInt(occupied.size(), "the cell occupancy"), MPI_UINT64_T,
                MPI_BOR, comm);

  // 6. The block: own vertices plus one ring of cells, triangulated.
  if (nv > Triangulation3D::kMaxVertices)
    throw Error("dw::mpi: " + std::to_string(nv) + " vertices exceed the 3D kernel's limit");
  SparsePoints pts(nv);
  std::copy(g.points.begin(), g.points.end(), pts.data() + base);
  RankBlock block(comm, grid, occupied, split, pts, keys, g.first_vertex,
                  static_cast<index_t>(base + g.points.size()));
  block.triangulate();
  g.timings.block_s = since(t0);
  checkFault(o.inject_fault, g.rank, "block");
  progress("blocks triangulated (own cells plus one ring)");

  // 7. The global hull: its boundary points are on some block's local hull; rank 0 triangulates the
  // candidates and tells everyone the hull vertices with their coordinates.
  t0 = std::chrono::steady_clock::now();
  struct Cand {
    index_t id;
    Vec3f p;
  };
  std::vector<Cand> cand;
  for (index_t h : block.hullVertices()) cand.push_back({h, pts[h]});
  std::vector<Cand> all_cand = gatherTo0(comm, cand);
  std::vector<Cand> hull;
  if (me == 0) {
    std::sort(all_cand.begin(), all_cand.end(), [](const Cand& a, const Cand& b) { return a.id < b.id; });
    all_cand.erase(std::unique(all_cand.begin(), all_cand.end(),
                               [](const Cand& a, const Cand& b) { return a.id == b.id; }),
                   all_cand.end());
    SparsePoints hp(nv);
    std::vector<index_t> ids;
    for (const Cand& c : all_cand) hp[c.id] = c.p, ids.push_back(c.id);
    Triangulation3D k;
    k.setPoints(hp.data(), hp.size());
    const std::vector<index_t> order = brio(ids);
    k.build(order.data(), order.size());
    for (index_t h : k.hullVertices()) {
      const auto it = std::lower_bound(all_cand.begin(), all_cand.end(), h,
                                       [](const Cand& a, index_t id) { return a.id < id; });
      hull.push_back(*it);
    }
  }
  std::uint64_t nh = hull.size();
  MPI_Bcast(&nh, 1, MPI_UINT64_T, 0, comm);
  hull.resize(nh);
  MPI_Bcast(hull.data(), toInt(nh * sizeof(Cand), "the hull"), MPI_BYTE, 0, comm);
  std::vector<index_t> hull_ids;
  for (const Cand& c : hull) {
    if (c.id >= nv) throw Error("dw::mpi: internal inconsistency: hull vertex out of range");
    if (c.id < g.first_vertex || c.id >= base + g.points.size()) pts[c.id] = c.p;
    hull_ids.push_back(c.id);
  }
  g.hull_points = hull_ids.size();
  g.timings.hull_s = since(t0);
  progress("global hull: " + std::to_string(hull_ids.size()) + " vertices");

  // 8. Certify: grow halos (fetching cells) until every tetrahedron around the own vertices is global.
  t0 = std::chrono::steady_clock::now();
  checkFault(o.inject_fault, g.rank, "grow");
  // One rank holds every point: its triangulation is the global one, nothing to certify.
  if (P > 1) block.certify(hull_ids);
  g.edges = block.edges();
  g.halo_points = block.haloPoints();
  g.fetched_points = block.fetchedPoints();
  g.growth_rounds = block.rounds();
  g.halo_exchanges = block.exchanges();
  g.timings.exchange_s = block.exchangeSeconds();
  g.timings.grow_s = since(t0);
  progress("halos certified");
  return g;
}

DelaunayGraph gatherGraph(MPI_Comm comm, RankGraph&& part) {
  DelaunayGraph g;
  if (part.gathered_fallback) return part.rank == 0 ? std::move(part.fallback) : g;
  std::vector<index_t> counts(part.points.size());
  for (std::size_t v = 0; v < counts.size(); ++v)
    counts[v] = part.originals_offsets[v + 1] - part.originals_offsets[v];
  const std::vector<Vec3f> points = gatherTo0(comm, part.points);
  std::vector<Vec3f>().swap(part.points);
  const std::vector<index_t> all_counts = gatherTo0(comm, counts);
  const std::vector<index_t> originals = gatherTo0(comm, part.originals);
  std::vector<index_t>().swap(part.originals);
  EdgeList edges = gatherTo0(comm, part.edges);
  EdgeList().swap(part.edges);
  if (part.rank != 0) return g;
  if (points.size() != part.vertices || all_counts.size() != part.vertices)
    throw Error("dw::mpi: internal inconsistency: gathered vertex count");
  g.origin = part.origin;
  g.dimension = 3;
  g.points = points;
  g.originals = originals;
  g.originals_offsets.assign(1, 0);
  for (index_t c : all_counts) g.originals_offsets.push_back(g.originals_offsets.back() + c);
  if (g.originals_offsets.back() != g.originals.size())
    throw Error("dw::mpi: internal inconsistency: gathered originals");
  g.input_to_vertex.assign(part.input_points, kInvalidIndex);
  for (std::size_t v = 0; v < g.points.size(); ++v)
    for (index_t k = g.originals_offsets[v]; k < g.originals_offsets[v + 1]; ++k) {
      if (g.originals[k] >= part.input_points) throw Error("dw::mpi: internal inconsistency: input index");
      g.input_to_vertex[g.originals[k]] = static_cast<index_t>(v);
    }
  assembleEdges(g, std::move(edges));
  return g;
}

}  // namespace mpi
}  // namespace dw
