// The calling thread's loop runner (parallel_for.h). Defined here, in the core library,
// rather than as an inline variable in the header, so that a shared core and its users see one.
#include "pcl_delaunay_walk/core/util/parallel_for.h"

namespace dw {
namespace detail {

LoopRunner*& loopRunnerOfThisThread() {
  thread_local LoopRunner* runner = nullptr;
  return runner;
}

}  // namespace detail
}  // namespace dw
