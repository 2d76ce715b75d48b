/// \file dw_lidar_gen.cpp
/// \brief Synthetic airborne LiDAR generator (terrain, buildings, trees, scan lines, LAS quantisation).
/// Core-only app: links pcl_delaunay_walk_core, not PCL.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>

#include "app_args.h"
#include "pcl_delaunay_walk/core/las/las_writer.h"
#include "pcl_delaunay_walk/core/las/laz_writer.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"

namespace {

void usage() {
  std::fprintf(
      stderr,
      "usage: dw_lidar_gen -n POINTS -o out.las|out.laz [--laz] [--format F] [--density PULSES_PER_M2]\n"
      "                    [--swath M] [--seed S] [--chunk N] [--variable-chunks] [--tile COL ROW]\n"
      "  Writes a synthetic airborne LiDAR tile (LAS 1.2 format 1; LAS 1.4 format 6 beyond 2^32).\n"
      "  .laz or --laz: LASzip-compressed. --format F: point format 0-3 or 6-8 instead.\n"
      "  --chunk N: LAZ points per chunk (default 50000). --variable-chunks: LAZ chunks of varying\n"
      "  sizes, N/4 to N points each (LASzip's variable chunking: the chunk table holds the counts).\n"
      "  --tile COL ROW: tile (COL, ROW) of a survey of equal tiles (same options): the tiles are one\n"
      "  cloud with the same scale and offsets, ROW 0 the southern row of tiles.\n"
      "  POINTS and N accept suffixes k and M (e.g. 21M).\n");
}

bool endsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

/// LAZ chunking of the output.
struct LazLayout {
  std::uint32_t chunk = 50000;
  bool variable = false;
};

dw::las::LasHeader tileHeader(const dw::las::LidarGenOptions& o, int format) {
  dw::las::LasHeader h = dw::las::syntheticHeader(o);
  if (format >= 0) {
    h.point_format = std::uint8_t(format);
    h.version_minor = format >= 6 ? 4 : std::min<std::uint8_t>(h.version_minor, 2);
  }
  return h;
}

/// Writes every generated record with `writer`, calling `after(n)` after the n-th; returns the count.
template <typename Writer, typename After>
std::uint64_t writeRecords(Writer& writer, const dw::las::LidarGenOptions& o,
                           const std::function<void(double)>& progress, After&& after) {
  std::uint64_t n = 0;
  const std::uint64_t step = std::max<std::uint64_t>(1, o.num_points / 100);
  dw::las::generateLidar(o, [&](const dw::las::LasRecord& r) {
    writer.write(r);
    after(++n);
    if (n % step == 0) progress(double(n) / double(o.num_points));
  });
  writer.close();
  return n;
}

std::uint64_t writeLasTile(const std::string& path, const dw::las::LidarGenOptions& o, int format,
                           const std::function<void(double)>& progress) {
  dw::las::LasWriter writer(path, tileHeader(o, format));
  return writeRecords(writer, o, progress, [](std::uint64_t) {});
}

/// Variable chunks end at sizes drawn from [chunk/4, chunk] by a generator seeded with the tile's
/// seed, so a file is reproducible and its chunks are of many sizes.
std::uint64_t writeLazTile(const std::string& path, const dw::las::LidarGenOptions& o, int format,
                           const LazLayout& layout, const std::function<void(double)>& progress) {
  dw::las::LazWriter writer(path, tileHeader(o, format), 0, layout.chunk,
                            layout.variable ? dw::las::LazChunking::kVariable : dw::las::LazChunking::kFixed);
  std::uint64_t state = o.seed * 0x9E3779B97F4A7C15ull + 1, next_end = 0;
  auto draw = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    const std::uint64_t lo = std::max<std::uint64_t>(1, layout.chunk / 4);
    return lo + (state >> 33) % (layout.chunk - lo + 1);
  };
  if (layout.variable) next_end = draw();
  return writeRecords(writer, o, progress, [&](std::uint64_t n) {
    if (layout.variable && n == next_end) {
      writer.endChunk();
      next_end = n + draw();
    }
  });
}

}  // namespace

int main(int argc, char** argv) {
  dw::las::LidarGenOptions o;
  std::string out;
  bool laz = false;
  int format = -1;
  LazLayout layout;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto value = [&]() -> const char* {
        if (i + 1 >= argc) throw dw::Error("missing value after " + a);
        return argv[++i];
      };
      if (a == "-n" || a == "--points")
        o.num_points = dw_apps::parseCount(value(), "point count");
      else if (a == "-o" || a == "--output")
        out = value();
      else if (a == "--laz")
        laz = true;
      else if (a == "--format") {
        format = std::atoi(value());
        if (!((format >= 0 && format <= 3) || (format >= 6 && format <= 8)))
          throw dw::Error("--format must be 0-3 or 6-8");
      } else if (a == "--chunk") {
        const std::uint64_t c = dw_apps::parseCount(value(), "chunk size");
        if (c < 1 || c > (1u << 24)) throw dw::Error("--chunk must be 1 to 16M points");
        layout.chunk = std::uint32_t(c);
      } else if (a == "--variable-chunks")
        layout.variable = true;
      else if (a == "--density")
        o.density = std::atof(value());
      else if (a == "--swath")
        o.swath = std::atof(value());
      else if (a == "--seed")
        o.seed = std::strtoull(value(), nullptr, 10);
      else if (a == "--tile") {
        const auto col = dw_apps::parseList(value(), "tile column", 0, 65535);
        const auto row = dw_apps::parseList(value(), "tile row", 0, 65535);
        if (col.size() != 1 || row.size() != 1) throw dw::Error("--tile takes a column and a row");
        o.tile_col = col[0], o.tile_row = row[0];
      } else if (a == "-h" || a == "--help") {
        usage();
        return 0;
      } else {
        throw dw::Error("unknown option " + a);
      }
    }
    if (out.empty()) throw dw::Error("no output file (-o)");
    const auto t0 = std::chrono::steady_clock::now();
    int last = -1;
    const std::function<void(double)> progress = [&](double f) {
      const int pct = int(f * 100);
      if (pct / 10 != last / 10) {
        std::fprintf(stderr, "\r%3d%%", pct);
        last = pct;
      }
    };
    laz = laz || endsWith(out, ".laz") || endsWith(out, ".LAZ");
    const std::uint64_t n = laz ? writeLazTile(out, o, format, layout, progress)
                                : (format < 0 ? dw::las::writeSyntheticLas(out, o, progress)
                                              : writeLasTile(out, o, format, progress));
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::fprintf(stderr, "\rwrote %llu points to %s in %.1f s\n", static_cast<unsigned long long>(n),
                 out.c_str(), s);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dw_lidar_gen: %s\n", e.what());
    usage();
    return 1;
  }
}
