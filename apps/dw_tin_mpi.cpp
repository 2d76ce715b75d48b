/// \file dw_tin_mpi.cpp
/// \brief Distributed Delaunay TIN of a LAS file, or of a pre-split set of LAS files, over MPI ranks.
///   mpirun -np N dw_tin_mpi input.las -o PREFIX        (pieces PREFIX.rank<r>.ply + PREFIX.manifest.json)
///   mpirun -np N dw_tin_mpi a.las b.las ... -o PREFIX  (or --list files.txt: the files' records in order)
///   mpirun -np N dw_tin_mpi input.las --gather -o out.ply
///   mpirun -np N dw_tin_mpi input.las --dem out.vrt --resolution R  (tiles out_tiles/out_r<r>.tif + VRT)
/// Exit status: 0 success; 1 bad input or a failing rank (all ranks are aborted, no manifest); 2 usage;
/// 3 --verify found a difference from the single-process triangulation.
#include <mpi.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "mpi/fault_injection.h"
#ifdef DW_HAVE_GDAL
#include "dem_mosaic.h"
#include "pcl_delaunay_walk/core/las/las_crs.h"
#include "pcl_delaunay_walk/gdal/las_srs.h"
#endif
#include "pcl_delaunay_walk/core/las/las_reader.h"
#include "pcl_delaunay_walk/core/tin/delaunay_tin.h"
#include "pcl_delaunay_walk/mpi/distributed_tin.h"
#include "pcl_delaunay_walk/mpi/las_input_set.h"

