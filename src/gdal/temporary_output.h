/// \file temporary_output.h
/// \brief A GDAL output under a temporary name: the contract of core/util/safe_output_file.h (write
/// under a temporary name in the target's folder, make the bytes durable, rename over the target only
/// when complete, so that a failure never destroys an existing file) for a library that opens files by
/// path, plus GDAL's side file "<temporary>.aux.xml". Unlike dw::temporaryPathFor it creates nothing
/// until GDAL does, so a target that is a folder or a missing folder is GDAL's error to report.
#pragma once

#include <string>

namespace dw {
namespace gdal {
namespace detail {

class TemporaryOutput {
 public:
  /// Chooses "<folder>/.<name>.tmp-<pid>-<n><ext>" beside `target` (ext: the target's, so that tools
  /// that look at names see the right type). Creates nothing yet.
  explicit TemporaryOutput(const std::string& target);
  /// Removes the temporary file (and a GDAL side file "<temporary>.aux.xml") unless committed.
  ~TemporaryOutput();
  TemporaryOutput(const TemporaryOutput&) = delete;
  TemporaryOutput& operator=(const TemporaryOutput&) = delete;

  const std::string& path() const { return temporary_; }
  const std::string& target() const { return target_; }
  /// fsync()s the temporary file, then renames it over the target; throws dw::Error naming both files
  /// and the system's reason when either fails (the target is then as it was, the temporary removed).
  void commit();
  /// Removes the temporary file now (idempotent).
  void discard();

 private:
  std::string target_, temporary_;
  bool done_ = false;
};

}  // namespace detail
}  // namespace gdal
}  // namespace dw
