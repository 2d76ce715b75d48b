/// \file replace_file.h
/// \brief Writing a file so that readers never see it half-written and a failed write leaves the old
/// file in place: write `path.tmp-<pid>` beside it, flush and close with checks, rename over `path`.
#pragma once

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace sim {
namespace detail {

inline std::string temporaryPathFor(const std::string& path) {
  return path + ".tmp-" + std::to_string(static_cast<long>(::getpid()));
}

/// Moves a finished temporary file over `path`; on failure removes it and throws.
inline void commitTemporary(const std::string& tmp, const std::string& path) {
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int e = errno;
    std::remove(tmp.c_str());
    throw Error("cannot write " + path + ": " + std::strerror(e));
  }
}

/// Calls write(FILE*) on a temporary file and renames it over `path`. `write` may throw; the
/// temporary is then removed and `path` is untouched.
template <typename Write>
void replaceFile(const std::string& path, Write&& write) {
  const std::string tmp = temporaryPathFor(path);
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw Error("cannot write " + path + ": " + std::strerror(errno));
  try {
    write(f);
  } catch (...) {
    std::fclose(f);
    std::remove(tmp.c_str());
    throw;
  }
  const bool ok = std::ferror(f) == 0 && std::fflush(f) == 0;
  const int e = errno;
  if (std::fclose(f) != 0 || !ok) {
    std::remove(tmp.c_str());
    throw Error("cannot write " + path + ": " + std::strerror(ok ? errno : e));
  }
  commitTemporary(tmp, path);
}

/// fwrite that throws on a short write (a full disk).
inline void writeBytes(std::FILE* f, const void* data, std::size_t bytes, const std::string& path) {
  if (bytes && std::fwrite(data, 1, bytes, f) != bytes)
    throw Error("cannot write " + path + ": " + std::strerror(errno));
}

}  // namespace detail
}  // namespace sim
}  // namespace dw
