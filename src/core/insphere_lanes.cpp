// The cold path of predicates::insphereLanes: the filter could not decide.
#include "pcl_delaunay_walk/core/insphere_lanes.h"

namespace dw {
namespace predicates {
namespace detail {

double insphereTailOfFloats(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d, const double* e) {
  const double da[3] = {a.x, a.y, a.z}, db[3] = {b.x, b.y, b.z}, dc[3] = {c.x, c.y, c.z},
               dd[3] = {d.x, d.y, d.z};
  return insphereTail(da, db, dc, dd, e);
}

}  // namespace detail
}  // namespace predicates
}  // namespace dw
