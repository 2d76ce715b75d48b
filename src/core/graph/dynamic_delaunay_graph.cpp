// DynamicDelaunayGraph: a sliding-window walk graph kept up to date by insertion into and removal from
// one 3D Delaunay triangulation (see dynamic_delaunay_graph.h).
#include "pcl_delaunay_walk/core/graph/dynamic_delaunay_graph.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <unordered_set>

#include "core/builder3d/insertion_order.h"
#include "core/builder3d/triangulation_3d.h"
#include "core/geometry/affine_span.h"
#include "core/util/space_filling_curve.h"
#include "pcl_delaunay_walk/core/graph/graph_builder.h"

namespace dw {

namespace {

const char* const kWhere = "dw::DynamicDelaunayGraph::";

std::uint32_t floatBits(float f) {
  f += 0.0f;  // -0 == +0 for the kernel, so they must collide here too
  std::uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

// The slots in Morton order over their bounding box. A batch goes into a triangulation that already
// surrounds most of it, so each walk should start next to the point before: BRIO's random rounds
// (which bound a fresh build's expected work) made every round walk across the batch again.
std::vector<index_t> mortonOrder(const std::vector<Vec3f>& points, const std::vector<index_t>& slots) {
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (index_t s : slots) {
    const float c[3] = {points[s].x, points[s].y, points[s].z};
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], c[a]), hi[a] = std::max(hi[a], c[a]);
  }
  double extent = 0;
  for (int a = 0; a < 3; ++a) extent = std::max(extent, double(hi[a]) - lo[a]);
  const double cell = extent > 0 ? double((1u << 21) - 1) / extent : 0.0;
  std::vector<std::pair<std::uint64_t, index_t>> keyed(slots.size());
  for (std::size_t i = 0; i < slots.size(); ++i) {
    const Vec3f& p = points[slots[i]];
    auto q = [&](float c, int a) {
      return static_cast<std::uint32_t>(std::min((double(c) - lo[a]) * cell, double((1u << 21) - 1)));
    };
    keyed[i] = {mortonKey(q(p.x, 0), q(p.y, 1), q(p.z, 2)), slots[i]};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<index_t> order(slots.size());
  for (std::size_t i = 0; i < keyed.size(); ++i) order[i] = keyed[i].second;
  return order;
}

}  // namespace

DynamicDelaunayGraph::DynamicDelaunayGraph() : kernel_(std::make_unique<builder3d::Triangulation3D>()) {}
DynamicDelaunayGraph::DynamicDelaunayGraph(DynamicDelaunayGraph&&) noexcept = default;
DynamicDelaunayGraph& DynamicDelaunayGraph::operator=(DynamicDelaunayGraph&&) noexcept = default;
DynamicDelaunayGraph::~DynamicDelaunayGraph() = default;

DynamicDelaunayGraph::DynamicDelaunayGraph(const std::array<double, 3>& origin)
    : origin_(origin), kernel_(std::make_unique<builder3d::Triangulation3D>()) {
  for (double c : origin)
    if (!std::isfinite(c)) throw Error(std::string(kWhere) + "DynamicDelaunayGraph: non-finite origin");
  have_origin_ = true;
}

std::size_t DynamicDelaunayGraph::PositionHash::operator()(const PositionKey& k) const {
  std::uint64_t h = k[0];
  h = h * 0x9E3779B97F4A7C15ull + k[1];
  h = h * 0x9E3779B97F4A7C15ull + k[2];
  return static_cast<std::size_t>(h ^ (h >> 29));
}

DynamicDelaunayGraph::PositionKey DynamicDelaunayGraph::keyOf(const Vec3f& p) {
  return {floatBits(p.x), floatBits(p.y), floatBits(p.z)};
}

index_t DynamicDelaunayGraph::slotOf(PointId id) const {
  const auto it = slot_of_.find(id);
  if (it == slot_of_.end()) throw Error(std::string(kWhere) + "no live point with id " + std::to_string(id));
  return it->second;
}

DynamicDelaunayGraph::PointId DynamicDelaunayGraph::idAt(const Vec3f& local) const {
  const auto it = slot_at_.find(keyOf(local));
  return it == slot_at_.end() ? kNoId : slot_id_[it->second];
}

std::array<double, 3> DynamicDelaunayGraph::position(PointId id) const {
  const Vec3f& p = points_[slotOf(id)];
  return {origin_[0] + p.x, origin_[1] + p.y, origin_[2] + p.z};
}

std::vector<DynamicDelaunayGraph::PointId> DynamicDelaunayGraph::liveIds() const {
  std::vector<PointId> ids;
  ids.reserve(slot_of_.size());
  for (const auto& kv : slot_of_) ids.push_back(kv.first);
  std::sort(ids.begin(), ids.end());
  return ids;
}

std::vector<index_t> DynamicDelaunayGraph::liveSlots() const {
  std::vector<index_t> s;
  s.reserve(slot_of_.size());
  for (index_t k = 0; k < slot_id_.size(); ++k)
    if (slot_id_[k] != kNoId) s.push_back(k);
  return s;
}

void DynamicDelaunayGraph::rebuildIfSpans3D() {
  const std::vector<index_t> slots = liveSlots();
  if (!builder3d::spans3D(points_.data(), slots.data(), slots.size())) return;
  const std::vector<index_t> order = builder3d::brioOrder(points_, slots);
  *kernel_ = builder3d::Triangulation3D();
  kernel_->setPoints(points_.data(), points_.size());
  kernel_->build(order.data(), order.size());
  triangulated_ = true;
  all_dirty_ = true;
}

std::vector<DynamicDelaunayGraph::PointId> DynamicDelaunayGraph::insert(const PointView& view) {
  const std::size_t n = view.size;
  if (n == 0) return {};
  if (view.data == nullptr) throw Error(std::string(kWhere) + "insert: point view without data");
  if (points_.size() + n > builder3d::Triangulation3D::kMaxVertices)
    throw Error(std::string(kWhere) + "insert: more slots than the kernel supports");

  // Everything is checked before anything changes: an insertion is all or nothing.
  std::array<double, 3> origin = origin_;
  if (!have_origin_) {
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (std::size_t i = 0; i < n; ++i) {
      const auto p = view[i];
      for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
    }
    for (int a = 0; a < 3; ++a) origin[a] = std::isfinite(lo[a] + hi[a]) ? 0.5 * (lo[a] + hi[a]) : 0.0;
  }
  std::vector<Vec3f> local(n);
  std::unordered_set<PositionKey, PositionHash> batch;
  batch.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto p = view[i];
    const Vec3f q{static_cast<float>(p[0] - origin[0]), static_cast<float>(p[1] - origin[1]),
                  static_cast<float>(p[2] - origin[2])};
    if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z))
      throw Error(std::string(kWhere) + "insert: point " + std::to_string(i) +
                  " is not finite (or too far from the origin for float)");
    const PositionKey key = keyOf(q);
    const auto live = slot_at_.find(key);
    if (live != slot_at_.end())
      throw Error(std::string(kWhere) + "insert: point " + std::to_string(i) + " repeats live point id " +
                  std::to_string(slot_id_[live->second]) + " (the triangulation needs distinct points)");
    if (!batch.insert(key).second)
      throw Error(std::string(kWhere) + "insert: point " + std::to_string(i) +
                  " repeats an earlier point of the same batch");
    local[i] = q;
  }

  // Slots: recycled ones first. The array may move, so the kernel is pointed at it again.
  origin_ = origin;
  have_origin_ = true;
  std::vector<index_t> slots(n);
  std::vector<PointId> ids(n);
  for (std::size_t i = 0; i < n; ++i) {
    index_t s;
    if (!free_slots_.empty()) {
      s = free_slots_.back();
      free_slots_.pop_back();
      points_[s] = local[i];
      slot_id_[s] = next_id_;
    } else {
      s = static_cast<index_t>(points_.size());
      points_.push_back(local[i]);
      slot_id_.push_back(next_id_);
    }
    slots[i] = s;
    ids[i] = next_id_++;
    slot_of_.emplace(ids[i], s);
    slot_at_.emplace(keyOf(local[i]), s);
  }

  auto undoBookkeeping = [&] {
    for (std::size_t i = 0; i < n; ++i) {
      slot_of_.erase(ids[i]);
      slot_at_.erase(keyOf(local[i]));
      slot_id_[slots[i]] = kNoId;
      free_slots_.push_back(slots[i]);
    }
  };
  if (!triangulated_) {
    try {
      rebuildIfSpans3D();
    } catch (...) {
      triangulated_ = false;
      undoBookkeeping();
      throw;
    }
    return ids;
  }
  kernel_->setPoints(points_.data(), points_.size());
  // Space-filling-curve order keeps consecutive walks short.
  const std::vector<index_t> order = mortonOrder(points_, slots);
  std::size_t done = 0;
  try {
    for (; done < n; ++done) {
      kernel_->insert(order[done]);
      markDirty(order[done], true);
    }
  } catch (...) {
    // The triangulation is unique, so removing what went in restores it exactly.
    all_dirty_ = true;
    while (done > 0) kernel_->remove(order[--done]);
    undoBookkeeping();
    throw;
  }
  return ids;
}

