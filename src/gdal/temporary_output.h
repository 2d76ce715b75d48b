/// \file temporary_output.h
/// \brief LOCAL STAND-IN for the project's shared safe-output utility (being written in src/core/util);
/// replace the uses of dw::gdal::detail::TemporaryOutput by it when it lands. The contract is the
/// same: write under a temporary name in the target's folder, make the bytes durable, and rename over
/// the target only when complete, so that a failure never destroys an existing file.
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
