/// \file point_file.h
/// \brief PCL-free reading of xyz from PLY (ascii / binary little endian) and KITTI .bin files, so the
/// core, the GPU module and the benchmarks can load real clouds where PCL is absent (device machine).
#pragma once

#include <string>
#include <vector>

namespace dw {

/// xyz triples (double) of every vertex. Throws dw::Error on unreadable, truncated or foreign files.
std::vector<double> readPointsXyz(const std::string& path);

}  // namespace dw
