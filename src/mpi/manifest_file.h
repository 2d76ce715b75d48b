/// \file manifest_file.h
/// \brief The JSON manifests of the per-rank piece sets (graph and TIN), internal: string quoting,
/// and the write that readers never see half done (a temporary file renamed into place).
#pragma once

#include <cstdio>
#include <fstream>
#include <string>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace mpi {
namespace detail {

/// s as a JSON string literal (quotes and backslashes escaped, control characters dropped).
inline std::string jsonString(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (static_cast<unsigned char>(c) >= 0x20) o += c;
  }
  return o + "\"";
}

/// Writes `text` to path.tmp, then renames it to `path`: a manifest exists only once complete.
inline void writeFileAtomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    out.close();
    if (!out) throw Error(tmp + ": write failed");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) throw Error(path + ": rename failed");
}

}  // namespace detail
}  // namespace mpi
}  // namespace dw
