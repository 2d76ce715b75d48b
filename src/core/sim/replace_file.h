/// \file replace_file.h
/// \brief The simulator's files written the module's safe way (dw::SafeOutputFile: a temporary
/// beside the target, every write checked, renamed over it when complete), through a FILE*.
#pragma once

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/safe_output_file.h"

namespace dw {
namespace sim {
namespace detail {

/// Calls write(FILE*) on a temporary file and renames it over `path`. `write` may throw; the
/// temporary is then removed and `path` is untouched.
template <typename Write>
void replaceFile(const std::string& path, Write&& write) {
  SafeOutputFile out;
  out.open(path);
  write(out.stream());
  out.commit();
}

/// fwrite that throws on a short write (a full disk).
inline void writeBytes(std::FILE* f, const void* data, std::size_t bytes, const std::string& path) {
  if (bytes && std::fwrite(data, 1, bytes, f) != bytes)
    throw Error("cannot write " + path + ": " + std::strerror(errno));
}

}  // namespace detail
}  // namespace sim
}  // namespace dw