namespace {

void usage() {
  std::fprintf(
      stderr,
      "usage: mpirun -np N dw_tin_mpi input.las [more.las ...] [--list FILE] -o PREFIX|out.ply [--gather]\n"
      "                  [--class C] [--threads T] [--verify] [--max-points N] [--quiet]\n"
      "                  [--inject fail|kill:STAGE:RANK]\n"
      "                  [--dem OUT.vrt --resolution R [--bounds X0 Y0 X1 Y1] [--max-edge L] [--nodata V]\n"
      "                   [--value z|intensity]"
      "                   [--float64] [--compress C] [--cog]]\n"
      "  inputs      one LAS file or a pre-split set (several paths and/or --list FILE, one path per\n"
      "              line, relative to FILE's folder): their records in that order are the cloud; every\n"
      "              rank reads only its own range of them\n"
      "  -o PREFIX   per-rank pieces PREFIX.rank<r>.ply and, written last, PREFIX.manifest.json\n"
      "  --gather    one PLY on rank 0 instead (-o out.ply); rank 0 then holds the whole mesh\n"
      "  --class C   keep points of LAS classification C (2 = ground)\n"
      "  --threads T threads per rank for the local triangulations (default 1)\n"
      "  --verify    rank 0 also runs the single-process dw::tin::triangulate and compares\n"
      "  --max-points N  use only the first N records of the input (weak-scaling runs)\n"
      "  --dem OUT.vrt  also the TIN-linear DEM (dw_dem's options): each rank's row band as the\n"
      "              GeoTIFF OUT_tiles/OUT_r<rank>.tif, and rank 0 writes the GDAL VRT mosaic OUT.vrt\n"
      "              (-o is then optional; --value intensity: the DEM only)\n"
      "  --inject    testing: make RANK fail (exception) or be killed at STAGE\n"
      "              (read, leaf, merge, write, dem)\n");
}

std::array<dw::index_t, 3> canonical(const dw::index_t* t) {
  const int m = (t[1] < t[0] && t[1] < t[2]) ? 1 : (t[2] < t[0] && t[2] < t[1]) ? 2 : 0;
  return {t[m], t[(m + 1) % 3], t[(m + 2) % 3]};
}

std::vector<std::array<dw::index_t, 3>> canonicalSet(const std::vector<dw::index_t>& t) {
  std::vector<std::array<dw::index_t, 3>> s(t.size() / 3);
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = canonical(&t[3 * i]);
  std::sort(s.begin(), s.end());
  return s;
}

/// Rank 0: the single-process run on the same frame; true when the triangle sets are identical.
bool verify(const dw::mpi::DistributedTinOptions& o, const std::vector<dw::index_t>& got, unsigned threads) {
  const dw::mpi::LasInputSet input(o.inputs, o.max_records);
  std::vector<double> x, y;
  input.forEach(0, input.size(), [&](const dw::las::LasRecord& r, double px, double py, double) {
    if (o.classification >= 0 && r.classification != o.classification) return;
    x.push_back(px);
    y.push_back(py);
  });
  dw::tin::TinOptions topt;
  topt.num_threads = threads;
  const dw::tin::TinResult ref = dw::tin::triangulate(std::move(x), std::move(y), topt);
  const auto a = canonicalSet(got), b = canonicalSet(ref.triangles);
  const bool twice = std::adjacent_find(a.begin(), a.end()) != a.end();
  std::fprintf(stderr, "verify: distributed %zu triangles%s, single-process %zu: %s\n", a.size(),
               twice ? " (some emitted twice!)" : "", b.size(), a == b ? "IDENTICAL" : "DIFFERENT");
  return a == b;
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  dw::mpi::DistributedTinOptions opt;
  std::string out;
#ifdef DW_HAVE_GDAL
  dw_apps::DemOptions dem;
#endif
  bool gather = false, check = false, quiet = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        if (rank == 0) usage();
        MPI_Finalize();
        std::exit(2);
      }
      return argv[++i];
    };
    try {
      if (a == "-o" || a == "--output") out = next();
#ifdef DW_HAVE_GDAL
      else if (a == "--dem")
        dem.out = next();
      else if (dw_apps::parseDemOption(
                   a, [&]() -> const char* { return (next(), argv[i]); }, dem)) {
        if (!dem.hillshade.empty()) throw std::invalid_argument(a + " (not with dw_tin_mpi)");
      }
#else
      else if (a == "--dem")
        throw std::invalid_argument(a + " (dw_tin_mpi was built without GDAL)");
#endif
      else if (a == "--gather")
        gather = true;
      else if (a == "--class")
        opt.classification = std::stoi(next());
      else if (a == "--threads")
        opt.num_threads = static_cast<unsigned>(std::stoul(next()));
      else if (a == "--verify")
        check = true;
      else if (a == "--max-points")
        opt.max_records = std::stoull(next());
      else if (a == "--quiet")
        quiet = true;
      else if (a == "--inject") {
        opt.inject_fault = next();
        dw::mpi::FaultInjection::parse(opt.inject_fault);  // refuses a bad spec before any rank starts
      } else if (a == "-h" || a == "--help") {
        if (rank == 0) usage();
        MPI_Finalize();
        return 0;
      } else if (a == "--list") {
        const std::vector<std::string> l = dw::mpi::readPathList(next());
        opt.inputs.insert(opt.inputs.end(), l.begin(), l.end());
      } else if (!a.empty() && a[0] != '-')
        opt.inputs.push_back(a);
      else
        throw std::invalid_argument(a);
    } catch (const std::exception&) {
      if (rank == 0) {
        std::fprintf(stderr, "dw_tin_mpi: bad argument '%s'\n", a.c_str());
        usage();
      }
      MPI_Finalize();
      return 2;
    }
  }
  std::string dem_out;
#ifdef DW_HAVE_GDAL
  dem_out = dem.out;
  opt.intensity_as_z = !dem_out.empty() && dem.value == "intensity";
  if (opt.intensity_as_z && !out.empty()) {
    if (rank == 0) std::fprintf(stderr, "dw_tin_mpi: --value intensity writes the DEM only (no -o)\n");
    MPI_Finalize();
    return 2;
  }
  if (!dem_out.empty() && !(dem.resolution > 0)) {
    if (rank == 0) std::fprintf(stderr, "dw_tin_mpi: --dem needs --resolution\n");
    MPI_Finalize();
    return 2;
  }
