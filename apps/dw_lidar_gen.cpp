/// \file dw_lidar_gen.cpp
/// \brief Synthetic airborne LiDAR generator (terrain, buildings, trees, scan lines, LAS quantisation).
/// Core-only app: links pcl_delaunay_walk_core, not PCL.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "app_args.h"
#include "pcl_delaunay_walk/core/las/synthetic_lidar.h"

namespace {

void usage() {
  std::fprintf(stderr,
               "usage: dw_lidar_gen -n POINTS -o out.las [--density PULSES_PER_M2] [--swath M] [--seed S]\n"
               "  Writes a synthetic airborne LiDAR tile (LAS 1.2 format 1; LAS 1.4 format 6 beyond 2^32).\n"
               "  POINTS accepts suffixes k and M (e.g. 21M).\n");
}

}  // namespace

int main(int argc, char** argv) {
  dw::las::LidarGenOptions o;
  std::string out;
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
      else if (a == "--density")
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
    const std::uint64_t n = dw::las::writeSyntheticLas(out, o, [&](double f) {
      const int pct = int(f * 100);
      if (pct / 10 != last / 10) {
        std::fprintf(stderr, "\r%3d%%", pct);
        last = pct;
      }
    });
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
