/// \file strip_merge.h
/// \brief Merge of two adjacent strip triangulations (internal; the reduce step of the seed's method).
///
/// Why it is exact. Let A lie strictly left of the seam u = s and B on or right of it (u: the long axis).
/// A triangle of DT(A) whose closed circumdisk lies strictly left of the seam contains no point of B, so
/// it is a triangle of DT(A u B) ("sure"). Everything else (the band whose circles cross the seam, plus
/// the ghost triangles along the hull) is re-triangulated: DT(A u B) minus the sure triangles consists
/// only of triangles whose vertices are vertices of unsure triangles (a DT(A u B) triangle with all
/// vertices in A that is not sure is itself an unsure triangle of DT(A); a vertex of a mixed triangle
/// has an edge leaving it into its star, which would cross a sure triangle unless that star holds an
/// unsure triangle or a ghost). Those triangles have empty circles, so they are triangles of DT(V_U),
/// V_U the band's vertices; they tile exactly the region U that the sure triangles leave uncovered.
/// The band-to-sure boundary edges are therefore edges of DT(V_U); flooding DT(V_U) from the sure side
/// of each such edge without crossing one marks exactly the triangles that are not in U. The rest, with
/// the ghosts of DT(V_U) (conv V_U = conv(A u B), as V_U holds every hull vertex), is stitched to the
/// sure triangles. With the symbolic perturbation DT is unique, so the result equals the sequential
/// kernel's, tie for tie. Every step that this argument says cannot fail is checked at run time.
///
/// "Strictly left" is tested in floating point with a generous error margin: a triangle that cannot be
/// proved sure is treated as unsure, which costs time but never exactness.
#pragma once

#include <cstddef>
#include <vector>

#include "triangle_store.h"

namespace dw {
namespace tin {
namespace detail {

/// One or more adjacent strips, already triangulated into slots of the shared arena.
struct Group {
  std::size_t strip_begin = 0, strip_end = 0;  ///< strips [begin, end)
  std::size_t num_vertices = 0;                ///< distinct vertices
  bool has_triangles = false;
  std::vector<index_t> loose;       ///< the (collinear) vertices of a group without triangles
  index_t ghost = kDead;            ///< any ghost triangle of the group
  std::vector<index_t> free_slots;  ///< arena slots owned by the group but unused (tv = kDead)
};

/// Merges A (strictly left of the seam) and B (on or right of it) along `axis` (0: x, 1: y).
/// Adds the number of re-triangulated band vertices to *band_points.
Group mergeGroups(const PointSet& ps, TriangleArena arena, int axis, double seam, Group&& a, Group&& b,
                  std::size_t* band_points);

}  // namespace detail
}  // namespace tin
}  // namespace dw
