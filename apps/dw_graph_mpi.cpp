/// \file dw_graph_mpi.cpp
/// \brief The 3D Delaunay walk graph built over MPI ranks (blocks on ranks, halos fetched from their
/// owners); the same graph as dw_graph / dw::buildDelaunayGraph on the same input.
///   mpirun -np N dw_graph_mpi input.ply [more.ply ...] -o out.graph     (rank 0 writes the whole graph)
///   mpirun -np N dw_graph_mpi input.ply --pieces PREFIX                 (per-rank pieces + manifest)
/// Exit status: 0 success; 1 bad input or a failing rank (all ranks are aborted, no manifest); 2 usage;
/// 3 --verify found a difference from the single-process graph.
#include <mpi.h>
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "mpi/fault_injection.h"
#include "pcl_delaunay_walk/core/graph/graph_io.h"
#include "pcl_delaunay_walk/mpi/distributed_graph.h"
#include "pcl_delaunay_walk/mpi/las_input_set.h"

namespace {

void usage() {
  std::fprintf(
      stderr,
      "usage: mpirun -np N dw_graph_mpi INPUT... [--list FILE] [--uniform N [--seed S]]\n"
      "                    (-o out.graph | --pieces PREFIX) [--verify] [--cell-shift S] [--quiet]\n"
      "                    [--inject fail|kill:STAGE:RANK]\n"
      "  INPUT       PLY (ascii or binary) or KITTI .bin; several files (or --list FILE, one path per line)\n"
      "              are one cloud, their points in that order; binary files are read by range per rank\n"
      "  --uniform N N uniform random points generated on the ranks (scaling runs; no input file)\n"
      "  -o FILE     rank 0 gathers the graph and saves it (dw::saveGraph, as dw_graph does)\n"
      "  --pieces P  every rank writes P.rank<r>.dwgp, then rank 0 writes P.manifest.json (last)\n"
      "  --verify    rank 0 also builds the graph with dw::buildDelaunayGraph and compares (needs -o)\n"
      "  --cell-shift S  halo cells 2^S times the edge of ~4-point cells (default 1; speed only)\n"
      "  --inject    testing: make RANK fail (exception) or be killed at STAGE\n"
      "              (read, sort, block, grow, write)\n");
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  dw::mpi::DistributedGraphOptions opt;
  std::vector<std::string> inputs;
  std::string out, pieces;
  std::uint64_t uniform = 0, seed = 1;
  bool check = false, quiet = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a);
      return argv[++i];
    };
    try {
      if (a == "-o" || a == "--output")
        out = next();
      else if (a == "--pieces")
        pieces = next();
      else if (a == "--list") {
        const std::vector<std::string> l = dw::mpi::readPathList(next());
        inputs.insert(inputs.end(), l.begin(), l.end());
      } else if (a == "--uniform")
        uniform = std::stoull(next());
      else if (a == "--seed")
        seed = std::stoull(next());
      else if (a == "--cell-shift")
        opt.cell_shift = std::stoi(next());
      else if (a == "--verify")
        check = true;
      else if (a == "--quiet")
        quiet = true;
      else if (a == "--inject") {
        opt.inject_fault = next();
        dw::mpi::FaultInjection::parse(opt.inject_fault);  // refuses a bad spec before any rank starts
      } else if (a == "-h" || a == "--help") {
        if (rank == 0) usage();
        MPI_Finalize();
        return 0;
      } else if (!a.empty() && a[0] != '-')
        inputs.push_back(a);
      else
        throw std::invalid_argument(a);
    } catch (const std::exception& e) {
      if (rank == 0) {
        std::fprintf(stderr, "dw_graph_mpi: bad argument '%s' (%s)\n", a.c_str(), e.what());
        usage();
      }
      MPI_Finalize();
      return 2;
    }
  }
  if ((inputs.empty() == (uniform == 0)) || (out.empty() == pieces.empty()) || (check && out.empty())) {
    if (rank == 0) usage();
    MPI_Finalize();
    return 2;
  }
  if (!quiet)
    opt.progress = [](const std::string& s) { std::fprintf(stderr, "[dw_graph_mpi] %s\n", s.c_str()); };

  int status = 0;
  try {
    // A manifest from an earlier run must not survive a failing one.
    if (rank == 0 && !pieces.empty()) std::remove((pieces + ".manifest.json").c_str());
    MPI_Barrier(MPI_COMM_WORLD);
    const auto t0 = std::chrono::steady_clock::now();
    const dw::mpi::PointInputSet input =
        uniform ? dw::mpi::PointInputSet::uniform(uniform, seed) : dw::mpi::PointInputSet(inputs);
    dw::mpi::RankGraph part = dw::mpi::buildGraphDistributed(MPI_COMM_WORLD, input, opt);
    const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    // Per-rank statistics on rank 0.
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    const double row[12] = {
        part.timings.read_s,        part.timings.sort_s,         part.timings.block_s,
        part.timings.hull_s,        part.timings.grow_s,         part.timings.exchange_s,
        double(part.points.size()), double(part.halo_points),    double(part.fetched_points),
        double(part.growth_rounds), double(part.halo_exchanges), double(ru.ru_maxrss) / 1024.0};
    std::vector<double> rows(12 * static_cast<std::size_t>(size));
    MPI_Gather(row, 12, MPI_DOUBLE, rows.data(), 12, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    if (rank == 0 && !quiet) {
      std::fprintf(stderr,
                   "rank  read_s  sort_s block_s  hull_s  grow_s (exch_s)   own_pts  halo_pts  fetched "
                   "passes fetches  rss_MB\n");
      for (int r = 0; r < size; ++r) {
        const double* v = &rows[12 * r];
        std::fprintf(stderr,
                     "%4d %7.2f %7.2f %7.2f %7.2f %7.2f (%6.2f) %9.0f %9.0f %8.0f %6.0f %7.0f %7.0f\n", r,
                     v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], v[9], v[10], v[11]);
      }
      std::fprintf(stderr,
                   "built in %.2f s: %llu points, %llu vertices, %zu hull vertices, %zu cells, %d ranks%s\n",
                   build_s, static_cast<unsigned long long>(part.input_points),
                   static_cast<unsigned long long>(part.vertices), part.hull_points, part.cells, size,
                   part.gathered_fallback ? " (degenerate input: built on rank 0)" : "");
    }

    if (!pieces.empty()) {
      dw::mpi::writeGraphPiecesAndManifest(MPI_COMM_WORLD, pieces, part, input.describe(), opt);
    } else {
      dw::mpi::checkFault(opt.inject_fault, part.rank, "write");
      const dw::DelaunayGraph g = dw::mpi::gatherGraph(MPI_COMM_WORLD, std::move(part));
      if (rank == 0) {
        dw::saveGraph(g, out);
        if (!quiet)
          std::fprintf(stderr,
                       "wrote %s: %zu vertices, %zu directed edges (mean degree %.2f), %.2f s in all\n",
                       out.c_str(), g.numVertices(), g.numDirectedEdges(),
                       g.numVertices() ? double(g.numDirectedEdges()) / g.numVertices() : 0.0,
                       std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        if (check) {
          const std::vector<double> xyz = input.read(0, input.size());
          const auto r0 = std::chrono::steady_clock::now();
          const dw::DelaunayGraph ref =
              dw::buildDelaunayGraph(dw::PointView::fromDouble(xyz.data(), xyz.size() / 3));
          const double ref_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - r0).count();
          const bool same = dw::serializeGraph(g) == dw::serializeGraph(ref);
          std::fprintf(stderr,
                       "verify: distributed %zu vertices / %zu directed edges, single-process %zu / %zu "
                       "(%.2f s): %s\n",
                       g.numVertices(), g.numDirectedEdges(), ref.numVertices(), ref.numDirectedEdges(),
                       ref_s, same ? "IDENTICAL" : "DIFFERENT");
          if (!same) status = 3;
        }
      }
      MPI_Bcast(&status, 1, MPI_INT, 0, MPI_COMM_WORLD);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_graph_mpi: rank %d of %d failed: %s\n", rank, size, e.what());
    std::fflush(stderr);
    // Other ranks may be blocked in a collective: abort the whole job with a non-zero status.
    MPI_Abort(MPI_COMM_WORLD, 1);
    return 1;
  }
  MPI_Finalize();
  return status;
}
