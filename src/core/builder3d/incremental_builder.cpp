// Placeholder until the incremental 3D kernel lands: reports itself as unavailable, so BuilderType::Auto
// falls back to Qhull and BuilderType::Incremental gives a clear error.
#include "pcl_delaunay_walk/core/graph_builder.h"

namespace dw {

bool haveIncrementalBuilder() { return false; }

EdgeList incrementalDelaunayEdges(const std::vector<Vec3f>&, const BuildOptions&) {
  throw Error("pcl_delaunay_walk: the incremental 3D Delaunay builder is not part of this build");
}

}  // namespace dw
