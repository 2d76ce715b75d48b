/// \file temporary_output.h
/// \brief A GDAL output under a temporary name: the core's temporaryPathFor / commitTemporary /
/// discardTemporary (core/util/safe_output_file.h) as one scoped object, plus GDAL's side file
/// "<temporary>.aux.xml". Write under path(), commit() when complete; a failure or a scope left without
/// commit never destroys an existing target.
#pragma once

#include <string>

namespace dw {
namespace gdal {
namespace detail {

class TemporaryOutput {
 public:
  /// Creates the temporary beside `target` (dw::temporaryPathFor: the target's extension kept, so that
  /// GDAL picks the right driver by name).
  explicit TemporaryOutput(const std::string& target);
  /// Removes the temporary file (and a GDAL side file "<temporary>.aux.xml") unless committed.
  ~TemporaryOutput();
  TemporaryOutput(const TemporaryOutput&) = delete;
  TemporaryOutput& operator=(const TemporaryOutput&) = delete;

  const std::string& path() const { return temporary_; }
  const std::string& target() const { return target_; }
  /// fsync()s the temporary file, then renames it over the target; throws dw::Error naming the target
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