void DynamicDelaunayGraph::remove(const std::vector<PointId>& ids) {
  std::vector<index_t> slots;
  slots.reserve(ids.size());
  {
    std::unordered_set<PointId> seen;
    for (PointId id : ids) {
      const auto it = slot_of_.find(id);
      if (it == slot_of_.end())
        throw Error(std::string(kWhere) + "remove: no live point with id " + std::to_string(id));
      if (!seen.insert(id).second)
        throw Error(std::string(kWhere) + "remove: id " + std::to_string(id) + " is listed twice");
      slots.push_back(it->second);
    }
  }
  if (triangulated_) {
    // Space-filling-curve order: each removal's walk to its vertex starts next to the last one.
    const std::vector<index_t> order = mortonOrder(points_, slots);
    std::size_t done = 0;
    try {
      for (; done < order.size(); ++done) {
        markDirty(order[done], true);  // before: afterwards its neighbours are no longer known
        kernel_->remove(order[done]);
      }
    } catch (const Error&) {
      all_dirty_ = true;
      // The kernel refuses only when the remaining vertices would not span 3D, or on corruption.
      std::vector<index_t> rest = liveSlots();
      std::vector<index_t> gone(order.begin(), order.begin() + done + 1);
      std::sort(gone.begin(), gone.end());
      rest.erase(std::remove_if(rest.begin(), rest.end(),
                                [&](index_t s) { return std::binary_search(gone.begin(), gone.end(), s); }),
                 rest.end());
      if (builder3d::spans3D(points_.data(), rest.data(), rest.size())) {
        while (done > 0) kernel_->insert(order[--done]);
        throw;
      }
      // Below 3D: drop the triangulation; graph() uses the lower-dimensional builders until the
      // points span 3D again.
      *kernel_ = builder3d::Triangulation3D();
      triangulated_ = false;
    }
  }
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (slots[i] < neighbourhood_.size()) neighbourhood_[slots[i]].clear();
    slot_at_.erase(keyOf(points_[slots[i]]));
    slot_of_.erase(ids[i]);
    slot_id_[slots[i]] = kNoId;
    free_slots_.push_back(slots[i]);
  }
}

