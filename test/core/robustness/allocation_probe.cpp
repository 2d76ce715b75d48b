// Replaces the global operator new/delete of test_robustness so that a test can see the largest single
// allocation a call makes. Forwarding to malloc/free keeps ASan's bookkeeping consistent (it then sees
// matching malloc/free pairs).
#include <cstdlib>
#include <new>

#include "robustness_util.h"

namespace {
thread_local int probe_depth = 0;
thread_local std::size_t probe_largest = 0;
}  // namespace

void* operator new(std::size_t n) {
  if (probe_depth > 0 && n > probe_largest) probe_largest = n;
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}

namespace dw_robust {

AllocationProbe::AllocationProbe() {
  if (probe_depth++ == 0) probe_largest = 0;
}
AllocationProbe::~AllocationProbe() {
  --probe_depth;
}
std::size_t AllocationProbe::largest() const {
  return probe_largest;
}

}  // namespace dw_robust
