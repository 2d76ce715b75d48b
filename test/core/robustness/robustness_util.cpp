#include "robustness_util.h"

#include <sstream>

namespace dw_robust {

void reseal(std::vector<std::uint8_t>& f) {
  if (f.size() < hdr::kSize) return;
  dw::resealGraphFile(f);
}

std::vector<dw::Vec3f> mixedQueries(const dw::DelaunayGraph& g, const std::vector<double>& xyz, std::size_t n,
                                    unsigned seed) {
  std::vector<dw::Vec3f> q;
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  std::vector<std::size_t> finite;
  for (std::size_t i = 0; i + 2 < xyz.size(); i += 3) {
    if (!finitePoint(&xyz[i])) continue;
    finite.push_back(i);
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], xyz[i + a]), hi[a] = std::max(hi[a], xyz[i + a]);
  }
  if (finite.empty()) {
    for (std::size_t k = 0; k < n; ++k) q.push_back({float(k), -float(k), 0.5f});
    return q;
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.5, 1.5);
  for (std::size_t k = 0; k < n; ++k) {
    if (k % 3 == 0) {
      const std::size_t i = finite[rng() % finite.size()];
      q.push_back(g.toLocal(xyz[i], xyz[i + 1], xyz[i + 2]));
    } else {
      double p[3];
      for (int a = 0; a < 3; ++a)
        p[a] = lo[a] + u(rng) * std::max(hi[a] - lo[a], 1e-3 * (1 + std::fabs(lo[a])));
      q.push_back(g.toLocal(p[0], p[1], p[2]));
    }
  }
  return q;
}

std::string checkAgainstBruteForce(const std::vector<double>& xyz, const dw::DelaunayGraph::ConstPtr& g,
                                   const std::vector<dw::Vec3f>& queries) {
  using namespace dw;
  const NeighbourSearch search(g);
  float scale2 = 0.f;
  for (const Vec3f& p : g->points) scale2 = std::max(scale2, 4.f * dot(p, p));
  std::vector<index_t> idx;
  std::vector<float> d2;
  std::ostringstream why;
  for (std::size_t qi = 0; qi < queries.size(); ++qi) {
    const Vec3f& q = queries[qi];
    const auto all = bruteForce(*g, xyz, q);
    if (all.empty()) {
      if (search.nearest(q).vertex != kInvalidIndex) return "nearest on an empty graph returned a vertex";
      if (search.knn(q, 5, search.nearest(q), idx, d2) != 0) return "knn on an empty graph returned results";
      continue;
    }
    for (StartStrategy s :
         {StartStrategy::Zero, StartStrategy::KdAnn, StartStrategy::Pnn, StartStrategy::PnnOptimized}) {
      const WalkResult r = search.nearest(q, s, index_t(qi * 7919 % g->numVertices()));
      if (r.vertex >= g->numVertices() || std::fabs(r.dist2 - all[0]) > tolerance(all[0], scale2)) {
        why << "query " << qi << " strategy " << toString(s) << ": nearest dist2 " << r.dist2
            << ", brute force " << all[0];
        return why.str();
      }
    }
    const WalkResult nn = search.nearest(q);
    for (std::size_t k : {std::size_t(1), std::size_t(3), std::size_t(16), all.size() + 3}) {
      search.knn(q, k, nn, idx, d2);
      if (idx.size() != std::min(k, all.size())) {
        why << "query " << qi << ": knn(" << k << ") gave " << idx.size() << " of " << all.size();
        return why.str();
      }
      std::vector<index_t> sorted_idx(idx);
      std::sort(sorted_idx.begin(), sorted_idx.end());
      if (std::adjacent_find(sorted_idx.begin(), sorted_idx.end()) != sorted_idx.end())
        return "knn returned an input index twice";
      for (std::size_t r = 0; r < idx.size(); ++r) {
        const double* p = &xyz[3 * std::size_t(idx[r])];
        if (3 * std::size_t(idx[r]) + 2 >= xyz.size() || !finitePoint(p))
          return "knn returned a non-finite input";
        const float own = squaredDistance(q, g->toLocal(p[0], p[1], p[2]));
        if (std::fabs(d2[r] - all[r]) > tolerance(all[r], scale2) ||
            std::fabs(own - d2[r]) > tolerance(own, scale2)) {
          why << "query " << qi << ": knn(" << k << ") rank " << r << " dist2 " << d2[r] << " (own " << own
              << "), brute force " << all[r];
          return why.str();
        }
      }
    }
    // Radius through the 5th neighbour (or the last), widened by the tolerance: ties on the sphere may
    // fall either way, everything strictly inside must be found.
    const float r2 = all[std::min<std::size_t>(4, all.size() - 1)];
    search.radius(q, r2, nn, idx, d2);
    const std::size_t must =
        std::lower_bound(all.begin(), all.end(), r2 - tolerance(r2, scale2)) - all.begin();
    const std::size_t may =
        std::upper_bound(all.begin(), all.end(), r2 + tolerance(r2, scale2)) - all.begin();
    if (idx.size() < must || idx.size() > may) {
      why << "query " << qi << ": radius2 " << r2 << " gave " << idx.size() << ", expected " << must << ".."
          << may;
      return why.str();
    }
  }
  return "";
}

}  // namespace dw_robust