DelaunayGraph DynamicDelaunayGraph::graph(std::vector<PointId>* input_ids, unsigned num_threads) const {
  const std::vector<PointId> ids = liveIds();
  if (input_ids) *input_ids = ids;
  const std::size_t n = ids.size();
  std::vector<index_t> slot_of_input(n);
  for (std::size_t i = 0; i < n; ++i) slot_of_input[i] = slot_of_.at(ids[i]);

  if (!triangulated_) {
    // Fewer than 4 points or a flat set: the general builder handles it exactly.
    std::vector<Vec3f> pts(n);
    for (std::size_t i = 0; i < n; ++i) pts[i] = points_[slot_of_input[i]];
    BuildOptions options;
    options.num_threads = std::max(1u, num_threads);
    const float* xyz = n ? &pts[0].x : nullptr;
    DelaunayGraph g = buildDelaunayGraph(PointView::fromFloat(xyz, n, sizeof(Vec3f)), options);
    for (int a = 0; a < 3; ++a) g.origin[a] += origin_[a];  // built in the local frame
    return g;
  }

  // Vertices in Morton order over the live bounding box (memory order dominates the walk's speed);
  // positions are the kernel's floats themselves, so the graph is exactly the triangulated geometry.
  DelaunayGraph g;
  g.origin = origin_;
  g.dimension = 3;
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (index_t s : slot_of_input) {
    const float c[3] = {points_[s].x, points_[s].y, points_[s].z};
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], c[a]), hi[a] = std::max(hi[a], c[a]);
  }
  double extent = 0;
  for (int a = 0; a < 3; ++a) extent = std::max(extent, double(hi[a]) - lo[a]);
  const double cell = extent > 0 ? double((1u << 21) - 1) / extent : 0.0;
  std::vector<std::pair<std::uint64_t, index_t>> keyed(n);  // (Morton key, input index)
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3f& p = points_[slot_of_input[i]];
    auto q = [&](float c, int a) {
      return static_cast<std::uint32_t>(std::min((double(c) - lo[a]) * cell, double((1u << 21) - 1)));
    };
    keyed[i] = {mortonKey(q(p.x, 0), q(p.y, 1), q(p.z, 2)), static_cast<index_t>(i)};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<index_t> vertex_of_slot(points_.size(), kInvalidIndex);
  g.points.resize(n);
  g.input_to_vertex.resize(n);
  g.originals.resize(n);
  g.originals_offsets.resize(n + 1);
  for (std::size_t v = 0; v < n; ++v) {
    const index_t input = keyed[v].second;
    const index_t s = slot_of_input[input];
    g.points[v] = points_[s];
    g.input_to_vertex[input] = static_cast<index_t>(v);
    g.originals[v] = input;
    g.originals_offsets[v] = static_cast<index_t>(v);
    vertex_of_slot[s] = static_cast<index_t>(v);
  }
  g.originals_offsets[n] = static_cast<index_t>(n);

  // Edges straight from the tetrahedra, bucketed by the smaller endpoint in vertex (Morton) order.
  // Not Triangulation3D::edgeChunks: its ranges of ids assume ids that follow a space-filling curve,
  // and slots arrive in stream order, where that took several passes over the tetrahedra and left the
  // edge list unsorted for assembleEdges (measured: 40 % of graph() at 200k points).
  static constexpr unsigned kPairs[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  const std::size_t tet_slots = kernel_->tetSlots();
  auto forEachPair = [&](auto&& visit) {
    for (std::size_t t = 0; t < tet_slots; ++t) {
      const index_t* tv = kernel_->tetVertices(t);
      // kDead and kInfinite are the two largest ids: one comparison skips both.
      if (std::max(std::max(tv[0], tv[1]), std::max(tv[2], tv[3])) >= builder3d::Triangulation3D::kDead)
        continue;
      const index_t w[4] = {vertex_of_slot[tv[0]], vertex_of_slot[tv[1]], vertex_of_slot[tv[2]],
                            vertex_of_slot[tv[3]]};
      for (const auto& pr : kPairs) visit(std::min(w[pr[0]], w[pr[1]]), std::max(w[pr[0]], w[pr[1]]));
    }
  };
  std::vector<std::size_t> start(n + 1, 0);
  forEachPair([&](index_t a, index_t) { ++start[a + 1]; });
  for (std::size_t v = 0; v < n; ++v) start[v + 1] += start[v];
  std::vector<index_t> bucket(start[n]);
  {
    std::vector<std::size_t> fill(start.begin(), start.end() - 1);
    forEachPair([&](index_t a, index_t b) { bucket[fill[a]++] = b; });
  }
  EdgeList edges;
  edges.reserve(bucket.size() / 3);
  {
    // Each edge comes once per tetrahedron around it (~5): drop repeats with a stamp, then sort the
    // few distinct ones so that assembleEdges receives a sorted list.
    std::vector<index_t> stamp(n, kInvalidIndex), distinct;
    for (std::size_t a = 0; a < n; ++a) {
      distinct.clear();
      for (std::size_t k = start[a]; k < start[a + 1]; ++k)
        if (stamp[bucket[k]] != a) {
          stamp[bucket[k]] = static_cast<index_t>(a);
          distinct.push_back(bucket[k]);
        }
      std::sort(distinct.begin(), distinct.end());
      for (index_t b : distinct) edges.emplace_back(static_cast<index_t>(a), b);
    }
  }
  std::vector<index_t>().swap(bucket);
  assembleEdges(g, std::move(edges));
  return g;
}

