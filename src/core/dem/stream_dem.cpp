/// \file stream_dem.cpp
/// \brief The streaming DEM's passes (see stream_dem.h): scan, spill into strips, strips in order.
#include "pcl_delaunay_walk/core/dem/stream_dem.h"

#include <unistd.h>

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
constexpr std::size_t kMaxStrips = 512;
/// Pass 2 keeps one spill file per worker and strip open: workers are limited to keep them within this.
constexpr std::size_t kMaxSpillFiles = 512;

/// One spilled point, 20 bytes packed: the global index and the frame integers (x, y and z or the
/// intensity), from which the frame coordinates and the value are recomputed bit for bit.
constexpr std::size_t kSpillBytes = 20;

/// One spill file: the points one pass-2 worker sent to one strip, in the order it read them.
struct SpillFile {
  std::FILE* f = nullptr;
  std::uint64_t count = 0;
  std::vector<char> buffer;  // stdio's buffer: large writes, not one per 4 KB
  ~SpillFile() {
    if (f) std::fclose(f);
  }
};

/// The points of one input in one strip: `count` records from record `offset` of worker `worker`'s
/// spill file. Inputs are read whole by one worker and in order, so a run's global indices ascend and
/// a strip's runs in input order give its points in ascending index.
struct SpillRun {
  std::size_t input, worker;
  std::uint64_t offset, count;
};

/// The convex hull of points added one by one: hull(points so far) = hull(hull of the earlier ones u
/// the new batch), folded every 65,536 points that may be hull vertices.
struct RunningHull {
  detail::Hull hull;
  detail::Hull core;           // the hull's extreme octagon: points deep inside it are skipped
  std::vector<double> hx, hy;  // the batch

  void add(double x, double y) {
    // Inside the hull of the points so far: no vertex of any later hull (the test only skips work).
    if (detail::deepInside(core, x, y)) return;
    hx.push_back(x), hy.push_back(y);
    if (hx.size() >= (1u << 16)) fold();
  }

