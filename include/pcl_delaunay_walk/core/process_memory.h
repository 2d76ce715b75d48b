/// \file process_memory.h
/// \brief Resident and peak memory of this process (Linux /proc), for the apps' and benchmarks' reports.
#pragma once

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

namespace dw {

/// The kB value of a /proc/self/status line such as "VmRSS:" or "VmHWM:" (0 where unavailable).
inline long processStatusKb(const char* key) {
  std::ifstream f("/proc/self/status");
  std::string line;
  const std::size_t kl = std::strlen(key);
  while (std::getline(f, line))
    if (line.compare(0, kl, key) == 0) return std::atol(line.c_str() + kl);
  return 0;
}

/// Resets the kernel's peak-resident mark (VmHWM) to the current resident size, so that the next
/// reading measures one run's own peak (Linux: writing 5 to /proc/self/clear_refs; a no-op elsewhere).
inline void resetPeakResident() {
  std::ofstream f("/proc/self/clear_refs");
  f << "5";
}

}  // namespace dw