void DynamicDelaunayGraph::collectLink(index_t s, index_t root) {
  const builder3d::TetraMesh& mesh = kernel_->mesh();
  if (tet_seen_.size() < mesh.slots()) tet_seen_.resize(mesh.slots(), 0);
  if (slot_seen_.size() < points_.size()) slot_seen_.resize(points_.size(), 0);
  if (++stamp_ == 0) {  // the stamps wrapped: clear them once
    std::fill(tet_seen_.begin(), tet_seen_.end(), 0u);
    std::fill(slot_seen_.begin(), slot_seen_.end(), 0u);
    stamp_ = 1;
  }
  star_.clear();
  link_.clear();
  star_.push_back(root);
  tet_seen_[root] = stamp_;
  // The star is connected through the faces that hold s: face f holds s unless its opposite vertex
  // (tv[f]) is s.
  for (std::size_t k = 0; k < star_.size(); ++k) {
    const std::size_t c = star_[k];
    const index_t* tv = mesh.vertices(c);
    for (unsigned f = 0; f < 4; ++f) {
      const index_t u = tv[f];
      if (u == s) continue;
      if (u != builder3d::Triangulation3D::kInfinite && slot_seen_[u] != stamp_) {
        slot_seen_[u] = stamp_;
        link_.push_back(u);
      }
      const index_t nb = mesh.tet_n[4 * c + f] >> 2;
      if (tet_seen_[nb] != stamp_) {
        tet_seen_[nb] = stamp_;
        star_.push_back(nb);
      }
    }
  }
}

