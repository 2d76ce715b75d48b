// Delaunay edges with Qhull (libqhull_r), the baseline builder and the cross-check of the others.
//
// Options: "d Qbb QJ". Measured (docs/architecture.md, "Building the graph"): the default triangulated output
// "Qt" ran past 120 s on exactly cospherical input, while joggle (QJ) always finishes. A joggled
// triangulation is a Delaunay triangulation of points moved by ~1e-11 of the extent; it can differ from the
// real points' only where they are degenerate within that distance, where the choice of diagonal is a tie
// (both walks stay exact to float resolution). The input is centred by the caller (raw UTM coordinates made
// Qhull run past 200 s and drop points), and every point must come back as a vertex, or we throw.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "pcl_delaunay_walk/core/graph/graph_builder.h"

#ifdef DW_HAVE_QHULL
extern "C" {
#include <libqhull_r/qhull_ra.h>
}
#endif

namespace dw {

bool haveQhullBuilder() {
#ifdef DW_HAVE_QHULL
  return true;
#else
  return false;
#endif
}

#ifdef DW_HAVE_QHULL
namespace {

/// Owns one Qhull run (its state, error stream) so that every exit path frees it.
class QhullRun {
 public:
  QhullRun() {
    err_ = open_memstream(&err_buf_, &err_len_);
    qh_zero(&qh_, err_);
  }
  ~QhullRun() {
    int curlong = 0, totlong = 0;
    qh_freeqhull(&qh_, !qh_ALL);
    qh_memfreeshort(&qh_, &curlong, &totlong);
    if (err_) std::fclose(err_);
    std::free(err_buf_);
  }
  QhullRun(const QhullRun&) = delete;
  QhullRun& operator=(const QhullRun&) = delete;

  int run(int dim, std::vector<double>& coords, const char* flags) {
    std::string f = flags;
    return qh_new_qhull(&qh_, dim, static_cast<int>(coords.size() / dim), coords.data(), False,
                        const_cast<char*>(f.c_str()), nullptr, err_);
  }
  std::string errors() {
    if (err_) std::fflush(err_);
    std::string s = err_buf_ ? std::string(err_buf_, err_len_) : std::string();
    if (s.size() > 600) s = s.substr(0, 600) + "...";
    return s;
  }
  qhT* qh() { return &qh_; }

 private:
  qhT qh_;
  FILE* err_ = nullptr;
  char* err_buf_ = nullptr;
  std::size_t err_len_ = 0;
};

}  // namespace
#endif

EdgeList qhullDelaunayEdges(const std::vector<Vec3f>& points, int dim, const double basis[6]) {
#ifndef DW_HAVE_QHULL
  (void)points, (void)dim, (void)basis;
  throw Error("pcl_delaunay_walk: this build has no Qhull; use BuilderType::Incremental");
#else
  if (dim != 2 && dim != 3) throw Error("pcl_delaunay_walk: qhullDelaunayEdges supports dim 2 or 3");
  const std::size_t n = points.size();
  if (n < static_cast<std::size_t>(dim) + 2)
    throw Error("pcl_delaunay_walk: Qhull needs at least dim + 2 points");
  if (n > 0x7fffffff) throw Error("pcl_delaunay_walk: too many points for Qhull");
  std::vector<double> coords(n * dim);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3f& p = points[i];
    if (dim == 3) {
      coords[3 * i] = p.x, coords[3 * i + 1] = p.y, coords[3 * i + 2] = p.z;
    } else {
      coords[2 * i] = p.x * basis[0] + p.y * basis[1] + double(p.z) * basis[2];
      coords[2 * i + 1] = p.x * basis[3] + p.y * basis[4] + double(p.z) * basis[5];
    }
  }
  QhullRun q;
  const int code = q.run(dim, coords, "qhull d Qbb QJ");
  if (code != 0)
    throw Error("pcl_delaunay_walk: Qhull failed (exit code " + std::to_string(code) + "): " + q.errors());

  qhT* qh = q.qh();
  EdgeList edges;
  // Every lower facet (a simplex) lists all its vertex pairs, so the list holds each edge about five
  // times in 3D (~39 per point). Reserved at 8 per point, it grew by doubling to 64 per point while
  // Qhull's own structures were still alive.
  edges.reserve(static_cast<std::size_t>(qh->num_facets) * (dim == 3 ? 6 : 3));
  std::vector<char> seen(n, 0);
  facetT* facet;
  vertexT *vertex, **vertexp;
  FORALLfacets {
    if (facet->upperdelaunay) continue;
    index_t ids[4];
    int k = 0;
    FOREACHvertex_(facet->vertices) {
      const int id = qh_pointid(qh, vertex->point);
      if (id < 0 || static_cast<std::size_t>(id) >= n || k >= dim + 1) continue;
      ids[k++] = static_cast<index_t>(id);
      seen[id] = 1;
    }
    for (int a = 0; a < k; ++a)
      for (int b = a + 1; b < k; ++b) edges.emplace_back(ids[a], ids[b]);
  }
  std::size_t missing = 0;
  for (char s : seen) missing += s == 0;
  if (missing > 0)
    throw Error("pcl_delaunay_walk: Qhull returned " + std::to_string(n - missing) + " of " +
                std::to_string(n) + " points as Delaunay vertices; refusing an incomplete graph");
  return edges;
#endif
}

}  // namespace dw
