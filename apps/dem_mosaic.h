/// \file dem_mosaic.h
/// \brief The DEM stage of dw_tin_mpi: the grid fixed from the global bounds, each rank's row band of the
/// raster (dw::mpi::rasterizeBands) written as OUT_tiles/<name>_rNNN.tif, and the GDAL VRT mosaic OUT on
/// rank 0 (docs/mpi.md, "The DEM"). Options, grid and frame come from dem_stage.h, as for dw_dem.
/// Written in two phases so that a failure leaves an existing mosaic whole: every rank first finishes
/// its tile under a temporary name; only when all have, the old VRT is removed, the tiles renamed into
/// place and the new VRT written (a failing rename can then leave no VRT, never a mixed one).
#pragma once

#include <mpi.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "dem_stage.h"
#include "mpi/fault_injection.h"
#include "pcl_delaunay_walk/gdal/vrt_mosaic.h"
#include "pcl_delaunay_walk/mpi/distributed_raster.h"

namespace dw_apps {

struct MosaicResult {
  dw::dem::RasterGrid grid;
  dw::dem::TinRasterStats stats;
  std::size_t tiles = 0;
};

/// Where rank r's tile goes: "<out without .vrt>_tiles/<name>_r<r, 3 digits or more>.tif"; `relative`
/// is the same path relative to the VRT's folder.
inline std::string tilePath(const std::string& vrt, int r, std::string* relative = nullptr) {
  const std::string stem =
      vrt.size() > 4 && vrt.compare(vrt.size() - 4, 4, ".vrt") == 0 ? vrt.substr(0, vrt.size() - 4) : vrt;
  const std::size_t slash = stem.find_last_of('/');
  const std::string name = slash == std::string::npos ? stem : stem.substr(slash + 1);
  char num[16];
  std::snprintf(num, sizeof num, "%03d", r);
  const std::string rel = name + "_tiles/" + name + "_r" + num + ".tif";
  if (relative) *relative = rel;
  return (slash == std::string::npos ? std::string() : stem.substr(0, slash + 1)) + rel;
}

/// Collective: true when every rank passes ok.
inline bool allOk(MPI_Comm comm, bool ok) {
  int v = ok ? 1 : 0;
  MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_INT, MPI_MIN, comm);
  return v == 1;
}

/// Collective: the mosaic of `tin` (world = frame * scale + offset, equal x and y scales) with the CRS
/// `srs_wkt`. Throws dw::Error on every rank when any rank failed (its message on that rank).
inline MosaicResult writeDemMosaic(MPI_Comm comm, const DemOptions& d, const dw::mpi::RankTin& tin,
                                   const std::string& srs_wkt, unsigned threads,
                                   const std::string& inject_fault) {
  if (tin.frame.scale[0] != tin.frame.scale[1])
    throw dw::Error("--dem: the input's x and y scales differ; the DEM needs one frame scale");
  const Frame frame{tin.frame.scale[0], tin.frame.offset[0], tin.frame.offset[1]};
  double lo[2], hi[2];
  const bool any = dw::mpi::globalFrameBox(comm, tin, lo, hi);
  if (!any && !d.has_bounds)
    throw dw::Error("--dem: the points are collinear (no triangle); give --bounds for an all-nodata raster");
  for (int k = 0; k < 2 && any; ++k) {
    lo[k] = lo[k] * frame.k + (k ? frame.off_y : frame.off_x);
    hi[k] = hi[k] * frame.k + (k ? frame.off_y : frame.off_x);
  }
  MosaicResult res;
  res.grid = demGrid(d, lo, hi);
  const dw::dem::RasterGrid& grid = res.grid;
  const dw::mpi::RasterBand band =
      dw::mpi::rasterizeBands(comm, tin, frameGrid(grid, frame), rasterOptions(d, frame, threads));
  res.stats = band.stats;

  dw::gdal::GeoTiffOptions tiff = d.tiff;
  tiff.srs_wkt = srs_wkt;
  tiff.num_threads = threads;
  const std::string tile = tilePath(d.out, tin.rank);
  if (tin.rank == 0) {
    const std::string folder = tile.substr(0, tile.find_last_of('/'));
    if (::mkdir(folder.c_str(), 0777) != 0 && errno != EEXIST)
      throw dw::Error(folder + ": cannot create the tiles' folder: " + std::strerror(errno));
  }
  MPI_Barrier(comm);

  // Phase 1: every tile complete under its temporary name.
  std::unique_ptr<dw::gdal::GeoTiffWriter> writer;
  std::string error;
  try {
    if (band.row_end > band.row_begin) {
      dw::dem::RasterGrid tg = grid;
      tg.north = grid.north - double(band.row_begin) * grid.cell;
      tg.rows = band.row_end - band.row_begin;
      writer = std::make_unique<dw::gdal::GeoTiffWriter>(tile, tg, tiff);
      writer->writeRows(0, tg.rows, band.values.data());
      writer->finish();
    }
    dw::mpi::checkFault(inject_fault, tin.rank, "dem");
  } catch (const std::exception& e) {
    error = e.what();
  }
  if (!allOk(comm, error.empty())) {
    writer.reset();  // removes this rank's temporary
    // The failing rank's error ends in MPI_Abort, which kills the others: each removes its
    // temporary first.
    MPI_Barrier(comm);
    throw dw::Error(error.empty() ? "--dem: another rank failed to write its tile" : error);
  }

  // Phase 2: nothing claims the old mosaic while its tiles are replaced, then the new VRT.
  if (tin.rank == 0) std::remove(d.out.c_str());
  MPI_Barrier(comm);
  try {
    if (writer) writer->commit();
  } catch (const std::exception& e) {
    error = e.what();
  }
  if (!allOk(comm, error.empty())) {
    writer.reset();
    MPI_Barrier(comm);  // as in phase 1: every temporary gone before anyone aborts
    throw dw::Error(error.empty() ? "--dem: another rank failed to rename its tile" : error);
  }
  std::vector<dw::gdal::VrtBand> bands;
  for (int r = 0; r < tin.size; ++r) {
    dw::gdal::VrtBand b;
    std::size_t e = 0;
    dw::mpi::rowBand(grid.rows, r, tin.size, b.row_begin, e);
    b.rows = e - b.row_begin;
    tilePath(d.out, r, &b.path);
    if (b.rows > 0) bands.push_back(b);
  }
  res.tiles = bands.size();
  if (tin.rank == 0) {
    try {
      dw::gdal::writeVrtMosaic(d.out, grid, bands, tiff);
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  if (!allOk(comm, error.empty()))
    throw dw::Error(error.empty() ? "--dem: rank 0 failed to write the VRT" : error);
  return res;
}

}  // namespace dw_apps