  void fold() {
    hx.insert(hx.end(), hull.x.begin(), hull.x.end());
    hy.insert(hy.end(), hull.y.begin(), hull.y.end());
    hull = detail::convexHull(hx.data(), hy.data(), hx.size());
    hx.clear(), hy.clear();
    core = detail::extremeOctagon(hull.x.data(), hull.y.data(), hull.x.size());
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
  std::vector<std::uint64_t> kept_of;  // kept points of each input (pass 1)
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
  double valueOf(std::int32_t v) const {
    return o.intensity ? double(v) : v * first.scale[2] + first.offset[2];
  }

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
    kept_of.assign(o.inputs.size(), 0);
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
              ++part.kept, ++kept_of[i];
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
      for (std::size_t v = 0; v < part.hull.hull.x.size(); ++v)
        all.add(part.hull.hull.x[v], part.hull.hull.y[v]);
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

  void spillAll(const StreamMeshSink* mesh, std::vector<std::vector<SpillFile>>& spill,
                std::vector<std::vector<SpillRun>>& runs);
  detail::StripPoints readStrip(std::size_t s, std::vector<std::vector<SpillFile>>& spill,
                                std::vector<SpillRun>& runs) const;

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

/// Pass 2: every kept point appended to its strip's spill file, the inputs read in parallel, one
/// worker per input at a time (one worker when the mesh sink needs the vertices in input order).
/// Leaves spill[worker][strip] and runs[strip].
void StreamDem::Impl::spillAll(const StreamMeshSink* mesh, std::vector<std::vector<SpillFile>>& spill,
                               std::vector<std::vector<SpillRun>>& runs) {
  const std::size_t strips = seams.size() + 1;
  const unsigned workers = mesh ? 1u
                                : unsigned(std::max<std::size_t>(
                                      1, std::min<std::size_t>({resolveThreads(o.threads), o.inputs.size(),
                                                                kMaxSpillFiles / strips})));
  // stdio buffers of an eighth of the memory limit together, 4 KB to 1 MB each.
  const std::size_t buffer_bytes = std::min<std::size_t>(
      1 << 20, std::max<std::size_t>(4096, o.memory_limit_mb * 131072 / (strips * workers)));
  spill.assign(workers, std::vector<SpillFile>(strips));
  for (auto& of_worker : spill)
    for (SpillFile& f : of_worker) {
      f.f = std::tmpfile();  // unlinked: gone however the run ends
      if (!f.f) throw Error("dw::dem::StreamDem: cannot create a spill file in the temporary folder");
      f.buffer.resize(buffer_bytes);
      std::setvbuf(f.f, f.buffer.data(), _IOFBF, f.buffer.size());
    }
  std::vector<std::uint64_t> first_index(o.inputs.size(), 0);
  for (std::size_t i = 1; i < o.inputs.size(); ++i) first_index[i] = first_index[i - 1] + kept_of[i - 1];
  runs.assign(strips, {});
  std::mutex mutex;  // runs and progress
  std::atomic<std::size_t> next_input{0};
  std::atomic<std::uint64_t> done{0};
  const auto t = Clock::now();
  parallelFor(workers, workers, [&](std::size_t, std::size_t, unsigned w) {
    std::vector<std::uint64_t> in_strip(strips);
    for (std::size_t i; (i = next_input++) < o.inputs.size();) {
      std::uint64_t index = first_index[i];
      std::fill(in_strip.begin(), in_strip.end(), 0);
      forEachPointOf(
          i,
          [&](std::int32_t x, std::int32_t y, std::int32_t v, double wx, double wy, double wz) {
            if (mesh) mesh->vertex(wx, wy, wz);
            const std::size_t s = stripOf(frameY(y));
            char r[kSpillBytes];
            std::memcpy(r, &index, 8), std::memcpy(r + 8, &x, 4), std::memcpy(r + 12, &y, 4),
                std::memcpy(r + 16, &v, 4);
            if (std::fwrite(r, kSpillBytes, 1, spill[w][s].f) != 1)
              throw Error("dw::dem::StreamDem: cannot write a spill file (disk full?)");
            ++index, ++in_strip[s];
          },
          [&](std::size_t records) {
            const std::uint64_t d = done += records;
            std::lock_guard<std::mutex> lock(mutex);
            report("spill", d, t);
          });
      if (index - first_index[i] != kept_of[i])
        throw Error(o.inputs[i] + ": its points changed between the two passes");
      std::lock_guard<std::mutex> lock(mutex);
      for (std::size_t s = 0; s < strips; ++s)
        if (in_strip[s] > 0) {
          runs[s].push_back({i, w, spill[w][s].count, in_strip[s]});
          spill[w][s].count += in_strip[s];
        }
    }
  });
  for (auto& of_worker : spill)
    for (SpillFile& f : of_worker)
      if (std::fflush(f.f) != 0) throw Error("dw::dem::StreamDem: cannot write a spill file (disk full?)");
}

/// Strip s read back from its runs in input order, in pieces on all threads; its spill files closed.
detail::StripPoints StreamDem::Impl::readStrip(std::size_t s, std::vector<std::vector<SpillFile>>& spill,
                                               std::vector<SpillRun>& runs) const {
  std::sort(runs.begin(), runs.end(), [](const SpillRun& a, const SpillRun& b) { return a.input < b.input; });
  constexpr std::uint64_t kPiece = 1 << 16;
  struct Piece {
    const SpillRun* run;
    std::uint64_t first, count, at;  // records [first, first + count) of the run, to position `at`
  };
  std::vector<Piece> pieces;
  std::uint64_t total = 0;
  for (const SpillRun& r : runs) {
    for (std::uint64_t f = 0; f < r.count; f += kPiece)
      pieces.push_back({&r, f, std::min(kPiece, r.count - f), total + f});
    total += r.count;
  }
  detail::StripPoints p;
  p.x.resize(total), p.y.resize(total), p.value.resize(total), p.index.resize(total);
  parallelForDynamic(pieces.size(), o.threads, [&](std::size_t k) {
    const Piece& piece = pieces[k];
    std::vector<char> buf(piece.count * kSpillBytes);
    const int fd = fileno(spill[piece.run->worker][s].f);
    const off_t from = off_t((piece.run->offset + piece.first) * kSpillBytes);
    for (std::size_t got = 0; got < buf.size();) {
      const ssize_t r = pread(fd, buf.data() + got, buf.size() - got, from + off_t(got));
      if (r <= 0) throw Error("dw::dem::StreamDem: cannot read a spill file back");
      got += std::size_t(r);
    }
    for (std::uint64_t i = 0; i < piece.count; ++i) {
      const char* r = buf.data() + i * kSpillBytes;
      const std::size_t to = piece.at + i;
      std::int32_t x, y, v;
      std::memcpy(&p.index[to], r, 8), std::memcpy(&x, r + 8, 4), std::memcpy(&y, r + 12, 4),
          std::memcpy(&v, r + 16, 4);
      p.x[to] = frameX(x), p.y[to] = frameY(y), p.value[to] = valueOf(v);
    }
  });
  for (auto& of_worker : spill) {
    std::fclose(of_worker[s].f);
    of_worker[s].f = nullptr;
    std::vector<char>().swap(of_worker[s].buffer);
  }
  return p;
}

StreamDemStats StreamDem::run(const StreamRowSink& sink, const StreamMeshSink* mesh) {
  Impl& m = *impl_;
  const std::size_t strips = m.seams.size() + 1;
  std::vector<std::vector<SpillFile>> spill;
  std::vector<std::vector<SpillRun>> runs;
  const auto t_spill = Clock::now();
  m.spillAll(mesh, spill, runs);
  m.stats.spill_s = since(t_spill);

  const auto t_strips = Clock::now();
  std::unique_ptr<detail::StreamRaster> raster;
  if (m.o.raster)
    raster = std::make_unique<detail::StreamRaster>(m.fgrid, m.hull, m.o.max_edge / m.k, m.o.nodata, sink,
                                                    m.o.threads);
  detail::StreamTin tin(&m.hull, m.o.threads);
  std::uint64_t done = 0;
  std::vector<std::uint64_t> global;  // one strip's final triangles in global indices, for `mesh`
  for (std::size_t s = 0; s < strips; ++s) {
    const auto t_read = Clock::now();
    detail::StripPoints p = m.readStrip(s, spill, runs[s]);
    m.stats.read_s += since(t_read);
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
      const auto t_flush = Clock::now();
      m.stats.max_rows_held = std::max(m.stats.max_rows_held, raster->rowsHeld());
      raster->flush(s + 1 == strips);
      m.stats.flush_s += since(t_flush);
    }
    m.stats.max_resident = std::max(m.stats.max_resident, tin.residentPoints());
    m.stats.strips = s + 1;
    m.report("strips", done, t_strips);
  }
  if (raster) m.stats.raster = raster->stats();
  const detail::StreamTinTimes& tt = tin.times();
  m.stats.merge_s = tt.merge_s, m.stats.tin_s = tt.tin_s, m.stats.classify_s = tt.classify_s;
  m.stats.emit_s = tt.emit_s, m.stats.frontier_s = tt.frontier_s;
  m.stats.strips_s = since(t_strips);
  return m.stats;
}

}  // namespace dem
}  // namespace dw
