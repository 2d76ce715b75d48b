/// \file edge_scan.h
/// \brief One step of the walk over a neighbourhood (seed Algorithm 1's inner loop), four edges at a time.
#pragma once

#include <algorithm>
#include <cmath>

#if defined(__SSE2__)
#include <emmintrin.h>
#include <xmmintrin.h>
#endif

#include "pcl_delaunay_walk/core/graph/types.h"

namespace dw {

/// What one scan of vertex i's edges found for u = q - x_i, with c = u . e_ij.
struct EdgeScan {
  float max_margin = -INFINITY;  ///< max (c - m_ij): <= 0 means x_i is the nearest neighbour
  float best_gain = 0.f;         ///< the largest c among edges with c > m_ij (0 if none)
  index_t best = kInvalidIndex;  ///< that edge's neighbour j: the walk's next vertex
};

/// The reference definition, one edge at a time; the first edge wins ties of c. Stops at the first
/// edge with m > stop_m (default: reads them all).
inline EdgeScan scanEdgesScalar(const EdgeRecord* first, const EdgeRecord* end, const Vec3f& u,
                                float stop_m = INFINITY) {
  EdgeScan s;
  for (const EdgeRecord* e = first; e != end && !(e->m > stop_m); ++e) {
    const float c = u.x * e->ex + u.y * e->ey + u.z * e->ez;
    const float margin = c - e->m;
    if (margin > 0.f && c > s.best_gain) s.best_gain = c, s.best = e->j;
    s.max_margin = std::max(s.max_margin, margin);
  }
  return s;
}

/// Same result as scanEdgesScalar, bit for bit (same operation order, same tie rule).
///
/// Neighbourhoods are stored shortest edge first (DelaunayGraph), and c = u . e <= |u|: an edge with
/// m > |u| can neither be a move nor come near its threshold, and neither can any edge after it. The
/// walk passes stop_m slightly above |u|, so a query close to x_i reads only x_i's few shortest edges;
/// that is the safe ball generalised edge by edge. Blocks of four stop at the first block that starts
/// beyond stop_m (the rest of a block is scanned: harmless).
///
/// This is the walk's hot loop: most queries in ICP end at their start vertex after one scan. Each
/// EdgeRecord begins with {ex, ey, ez, m}, so four unaligned 16-byte loads and a 4x4 transpose give
/// four edges in SoA form without changing the documented 20-byte record; the move is chosen with
/// masks instead of a data-dependent branch. SSE2 is part of every x86-64 target; elsewhere (and for
/// the last degree % 4 edges) the scalar loop runs.
inline EdgeScan scanEdges(const EdgeRecord* first, const EdgeRecord* end, const Vec3f& u,
                          float stop_m = INFINITY) {
#if defined(__SSE2__)
  if (end - first < 4) return scanEdgesScalar(first, end, u, stop_m);
  const __m128 ux = _mm_set1_ps(u.x), uy = _mm_set1_ps(u.y), uz = _mm_set1_ps(u.z);
  const __m128 zero = _mm_setzero_ps();
  __m128 vmargin = _mm_set1_ps(-INFINITY), vgain = zero;
  __m128i vpos = _mm_set1_epi32(-1);  // per lane: position (edge index) of its best move, -1 none
  __m128i pos = _mm_setr_epi32(0, 1, 2, 3);
  const __m128i four = _mm_set1_epi32(4);
  const EdgeRecord* e = first;
  for (; end - e >= 4 && !(e->m > stop_m); e += 4, pos = _mm_add_epi32(pos, four)) {
    __m128 ex = _mm_loadu_ps(&e[0].ex), ey = _mm_loadu_ps(&e[1].ex);
    __m128 ez = _mm_loadu_ps(&e[2].ex), m = _mm_loadu_ps(&e[3].ex);
    _MM_TRANSPOSE4_PS(ex, ey, ez, m);
    const __m128 c = _mm_add_ps(_mm_add_ps(_mm_mul_ps(ux, ex), _mm_mul_ps(uy, ey)), _mm_mul_ps(uz, ez));
    const __m128 margin = _mm_sub_ps(c, m);
    // Lane k sees edges k, k+4, ... in order; strict > keeps its first maximum, as the scalar loop.
    const __m128 take = _mm_and_ps(_mm_cmpgt_ps(margin, zero), _mm_cmpgt_ps(c, vgain));
    vgain = _mm_or_ps(_mm_and_ps(take, c), _mm_andnot_ps(take, vgain));
    const __m128i takei = _mm_castps_si128(take);
    vpos = _mm_or_si128(_mm_and_si128(takei, pos), _mm_andnot_si128(takei, vpos));
    vmargin = _mm_max_ps(margin, vmargin);  // a NaN margin keeps the old value, as std::max does
  }
  alignas(16) float margins[4], gains[4];
  alignas(16) int positions[4];
  _mm_store_ps(margins, vmargin);
  _mm_store_ps(gains, vgain);
  _mm_store_si128(reinterpret_cast<__m128i*>(positions), vpos);
  EdgeScan s;
  int best_pos = -1;
  for (int k = 0; k < 4; ++k) {
    s.max_margin = std::max(s.max_margin, margins[k]);
    // Across lanes: the largest gain, and of equal gains the earliest edge (the scalar tie rule).
    if (positions[k] >= 0 && (gains[k] > s.best_gain || (gains[k] == s.best_gain && positions[k] < best_pos)))
      s.best_gain = gains[k], best_pos = positions[k];
  }
  if (best_pos >= 0) s.best = first[best_pos].j;
  const EdgeScan tail = scanEdgesScalar(e, end, u, stop_m);
  s.max_margin = std::max(s.max_margin, tail.max_margin);
  if (tail.best != kInvalidIndex && tail.best_gain > s.best_gain)
    s.best_gain = tail.best_gain, s.best = tail.best;
  return s;
#else
  return scanEdgesScalar(first, end, u, stop_m);
#endif
}

}  // namespace dw
