/// \file manifest_file.h
/// \brief The JSON manifests of the per-rank piece sets (graph and TIN), internal: string quoting,
/// and the write that readers never see half done (a temporary file renamed into place).
#pragma once

#include <string>

#include "pcl_delaunay_walk/core/graph/types.h"
#include "pcl_delaunay_walk/core/util/safe_output_file.h"

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

/// Writes `text` to a temporary and renames it over `path` (dw::SafeOutputFile): a manifest exists
/// only once complete, and a failed write leaves an earlier manifest as it was.
inline void writeFileAtomically(const std::string& path, const std::string& text) {
  SafeOutputFile out(path);
  out.write(text.data(), text.size());
  out.commit();
}

}  // namespace detail
}  // namespace mpi
}  // namespace dw
