/// \file stream_stage.h
/// \brief The streamed run shared by `dw_dem --stream` and `dw_tin --stream`: LAS/LAZ tiles read strip
/// by strip (dw::dem::StreamDem), the DEM's final rows written to the GeoTIFF as they come (with GDAL)
/// and the TIN's final triangles to a PLY as they come, with progress on stderr (docs/dem.md "Beyond
/// memory", docs/tin.md "Streamed TIN"). Each output goes to a temporary renamed over its target only
/// when complete, so a failed run leaves existing files as they were.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/util/process_memory.h"
#include "pcl_delaunay_walk/core/dem/stream_dem.h"
#include "pcl_delaunay_walk/core/tin/ply_writer.h"
#ifdef DW_HAVE_GDAL
#include "dem_stage.h"
#endif

namespace dw_apps {

/// What a streamed run reads and writes.
struct StreamRequest {
  std::vector<std::string> inputs;  ///< tiles of one survey, one cloud
  int classification = -1;
  std::size_t memory_limit_mb = 1024;
  unsigned threads = 1;
  bool quiet = false;
#ifdef DW_HAVE_GDAL
  const DemOptions* dem = nullptr;  ///< the GeoTIFF (out, resolution, ...); null: no raster
#endif
  std::string ply;  ///< the TIN as a binary PLY; empty: none
  std::vector<std::string> ply_comments;
};

/// One line on stderr, at most every second and once at the end of each stage: points read of the
/// stage's total, then (once pass 1 has planned them) strips done, rows written (with a raster),
/// triangles written (with a PLY), and the rate, seconds so far and the stage's time left.
class StreamProgress {
 public:
  std::size_t rows_written = 0;
  std::uint64_t triangles_written = 0;
  bool mesh = false;
  void operator()(const dw::dem::StreamDemProgress& p) {
    const bool end = p.points_read >= p.points_total;
    if (p.elapsed_s - last_ < 1.0 && !end && p.stage == stage_) return;
    last_ = p.elapsed_s;
    stage_ = p.stage;
    std::fprintf(stderr, "\r  %-6s points %llu of %llu", p.stage, (unsigned long long)p.points_read,
                 (unsigned long long)p.points_total);
    if (std::string(p.stage) != "scan") {
      std::fprintf(stderr, "  strips %zu of %zu", p.strips_done, p.strips);
      if (p.rows) std::fprintf(stderr, "  rows %zu of %zu", rows_written, p.rows);
      if (mesh) std::fprintf(stderr, "  triangles %llu", (unsigned long long)triangles_written);
    }
    std::fprintf(stderr, "  %.2f M points/s  %.0f s, left %.0f s   %s", p.rate / 1e6, p.elapsed_s, p.left_s,
                 end ? "\n" : "");
  }

 private:
  double last_ = -1;
  const char* stage_ = nullptr;
};

/// Runs the request and prints the report on stdout ("strips N" among it); throws dw::Error.
inline dw::dem::StreamDemStats runStreamed(const StreamRequest& r) {
  const auto t0 = std::chrono::steady_clock::now();
  dw::dem::StreamDemOptions o;
  o.inputs = r.inputs;
  o.classification = r.classification;
  o.memory_limit_mb = r.memory_limit_mb;
  o.threads = r.threads;
  o.raster = false;
#ifdef DW_HAVE_GDAL
  if (r.dem) {
    const DemOptions& d = *r.dem;
    o.raster = true;
    o.intensity = d.value == "intensity";
    o.resolution = d.resolution;
    o.has_bounds = d.has_bounds;
    std::copy(d.bounds, d.bounds + 4, o.bounds);
    o.max_edge = d.max_edge;
    o.nodata = d.tiff.nodata;
  }
#endif
  StreamProgress progress;
  progress.mesh = !r.ply.empty();
  std::function<void(const dw::dem::StreamDemProgress&)> show;
  if (!r.quiet) show = [&](const dw::dem::StreamDemProgress& p) { progress(p); };
  dw::dem::StreamDem stream(o, show);  // pass 1: bounds, hull, strips

  std::unique_ptr<dw::tin::PlyMeshWriter> ply;
  dw::dem::StreamMeshSink mesh;
  if (!r.ply.empty()) {
    ply = std::make_unique<dw::tin::PlyMeshWriter>(
        r.ply, stream.points(), dw::tin::PlyMeshWriter::kFacesCountedAtClose, r.ply_comments);
    mesh.vertex = [&](double x, double y, double z) { ply->vertex(x, y, z); };
    mesh.triangles = [&](const std::uint64_t* t, std::size_t count) {
      for (std::size_t i = 0; i < 3 * count; i += 3)
        ply->face(dw::index_t(t[i]), dw::index_t(t[i + 1]), dw::index_t(t[i + 2]));
      progress.triangles_written += count;
    };
  }
  dw::dem::StreamRowSink rows;
#ifdef DW_HAVE_GDAL
  std::unique_ptr<dw::gdal::GeoTiffWriter> tif;
  if (r.dem) {
    dw::gdal::GeoTiffOptions tiff = r.dem->tiff;
    tiff.srs_wkt = lasCrsWkt(r.inputs, r.quiet);
    tiff.num_threads = r.threads;
    tif = std::make_unique<dw::gdal::GeoTiffWriter>(r.dem->out, stream.grid(), tiff);
    rows = [&](std::size_t row, std::size_t k, const double* v) {
      tif->writeRows(row, k, v);
      progress.rows_written = row + k;
    };
  }
#endif
  const dw::dem::StreamDemStats st = stream.run(rows, ply ? &mesh : nullptr);
#ifdef DW_HAVE_GDAL
  if (tif) tif->commit();
#endif
  if (ply) ply->close();

  const dw::dem::RasterGrid& g = stream.grid();
  std::printf("points %llu  triangles %llu", (unsigned long long)st.points, (unsigned long long)st.triangles);
  if (o.raster)
    std::printf("  killed %zu  raster %zu x %zu (%.6g units)  cells set %zu of %zu",
                st.raster.triangles_killed, g.cols, g.rows, g.cell, st.raster.cells_set, g.size());
  std::printf("\nstrips %zu (largest %zu points)  resident at most %zu points", st.strips,
              st.max_strip_points, st.max_resident);
  if (o.raster) std::printf("  rows held at most %zu", st.max_rows_held);
  std::printf("\n");
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("threads %u  scan %.3f s  spill %.3f s  strips %.3f s  total %.3f s\n", r.threads, st.scan_s,
              st.spill_s, st.strips_s, total);
  const long peak = dw::processStatusKb("VmHWM:");
  std::printf("peak memory %.1f MB (%.1f bytes/point)  wrote", peak / 1024.0,
              peak * 1024.0 / double(st.points));
#ifdef DW_HAVE_GDAL
  if (r.dem) std::printf(" %s", r.dem->out.c_str());
#endif
  if (ply)
    std::printf("%s %s (%llu vertices: every kept point, input order)", o.raster ? " and" : "", r.ply.c_str(),
                (unsigned long long)st.points);
  std::printf("\n");
  return st;
}

}  // namespace dw_apps
