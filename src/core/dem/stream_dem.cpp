/// \file stream_dem.cpp
/// \brief The streaming DEM's passes (see stream_dem.h): scan, spill into strips, strips in order.
#include "pcl_delaunay_walk/core/dem/stream_dem.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <mutex>

#include "core/dem/stream_frontier.h"
#include "core/dem/stream_raster.h"
#include "core/dem/stream_tin.h"
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {
namespace dem {

namespace {

using Clock = std::chrono::steady_clock;
using las::LasHeader;
using las::LasReader;
using las::LasRecord;
double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

/// Bytes a strip's point costs at its peak: the in-memory TIN's ~72 bytes and its input copy, the
/// merged arrays, the triangles, the edge index and the labels (docs/dem.md "Beyond memory").
constexpr std::size_t kBytesPerStripPoint = 260;
constexpr std::size_t kHistogramBins = 1 << 16;
constexpr std::size_t kMaxStrips = 512;  // one open spill file each

/// One spilled point, 20 bytes packed: the global index and the frame integers (x, y and z or the
/// intensity), from which the frame coordinates and the value are recomputed bit for bit.
constexpr std::size_t kSpillBytes = 20;

struct Spill {
  std::FILE* f = nullptr;
  std::uint64_t count = 0;
  std::vector<char> buffer;  // stdio's buffer: large writes, not one per 4 KB
  ~Spill() {
    if (f) std::fclose(f);
  }
};

/// The convex hull of points added one by one: hull(points so far) = hull(hull of the earlier ones u
/// the new batch), folded every 65,536 points that may be hull vertices.
struct RunningHull {
  detail::Hull hull;
  std::vector<double> core_x, core_y;  // see insideCore
  std::vector<double> hx, hy;          // the batch

  void add(double x, double y) {
    if (insideCore(x, y)) return;
    hx.push_back(x), hy.push_back(y);
    if (hx.size() >= (1u << 16)) fold();
  }

  void fold() {
    hx.insert(hx.end(), hull.x.begin(), hull.x.end());
    hy.insert(hy.end(), hull.y.begin(), hull.y.end());
    hull = detail::convexHull(hx.data(), hy.data(), hx.size());
    hx.clear(), hy.clear();
    // The hull's extreme vertices in eight directions, counter-clockwise: a polygon inside the hull.
    core_x.clear(), core_y.clear();
    for (int d = 0; d < 8 && hull.x.size() >= 3; ++d) {
      const double cx = std::cos(d * 0.7853981633974483), cy = std::sin(d * 0.7853981633974483);
      std::size_t best = 0;
      for (std::size_t i = 1; i < hull.x.size(); ++i)
        if (hull.x[i] * cx + hull.y[i] * cy > hull.x[best] * cx + hull.y[best] * cy) best = i;
      if (core_x.empty() || core_x.back() != hull.x[best] || core_y.back() != hull.y[best])
        core_x.push_back(hull.x[best]), core_y.push_back(hull.y[best]);
    }
  }

  /// Whether (x, y) lies inside the core polygon by a margin far above rounding: then it is inside the
  /// hull of the points so far and cannot be a vertex of any later hull (it only skips work).
  bool insideCore(double x, double y) const {
    const std::size_t m = core_x.size();
    if (m < 3) return false;
    for (std::size_t i = 0; i < m; ++i) {
      const std::size_t j = (i + 1) % m;
      const double ex = core_x[j] - core_x[i], ey = core_y[j] - core_y[i];
      const double wx = x - core_x[i], wy = y - core_y[i];
      const double slack = 1e-9 * (std::fabs(ex) + std::fabs(ey)) *
                           (std::fabs(core_x[i]) + std::fabs(core_y[i]) + std::fabs(x) + std::fabs(y) + 1.0);
      if (!(ex * wy - ey * wx > slack)) return false;
    }
    return true;
  }
};

/// What pass 1 learns from some of the files; parts combine exactly in any order (counts and
/// histograms add, bounds take min/max, the hull of the union is the hull of the parts' hulls, and
/// convexHull's output depends only on the set of points).
struct ScanPart {
  std::uint64_t kept = 0, records = 0;
  double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
  std::vector<std::uint64_t> hist;
  RunningHull hull;
};

}  // namespace

struct StreamDem::Impl {
  StreamDemOptions o;
  std::function<void(const StreamDemProgress&)> progress;
  LasHeader first;
  double k = 1;  // frame: world = frame * k + offset (LAS integers when the x and y scales agree)
  bool same_scale = true;
  std::uint64_t total_records = 0, kept = 0;
  double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
  double hist_lo = 0, hist_hi = 0;
  std::vector<std::uint64_t> hist;
  detail::Hull hull;
  RasterGrid grid, fgrid;
  std::vector<double> seams;  // descending; strip s: seams[s] <= y < seams[s - 1]
  StreamDemStats stats;
  Clock::time_point t0 = Clock::now();

  /// The frame coordinates and the value of a point's integers (LAS units of the first input).
  double frameX(std::int32_t x) const { return same_scale ? double(x) : x * first.scale[0]; }
  double frameY(std::int32_t y) const { return same_scale ? double(y) : y * first.scale[1]; }
  double valueOf(std::int32_t v) const { return o.intensity ? double(v) : v * first.scale[2] + first.offset[2]; }

  /// Reads every kept point of input i in order, as (x, y, v, world x, y, z): x, y the integers in
  /// the first input's frame, v its z integer or its intensity; after each chunk, chunk(records).
  template <class F, class C>
  void forEachPointOf(std::size_t i, F&& f, C&& chunk_done) const {
    std::vector<LasRecord> chunk;
    LasReader reader(o.inputs[i]);
    const LasHeader& h = reader.header();
    std::int64_t shift[3] = {0, 0, 0};
    for (int a = 0; a < 3 && i > 0; ++a) {
      const double d = (h.offset[a] - first.offset[a]) / first.scale[a];
      if (h.scale[a] != first.scale[a] || d != std::round(d) || std::fabs(d) > 4e9)
        throw Error(o.inputs[i] + ": its LAS scale and offset do not share the first input's integer grid");
      shift[a] = std::int64_t(d);
    }
    while (reader.read(chunk, 1 << 16) > 0) {
      for (const LasRecord& r : chunk) {
        if (o.classification >= 0 && r.classification != o.classification) continue;
        const std::int64_t X = r.X + shift[0], Y = r.Y + shift[1], Z = r.Z + shift[2];
        if (X < INT32_MIN || X > INT32_MAX || Y < INT32_MIN || Y > INT32_MAX || Z < INT32_MIN ||
            Z > INT32_MAX)
          throw Error(o.inputs[i] + ": a coordinate leaves the first input's frame");
        const std::int32_t x = std::int32_t(X), y = std::int32_t(Y);
        const std::int32_t v = o.intensity ? std::int32_t(r.intensity) : std::int32_t(Z);
        f(x, y, v, x * first.scale[0] + first.offset[0], y * first.scale[1] + first.offset[1],
          std::int32_t(Z) * first.scale[2] + first.offset[2]);
      }
      chunk_done(chunk.size());
    }
  }

  /// Every kept point of every input in order, as (index, x, y, v, world x, y, z).
  template <class F>
  void forEachPoint(const char* stage, F&& f) {
    std::uint64_t index = 0, done = 0;
    const auto t = Clock::now();
    for (std::size_t i = 0; i < o.inputs.size(); ++i)
      forEachPointOf(
          i,
          [&](std::int32_t x, std::int32_t y, std::int32_t v, double wx, double wy, double wz) {
            f(index++, x, y, v, wx, wy, wz);
          },
          [&](std::size_t records) { report(stage, done += records, t); });
  }

  void report(const char* stage, std::uint64_t done, Clock::time_point t) {
    if (!progress) return;
    StreamDemProgress p;
    p.stage = stage;
    p.points_read = done;
    p.points_total = std::string(stage) == "strips" ? kept : total_records;
    p.strips_done = stats.strips;
    p.strips = seams.size() + 1;
    p.rows = grid.rows;
    p.elapsed_s = since(t0);
    const double dt = since(t);
    p.rate = dt > 0 ? double(done) / dt : 0;
    p.left_s = p.rate > 0 ? double(p.points_total - std::min(done, p.points_total)) / p.rate : 0;
    progress(p);
  }

  void scan() {
    for (const std::string& path : o.inputs) {
      LasReader r(path);
      total_records += r.header().point_count;
      if (&path == &o.inputs[0]) first = r.header();
    }
    same_scale = first.scale[0] == first.scale[1];
    k = same_scale ? first.scale[0] : 1.0;
    // The histogram spans the headers' y bounds in the frame; points outside (a lying header) fall
    // into the end bins, which only makes strips uneven.
    hist_lo = HUGE_VAL, hist_hi = -HUGE_VAL;
    for (const std::string& path : o.inputs) {
      LasReader r(path);
      const double off = same_scale ? first.offset[1] : 0.0;
      hist_lo = std::min(hist_lo, (r.header().min[1] - off) / k);
      hist_hi = std::max(hist_hi, (r.header().max[1] - off) / k);
    }
    // The files in parallel, one at a time per worker, each worker with its own part.
    const unsigned workers = std::min<unsigned>(resolveThreads(o.threads), unsigned(o.inputs.size()));
    std::vector<ScanPart> parts(workers);
    std::atomic<std::size_t> next_file{0};
    std::atomic<std::uint64_t> done{0};
    std::mutex report_mutex;
    const auto t = Clock::now();
    parallelFor(workers, workers, [&](std::size_t, std::size_t, unsigned w) {
      ScanPart& part = parts[w];
      part.hist.assign(kHistogramBins, 0);
      for (std::size_t i; (i = next_file++) < o.inputs.size();) {
        forEachPointOf(
            i,
            [&](std::int32_t x, std::int32_t y, std::int32_t, double wx, double wy, double) {
              const double fx = frameX(x), fy = frameY(y);
              ++part.kept;
              part.lo[0] = std::min(part.lo[0], wx), part.hi[0] = std::max(part.hi[0], wx);
              part.lo[1] = std::min(part.lo[1], wy), part.hi[1] = std::max(part.hi[1], wy);
              part.hist[bin(fy)]++;
              part.hull.add(fx, fy);
            },
            [&](std::size_t records) {
              const std::uint64_t d = done += records;
              std::lock_guard<std::mutex> lock(report_mutex);
              report("scan", d, t);
            });
      }
      part.hull.fold();
    });
    hist.assign(kHistogramBins, 0);
    RunningHull all;
    for (ScanPart& part : parts) {
      kept += part.kept;
      for (int a = 0; a < 2; ++a) lo[a] = std::min(lo[a], part.lo[a]), hi[a] = std::max(hi[a], part.hi[a]);
      for (std::size_t b = 0; b < kHistogramBins; ++b) hist[b] += part.hist[b];
      for (std::size_t v = 0; v < part.hull.hull.x.size(); ++v) all.add(part.hull.hull.x[v], part.hull.hull.y[v]);
      part = ScanPart();
    }
    all.fold();
    hull = all.hull;
    if (kept == 0)
      throw Error((o.inputs.size() == 1 ? o.inputs[0] : "the inputs") + ": no points" +
                  (o.classification >= 0 ? " of class " + std::to_string(o.classification) : std::string()));
    stats.points = kept;
    stats.scan_s = since(t0);
  }

  std::size_t bin(double fy) const {
    const double w = (hist_hi - hist_lo) / double(kHistogramBins);
    if (!(w > 0)) return 0;
    const double b = std::floor((fy - hist_lo) / w);
    return b < 0 ? 0 : (b >= double(kHistogramBins) ? kHistogramBins - 1 : std::size_t(b));
  }

  void plan() {
    if (o.raster) planGrid();
    planStrips();
  }

  void planGrid() {
    grid = o.has_bounds ? gridFromBounds(o.bounds[0], o.bounds[1], o.bounds[2], o.bounds[3], o.resolution)
                        : alignedGridCovering(lo[0], lo[1], hi[0], hi[1], o.resolution);
    if (grid.cols > 2147483647u || grid.rows > 2147483647u)
      throw Error("a raster of " + std::to_string(grid.cols) + " x " + std::to_string(grid.rows) +
                  " cells exceeds 2^31 - 1 cells a side");
    fgrid = grid;
    fgrid.west = (grid.west - (same_scale ? first.offset[0] : 0.0)) / k;
    fgrid.north = (grid.north - (same_scale ? first.offset[1] : 0.0)) / k;
    fgrid.cell = grid.cell / k;
  }

  void planStrips() {
    std::uint64_t per_strip =
        std::max<std::uint64_t>(1024, o.memory_limit_mb * 1048576ull / kBytesPerStripPoint);
    per_strip = std::max<std::uint64_t>(per_strip, kept / kMaxStrips + 1);
    // Bins from the north; a seam at a bin's lower edge once the strip holds per_strip points.
    const double w = (hist_hi - hist_lo) / double(kHistogramBins);
    std::uint64_t acc = 0;
    for (std::size_t b = kHistogramBins; b-- > 1;) {
      acc += hist[b];
      if (acc >= per_strip) {
        seams.push_back(hist_lo + double(b) * w);
        acc = 0;
      }
    }
  }

  std::size_t stripOf(double fy) const {  // seams descending: the number of seams > fy
    return std::size_t(std::upper_bound(seams.begin(), seams.end(), fy, std::greater<double>()) -
                       seams.begin());
  }
};

StreamDem::StreamDem(const StreamDemOptions& options, std::function<void(const StreamDemProgress&)> progress)
    : impl_(std::make_unique<Impl>()) {
  if (options.inputs.empty()) throw Error("dw::dem::StreamDem: no input file");
  impl_->o = options;
  impl_->progress = std::move(progress);
  impl_->scan();
  impl_->plan();
}

StreamDem::~StreamDem() = default;

const RasterGrid& StreamDem::grid() const {
  return impl_->grid;
}

std::uint64_t StreamDem::points() const {
  return impl_->kept;
}

StreamDemStats StreamDem::run(const StreamRowSink& sink, const StreamMeshSink* mesh) {
  Impl& m = *impl_;
  const std::size_t strips = m.seams.size() + 1;
  std::vector<Spill> spill(strips);
  // stdio buffers of an eighth of the memory limit together, 4 KB to 1 MB each.
  const std::size_t buffer_bytes =
      std::min<std::size_t>(1 << 20, std::max<std::size_t>(4096, m.o.memory_limit_mb * 131072 / strips));
  for (Spill& s : spill) {
    s.f = std::tmpfile();  // unlinked: gone however the run ends
    if (!s.f) throw Error("dw::dem::StreamDem: cannot create a spill file in the temporary folder");
    s.buffer.resize(buffer_bytes);
    std::setvbuf(s.f, s.buffer.data(), _IOFBF, s.buffer.size());
  }
  const auto t_spill = Clock::now();
  m.forEachPoint("spill", [&](std::uint64_t index, std::int32_t x, std::int32_t y, std::int32_t v, double wx,
                              double wy, double wz) {
    if (mesh) mesh->vertex(wx, wy, wz);
    Spill& s = spill[m.stripOf(m.frameY(y))];
    char r[kSpillBytes];
    std::memcpy(r, &index, 8), std::memcpy(r + 8, &x, 4), std::memcpy(r + 12, &y, 4), std::memcpy(r + 16, &v, 4);
    if (std::fwrite(r, kSpillBytes, 1, s.f) != 1) throw Error("dw::dem::StreamDem: cannot write a spill file");
    ++s.count;
  });
  for (Spill& s : spill)
    if (std::fflush(s.f) != 0) throw Error("dw::dem::StreamDem: cannot write a spill file");
  m.stats.spill_s = since(t_spill);

  const auto t_strips = Clock::now();
  std::unique_ptr<detail::StreamRaster> raster;
  if (m.o.raster)
    raster = std::make_unique<detail::StreamRaster>(m.fgrid, m.hull, m.o.max_edge / m.k, m.o.nodata, sink,
                                                    m.o.threads);
  detail::StreamTin tin(&m.hull, m.o.threads);
  std::uint64_t done = 0;
  std::vector<char> buf;
  std::vector<std::uint64_t> global;  // one strip's final triangles in global indices, for `mesh`
  for (std::size_t s = 0; s < strips; ++s) {
    detail::StripPoints p;
    const std::size_t count = spill[s].count;
    buf.resize(count * kSpillBytes);
    std::rewind(spill[s].f);
    if (count > 0 && std::fread(buf.data(), kSpillBytes, count, spill[s].f) != count)
      throw Error("dw::dem::StreamDem: cannot read a spill file back");
    std::fclose(spill[s].f);
    spill[s].f = nullptr;
    std::vector<char>().swap(spill[s].buffer);
    p.x.resize(count), p.y.resize(count), p.value.resize(count), p.index.resize(count);
    for (std::size_t i = 0; i < count; ++i) {
      const char* r = buf.data() + i * kSpillBytes;
      std::int32_t x, y, v;
      std::memcpy(&p.index[i], r, 8), std::memcpy(&x, r + 8, 4), std::memcpy(&y, r + 12, 4), std::memcpy(&v, r + 16, 4);
      p.x[i] = m.frameX(x), p.y[i] = m.frameY(y), p.value[i] = m.valueOf(v);
    }
    std::vector<char>().swap(buf);
    m.stats.max_strip_points = std::max(m.stats.max_strip_points, p.size());
    done += p.size();
    const double seam = s + 1 < strips ? m.seams[s] : -HUGE_VAL;
    tin.addStrip(std::move(p), seam, [&](const detail::StripPoints& pts, const std::vector<index_t>& t) {
      m.stats.triangles += t.size() / 3;
      if (raster) raster->add(pts, t);
      if (!mesh) return;
      global.resize(t.size());
      for (std::size_t i = 0; i < t.size(); ++i) global[i] = pts.index[t[i]];
      mesh->triangles(global.data(), t.size() / 3);
    });
    if (raster) {
      m.stats.max_rows_held = std::max(m.stats.max_rows_held, raster->rowsHeld());
      raster->flush(s + 1 == strips);
    }
    m.stats.max_resident = std::max(m.stats.max_resident, tin.residentPoints());
    m.stats.strips = s + 1;
    m.report("strips", done, t_strips);
  }
  if (raster) m.stats.raster = raster->stats();
  m.stats.strips_s = since(t_strips);
  return m.stats;
}

}  // namespace dem
}  // namespace dw