void DynamicDelaunayGraph::markDirty(index_t s, bool neighbours) {
  if (dirty_.size() < points_.size()) {
    dirty_.resize(points_.size(), 0);
    neighbourhood_.resize(points_.size());
  }
  auto mark = [&](index_t u) {
    if (!dirty_[u]) {
      dirty_[u] = 1;
      dirty_list_.push_back(u);
    }
  };
  mark(s);
  if (!neighbours || all_dirty_) return;
  // An insertion changes the stars of the new vertex and of its cavity's boundary vertices, which are
  // all its neighbours afterwards (an edge inside the cavity joins two of them); a removal changes
  // the stars of its neighbours before it.
  collectLink(s, kernel_->tetOf(s));
  for (index_t u : link_) mark(u);
}

void DynamicDelaunayGraph::recordNeighbourhood(index_t s) {
  // The records exactly as assembleEdges writes them, so the graph equals a fresh extraction. The
  // (m, j) order comes from sorting one 64-bit key per edge (m's float bits, which order like m >= 0,
  // above j), cheaper than sorting the 20-byte records.
  const Vec3f p = points_[s];
  record_keys_.clear();
  for (index_t u : link_) {
    const Vec3f d = points_[u] - p;
    const float m = float(0.5 * std::sqrt(double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z));
    std::uint32_t bits;
    std::memcpy(&bits, &m, sizeof bits);
    record_keys_.push_back(std::uint64_t(bits) << 32 | u);
  }
  std::sort(record_keys_.begin(), record_keys_.end());
  std::vector<EdgeRecord>& out = neighbourhood_[s];
  out.resize(record_keys_.size());
  for (std::size_t k = 0; k < record_keys_.size(); ++k) {
    const index_t u = static_cast<index_t>(record_keys_[k]);
    const Vec3f d = points_[u] - p;
    const double len = std::sqrt(double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z);
    const double inv = len > 0.0 ? 1.0 / len : 0.0;
    out[k] = {float(d.x * inv), float(d.y * inv), float(d.z * inv), float(0.5 * len), u};
  }
  ++last_refreshed_;
}

