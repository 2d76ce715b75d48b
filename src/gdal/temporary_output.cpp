/// \file temporary_output.cpp
/// \brief TemporaryOutput (see temporary_output.h).
#include "gdal/temporary_output.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {
namespace gdal {
namespace detail {

namespace {
std::atomic<unsigned> counter{0};
}

TemporaryOutput::TemporaryOutput(const std::string& target) : target_(target) {
  const std::size_t slash = target.find_last_of('/');
  const std::string folder = slash == std::string::npos ? std::string() : target.substr(0, slash + 1);
  const std::string name = slash == std::string::npos ? target : target.substr(slash + 1);
  const std::size_t dot = name.find_last_of('.');
  const std::string ext = dot == std::string::npos || dot == 0 ? std::string() : name.substr(dot);
  temporary_ =
      folder + "." + name + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + ext;
}

TemporaryOutput::~TemporaryOutput() {
  if (!done_) discard();
}

void TemporaryOutput::discard() {
  std::remove(temporary_.c_str());
  std::remove((temporary_ + ".aux.xml").c_str());
}

void TemporaryOutput::commit() {
  const int fd = ::open(temporary_.c_str(), O_RDONLY);
  if (fd < 0 || ::fsync(fd) != 0) {
    const std::string why = std::strerror(errno);
    if (fd >= 0) ::close(fd);
    discard();
    throw Error(target_ + ": cannot make the temporary file " + temporary_ + " durable: " + why);
  }
  ::close(fd);
  if (std::rename(temporary_.c_str(), target_.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    discard();
    throw Error(target_ + ": cannot rename the finished temporary file " + temporary_ + " over it: " + why);
  }
  done_ = true;
  std::remove((temporary_ + ".aux.xml").c_str());
}

}  // namespace detail
}  // namespace gdal
}  // namespace dw
