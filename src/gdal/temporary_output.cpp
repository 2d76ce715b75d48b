/// \file temporary_output.cpp
/// \brief TemporaryOutput over the core's safe-output helpers (see temporary_output.h).
#include "gdal/temporary_output.h"

#include <cstdio>

#include "pcl_delaunay_walk/core/util/safe_output_file.h"

namespace dw {
namespace gdal {
namespace detail {

TemporaryOutput::TemporaryOutput(const std::string& target)
    : target_(target), temporary_(dw::temporaryPathFor(target)) {}

TemporaryOutput::~TemporaryOutput() {
  if (!done_) discard();
}

void TemporaryOutput::discard() {
  dw::discardTemporary(temporary_);
  std::remove((temporary_ + ".aux.xml").c_str());
}

void TemporaryOutput::commit() {
  try {
    dw::commitTemporary(temporary_, target_);
  } catch (...) {
    std::remove((temporary_ + ".aux.xml").c_str());
    done_ = true;  // commitTemporary removed the temporary
    throw;
  }
  done_ = true;
  std::remove((temporary_ + ".aux.xml").c_str());
}

}  // namespace detail
}  // namespace gdal
}  // namespace dw
