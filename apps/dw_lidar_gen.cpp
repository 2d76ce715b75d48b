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
      "                    [--swath M] [--seed S]\n"
      "  Writes a synthetic airborne LiDAR tile (LAS 1.2 format 1; LAS 1.4 format 6 beyond 2^32).\n"
      "  .laz or --laz: LASzip-compressed. --format F: point format 0-3 or 6-8 instead.\n"
      "  POINTS accepts suffixes k and M (e.g. 21M).\n");
}

bool endsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

/// Writes the tile with `Writer` (LasWriter or LazWriter); returns the number of records.
template <typename Writer>
std::uint64_t writeTile(const std::string& path, const dw::las::LidarGenOptions& o, int format,
                        const std::function<void(double)>& progress) {
  dw::las::LasHeader h = dw::las::syntheticHeader(o);
  if (format >= 0) {
    h.point_format = std::uint8_t(format);
    h.version_minor = format >= 6 ? 4 : std::min<std::uint8_t>(h.version_minor, 2);
  }
  Writer writer(path, h);
  std::uint64_t n = 0;
  const std::uint64_t step = std::max<std::uint64_t>(1, o.num_points / 100);
  dw::las::generateLidar(o, [&](const dw::las::LasRecord& r) {
    writer.write(r);
    if (++n % step == 0) progress(double(n) / double(o.num_points));
  });
  writer.close();
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  dw::las::LidarGenOptions o;
  std::string out;
  bool laz = false;
  int format = -1;
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
      } else if (a == "--density")
        o.density = std::atof(value());
      else if (a == "--swath")
        o.swath = std::atof(value());
      else if (a == "--seed")
        o.seed = std::strtoull(value(), nullptr, 10);
      else if (a == "-h" || a == "--help") {
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
    const std::uint64_t n = laz ? writeTile<dw::las::LazWriter>(out, o, format, progress)
                                : (format < 0 ? dw::las::writeSyntheticLas(out, o, progress)
                                              : writeTile<dw::las::LasWriter>(out, o, format, progress));
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