#endif
  if (opt.inputs.empty() || (out.empty() && dem_out.empty())) {
    if (rank == 0) usage();
    MPI_Finalize();
    return 2;
  }
  if (!quiet)
    opt.progress = [](const std::string& s) { std::fprintf(stderr, "[dw_tin_mpi] %s\n", s.c_str()); };

  int status = 0;
  try {
    // A manifest from an earlier run must not survive a failing one.
    if (rank == 0 && !gather && !out.empty()) std::remove((out + ".manifest.json").c_str());
    MPI_Barrier(MPI_COMM_WORLD);
    const auto t0 = std::chrono::steady_clock::now();
    dw::mpi::RankTin tin = dw::mpi::triangulateDistributed(MPI_COMM_WORLD, opt);
    const auto t1 = std::chrono::steady_clock::now();
    if (out.empty()) {
    } else if (gather) {
      dw::mpi::writeGathered(MPI_COMM_WORLD, out, tin, opt);
    } else {
      dw::mpi::writePiecesAndManifest(MPI_COMM_WORLD, out, tin, opt);
    }
#ifdef DW_HAVE_GDAL
    if (!dem_out.empty()) {
      std::string wkt;
      try {
        wkt = dw::gdal::srsWktFromLas(dw::las::readLasCrs(opt.inputs[0]));
      } catch (const dw::gdal::RasterError& e) {
        if (rank == 0) std::fprintf(stderr, "warning: %s; the raster gets no coordinate system\n", e.what());
      }
      const auto t2 = std::chrono::steady_clock::now();
      const dw_apps::MosaicResult m = dw_apps::writeDemMosaic(
          MPI_COMM_WORLD, dem, tin, wkt, std::max(1u, opt.num_threads), opt.inject_fault);
      if (rank == 0 && !quiet)
        std::fprintf(
            stderr, "dem: raster %zu x %zu, cells set %zu, killed %zu, %zu tiles, %.2f s, wrote %s\n",
            m.grid.cols, m.grid.rows, m.stats.cells_set, m.stats.triangles_killed, m.tiles,
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t2).count(), dem_out.c_str());
    }
#endif
    tin.timings.write_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    // Per-rank timings table on rank 0.
    const double row[8] = {tin.timings.read_s,
                           tin.timings.exchange_s,
                           tin.timings.leaf_s,
                           tin.timings.merge_s,
                           tin.timings.write_s,
                           double(tin.strip_points),
                           double(tin.emitted.triangles.size() / 3),
                           double(tin.emitted.band_points)};
    std::vector<double> rows(8 * static_cast<std::size_t>(size));
    MPI_Gather(row, 8, MPI_DOUBLE, rows.data(), 8, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    if (rank == 0 && !quiet) {
      std::fprintf(stderr,
                   "rank   read_s  exch_s  leaf_s merge_s write_s  strip_pts  emitted_tris  triangulated\n");
      for (int r = 0; r < size; ++r) {
        const double* v = &rows[8 * r];
        std::fprintf(stderr, "%4d %8.2f %7.2f %7.2f %7.2f %7.2f %10.0f %13.0f %13.0f\n", r, v[0], v[1], v[2],
                     v[3], v[4], v[5], v[6], v[7]);
      }
      std::fprintf(stderr, "total %.2f s for %llu points on %d ranks (%.2f M points/s)\n", total,
                   static_cast<unsigned long long>(tin.total_points), size, tin.total_points / total / 1e6);
    }
    if (check) {
      const std::vector<dw::index_t> all = dw::mpi::gatherTriangles(MPI_COMM_WORLD, tin);
      if (rank == 0 && !verify(opt, all, std::max(1u, opt.num_threads))) status = 3;
      MPI_Bcast(&status, 1, MPI_INT, 0, MPI_COMM_WORLD);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_tin_mpi: rank %d of %d failed: %s\n", rank, size, e.what());
    std::fflush(stderr);
    // Other ranks may be blocked in a collective: abort the whole job with a non-zero status.
    MPI_Abort(MPI_COMM_WORLD, 1);
    return 1;
  }
  MPI_Finalize();
  return status;
}