void DynamicDelaunayGraph::refreshByScan() {
  // Every finite edge lies in a finite tetrahedron: one pass over them lists, per dirty slot, its
  // neighbours (each about five times), bucketed by counting as graph() does.
  static constexpr unsigned kPairs[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  const std::size_t tet_slots = kernel_->tetSlots(), ns = points_.size();
  auto forEachDirtyPair = [&](auto&& visit) {
    for (std::size_t t = 0; t < tet_slots; ++t) {
      const index_t* tv = kernel_->tetVertices(t);
      // kDead and kInfinite are the two largest ids: one comparison skips both.
      if (std::max(std::max(tv[0], tv[1]), std::max(tv[2], tv[3])) >= builder3d::Triangulation3D::kDead)
        continue;
      if (!(dirty_[tv[0]] | dirty_[tv[1]] | dirty_[tv[2]] | dirty_[tv[3]])) continue;
      for (const auto& pr : kPairs) {
        const index_t a = tv[pr[0]], b = tv[pr[1]];
        if (dirty_[a]) visit(a, b);
        if (dirty_[b]) visit(b, a);
      }
    }
  };
  scan_start_.assign(ns + 1, 0);
  forEachDirtyPair([&](index_t a, index_t) { ++scan_start_[a + 1]; });
  for (std::size_t k = 0; k < ns; ++k) scan_start_[k + 1] += scan_start_[k];
  scan_bucket_.resize(scan_start_[ns]);
  scan_fill_.assign(scan_start_.begin(), scan_start_.end() - 1);
  forEachDirtyPair([&](index_t a, index_t b) { scan_bucket_[scan_fill_[a]++] = b; });
  if (slot_seen_.size() < ns) slot_seen_.resize(ns, 0);
  for (index_t s : dirty_list_) {
    dirty_[s] = 0;
    if (slot_id_[s] == kNoId) continue;  // removed since it was marked
    if (++stamp_ == 0) {
      std::fill(tet_seen_.begin(), tet_seen_.end(), 0u);
      std::fill(slot_seen_.begin(), slot_seen_.end(), 0u);
      stamp_ = 1;
    }
    link_.clear();
    for (std::size_t k = scan_start_[s]; k < scan_start_[s + 1]; ++k) {
      const index_t u = scan_bucket_[k];
      if (slot_seen_[u] != stamp_) {
        slot_seen_[u] = stamp_;
        link_.push_back(u);
      }
    }
    recordNeighbourhood(s);
  }
}

void DynamicDelaunayGraph::refreshDirty() {
  if (all_dirty_) {
    for (index_t u : dirty_list_) dirty_[u] = 0;
    dirty_list_.clear();
    for (index_t u : liveSlots()) markDirty(u, false);
    all_dirty_ = false;
  }
  last_refreshed_ = 0;
  // Star by star suits small updates; a pass over all tetrahedra suits large ones (odometry bench,
  // 35k points, 13k to re-read, loaded 2-core box: 2.3 us per star read one by one, 1.5 us per
  // point in the pass). The eighth is a chosen switch, not a measured break-even.
  if (8 * dirty_list_.size() > slot_of_.size()) {
    refreshByScan();
  } else {
    index_t hint = kInvalidIndex;
    for (index_t s : dirty_list_) {
      dirty_[s] = 0;
      if (slot_id_[s] == kNoId) continue;  // removed since it was marked
      hint = kernel_->tetOf(s, hint);
      collectLink(s, hint);
      recordNeighbourhood(s);
    }
  }
  dirty_list_.clear();
}

void DynamicDelaunayGraph::layOutWalkGraph(DelaunayGraph& g, std::vector<PointId>* input_ids) {
  const std::size_t n = slot_of_.size();
  g.origin = origin_;
  g.dimension = 3;
  g.points.resize(n);
  g.offsets.resize(n + 1);
  if (input_ids) input_ids->resize(n);
  vertex_of_slot_.resize(points_.size());
  std::size_t total = 0;
  index_t v = 0;
  for (index_t s = 0; s < points_.size(); ++s) {
    if (slot_id_[s] == kNoId) continue;
    vertex_of_slot_[s] = v;
    g.points[v] = points_[s];
    g.offsets[v] = static_cast<index_t>(total);
    if (input_ids) (*input_ids)[v] = slot_id_[s];
    total += neighbourhood_[s].size();
    ++v;
  }
  g.offsets[n] = static_cast<index_t>(total);
  g.edges.resize(total);
  g.safe_radius2.resize(n);
  EdgeRecord* out = g.edges.data();
  v = 0;
  for (index_t s = 0; s < points_.size(); ++s) {
    if (slot_id_[s] == kNoId) continue;
    for (const EdgeRecord& r : neighbourhood_[s]) *out++ = {r.ex, r.ey, r.ez, r.m, vertex_of_slot_[r.j]};
    ++v;
  }
  g.input_to_vertex.resize(n);
  g.originals.resize(n);
  g.originals_offsets.resize(n + 1);
  for (std::size_t i = 0; i < n; ++i)
    g.input_to_vertex[i] = g.originals[i] = g.originals_offsets[i] = static_cast<index_t>(i);
  g.originals_offsets[n] = static_cast<index_t>(n);
  computeSafeRadii(g);
}

DelaunayGraph::ConstPtr DynamicDelaunayGraph::walkGraph(std::vector<PointId>* input_ids) {
  if (!triangulated_) {
    all_dirty_ = true;  // the next triangulation starts from scratch
    return std::make_shared<const DelaunayGraph>(graph(input_ids, 1));
  }
  refreshDirty();
  // Reused only when no caller holds the last one: a graph handed out never changes.
  if (!walk_graph_ || walk_graph_.use_count() > 1) walk_graph_ = std::make_shared<DelaunayGraph>();
  layOutWalkGraph(*walk_graph_, input_ids);
  return walk_graph_;
}

void DynamicDelaunayGraph::validate() const {
  auto fail = [](const std::string& what) { throw Error(std::string(kWhere) + "validate: " + what); };
  if (slot_id_.size() != points_.size()) fail("slot arrays differ in size");
  if (slot_of_.size() + free_slots_.size() != points_.size()) fail("live plus free slots != slots");
  if (slot_at_.size() != slot_of_.size()) fail("position index out of sync");
  for (const auto& kv : slot_of_) {
    if (kv.second >= points_.size() || slot_id_[kv.second] != kv.first) fail("id map out of sync");
    const auto at = slot_at_.find(keyOf(points_[kv.second]));
    if (at == slot_at_.end() || at->second != kv.second) fail("position index misses a live point");
  }
  for (index_t s : free_slots_)
    if (s >= points_.size() || slot_id_[s] != kNoId) fail("a free slot holds an id");
  const std::vector<index_t> live = liveSlots();
  if (triangulated_) {
    kernel_->validate();
    if (kernel_->numVertices() != live.size())
      fail("the triangulation's vertex count differs from the live count");
  } else if (builder3d::spans3D(points_.data(), live.data(), live.size())) {
    fail("the live points span 3D but no triangulation is kept");
  }
}

}  // namespace dw
