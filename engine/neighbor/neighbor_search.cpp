#include "engine/neighbor/neighbor_search.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include "engine/core/parallel.hpp"

namespace sparkdem {

namespace {

struct Grid {
  Vec3 lo;
  double h = 1.0;
  std::array<std::int64_t, 3> n{1, 1, 1};
  double rmax = 0.0;
  std::vector<std::int64_t> start;  // CSR over cells
  std::vector<Index> members;

  std::int64_t coord(double v, int d) const {
    const auto c = static_cast<std::int64_t>(std::floor((v - lo[d]) / h));
    return std::clamp<std::int64_t>(c, 0, n[d] - 1);
  }
  std::int64_t cell(std::int64_t a, std::int64_t b, std::int64_t c) const { return (c * n[1] + b) * n[0] + a; }
};

/// The size levels and their cell grids: each particle's level, each level's cells (CSR, members
/// in ascending index order).
struct Grids {
  std::vector<Grid> grid;
  std::vector<int> level;
  std::size_t total_cells = 0;
};

Grids build_grids(const std::vector<Vec3>& x, const std::vector<double>& r, double skin) {
  const std::size_t n = x.size();
  Grids out;
  // Bounds of the radii and of the centres (max / min reductions are exact: any thread count).
  struct Bounds {
    double rmin, rmax;
    Vec3 lo, hi;
  };
  const std::int64_t ni = static_cast<std::int64_t>(n);
  const Bounds b = par::reduce(
      ni, par::kLight, Bounds{r[0], r[0], x[0], x[0]},
      [&](Bounds& m, std::int64_t i) {
        m.rmin = std::min(m.rmin, r[i]);
        m.rmax = std::max(m.rmax, r[i]);
        m.lo = m.lo.cwiseMin(x[i]);
        m.hi = m.hi.cwiseMax(x[i]);
      },
      [](Bounds& out, const Bounds& m) {
        out.rmin = std::min(out.rmin, m.rmin);
        out.rmax = std::max(out.rmax, m.rmax);
        out.lo = out.lo.cwiseMin(m.lo);
        out.hi = out.hi.cwiseMax(m.hi);
      });
  const double rmin = b.rmin, rmax = b.rmax;
  const Vec3 lo = b.lo, hi = b.hi;
  // Size levels: level L holds radii in [rmin 2^L, rmin 2^(L+1)).
  const int nlev = std::max(1, static_cast<int>(std::floor(std::log2(rmax / rmin))) + 1);
  std::vector<int>& level = out.level;
  level.assign(n, 0);
  std::vector<std::size_t> count(nlev, 0);
  std::vector<Grid>& grids = out.grid;
  grids.resize(nlev);
  if (nlev == 1) {  // one size class (a monodisperse or narrow distribution): no logarithm per particle
    count[0] = n;
    grids[0].rmax = rmax;
  } else {
    for (std::size_t i = 0; i < n; ++i) {
      level[i] = std::min(nlev - 1, static_cast<int>(std::floor(std::log2(r[i] / rmin))));
      ++count[level[i]];
      grids[level[i]].rmax = std::max(grids[level[i]].rmax, r[i]);
    }
  }
  for (int L = 0; L < nlev; ++L) {
    Grid& g = grids[L];
    if (count[L] == 0) continue;
    g.h = 2.0 * g.rmax + skin;
    g.lo = lo;
    const Vec3 ext = hi - lo;
    // Cap the number of cells at ~8 per particle of the level plus a floor, enlarging h if needed.
    const double cap = 8.0 * static_cast<double>(count[L]) + 64.0;
    for (;;) {
      for (int d = 0; d < 3; ++d) g.n[d] = std::max<std::int64_t>(1, static_cast<std::int64_t>(std::floor(ext[d] / g.h)) + 1);
      if (static_cast<double>(g.n[0]) * g.n[1] * g.n[2] <= cap) break;
      g.h *= 1.26;
    }
    out.total_cells += g.n[0] * g.n[1] * g.n[2];
  }
  // Each particle's cell in its level's grid (in parallel), then a counting sort per level: the
  // members of a cell in ascending index order.
  std::vector<std::int64_t> cid(n);
  par::for_each(ni, par::kLight, [&](std::int64_t i) {
    const Grid& g = grids[level[i]];
    cid[i] = g.cell(g.coord(x[i][0], 0), g.coord(x[i][1], 1), g.coord(x[i][2], 2));
  });
  for (int L = 0; L < nlev; ++L) {
    Grid& g = grids[L];
    if (count[L] == 0) continue;
    const std::int64_t nc = g.n[0] * g.n[1] * g.n[2];
    g.start.assign(nc + 1, 0);
    for (std::size_t i = 0; i < n; ++i)
      if (level[i] == L) ++g.start[cid[i] + 1];
    for (std::int64_t c = 0; c < nc; ++c) g.start[c + 1] += g.start[c];
    g.members.assign(count[L], 0);
    std::vector<std::int64_t> fill(g.start.begin(), g.start.end() - 1);
    for (std::size_t i = 0; i < n; ++i)
      if (level[i] == L) g.members[fill[cid[i]]++] = static_cast<Index>(i);  // ascending index per cell
  }
  return out;
}

/// The candidate pairs of every particle against its own level (j > i) and the coarser ones,
/// sorted by i then j: per-thread lists of contiguous particle ranges, joined in thread order.
std::vector<std::array<Index, 2>> search_pairs(const Grids& gs, const std::vector<Vec3>& x, const std::vector<double>& r, double skin) {
  const std::size_t n = x.size();
  const int nlev = static_cast<int>(gs.grid.size());
  const std::vector<int>& level = gs.level;
  const std::vector<Grid>& grids = gs.grid;
  std::vector<std::vector<std::array<Index, 2>>> local(par::threads());
  par::region(par::worth(static_cast<std::int64_t>(n), par::kHeavy), [&] {
    auto& buf = local[par::thread_num()];
    std::vector<Index> found;
#pragma omp for schedule(static) nowait
    for (std::int64_t ii = 0; ii < static_cast<std::int64_t>(n); ++ii) {
      const Index i = static_cast<Index>(ii);
      found.clear();
      for (int L = level[i]; L < nlev; ++L) {
        const Grid& g = grids[L];
        if (g.start.empty()) continue;
        const double range = r[i] + g.rmax + skin;
        std::array<std::int64_t, 3> a{}, b{};
        for (int d = 0; d < 3; ++d) {
          a[d] = g.coord(x[i][d] - range, d);
          b[d] = g.coord(x[i][d] + range, d);
        }
        for (std::int64_t cz = a[2]; cz <= b[2]; ++cz)
          for (std::int64_t cy = a[1]; cy <= b[1]; ++cy)
            for (std::int64_t cx = a[0]; cx <= b[0]; ++cx) {
              const std::int64_t c = g.cell(cx, cy, cz);
              for (std::int64_t k = g.start[c]; k < g.start[c + 1]; ++k) {
                const Index j = g.members[k];
                if (L == level[i] && j <= i) continue;
                const double cut = r[i] + r[j] + skin;
                if ((x[i] - x[j]).squaredNorm() < cut * cut) found.push_back(j);
              }
            }
      }
      std::sort(found.begin(), found.end());
      for (Index j : found) buf.push_back({i, j});
    }
  });
  std::vector<std::array<Index, 2>> out;
  std::size_t total = 0;
  for (auto& b : local) total += b.size();
  out.reserve(total);
  for (auto& b : local) out.insert(out.end(), b.begin(), b.end());
  return out;
}

}  // namespace

std::vector<std::array<Index, 2>> find_pairs(const std::vector<Vec3>& x, const std::vector<double>& r, double skin, NeighborStats* stats) {
  if (x.size() < 2) return {};
  const Grids gs = build_grids(x, r, skin);
  std::vector<std::array<Index, 2>> out = search_pairs(gs, x, r, skin);
  if (stats) {
    stats->levels = static_cast<int>(gs.grid.size());
    stats->cells = gs.total_cells;
    stats->pairs = out.size();
  }
  return out;
}

std::vector<std::vector<Index>> wall_candidates(const std::vector<Wall>& walls, const std::vector<Vec3>& x, const std::vector<double>& r,
                                                double skin) {
  const std::size_t nw = walls.size();
  const std::int64_t n = static_cast<std::int64_t>(x.size());
  std::vector<std::vector<Index>> out(nw);
  if (nw == 0) return out;
  // Each thread lists its static (contiguous, ascending) share of the particles per wall; the
  // lists are joined in thread order.
  std::vector<std::vector<std::vector<Index>>> local(par::threads(), std::vector<std::vector<Index>>(nw));
  par::region(par::worth(n * static_cast<std::int64_t>(nw), par::kLight), [&] {
    auto& mine = local[par::thread_num()];
#pragma omp for schedule(static) nowait
    for (std::int64_t i = 0; i < n; ++i)
      for (std::size_t k = 0; k < nw; ++k) {
        Vec3 nrm;
        double d;
        walls[k].distance(x[i], nrm, d);
        if (d < r[i] + skin) mine[k].push_back(static_cast<Index>(i));
      }
  });
  for (std::size_t k = 0; k < nw; ++k) {
    std::size_t total = 0;
    for (const auto& l : local) total += l[k].size();
    out[k].reserve(total);
    for (const auto& l : local) out[k].insert(out[k].end(), l[k].begin(), l[k].end());
  }
  return out;
}

std::vector<std::array<Index, 2>> find_pairs_brute_force(const std::vector<Vec3>& x, const std::vector<double>& r, double skin) {
  std::vector<std::array<Index, 2>> out;
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::size_t j = i + 1; j < x.size(); ++j) {
      const double cut = r[i] + r[j] + skin;
      if ((x[i] - x[j]).squaredNorm() < cut * cut) out.push_back({static_cast<Index>(i), static_cast<Index>(j)});
    }
  return out;
}

bool VerletTracker::needs_rebuild(const std::vector<Vec3>& x, const std::vector<double>& r, double skin,
                                  const std::vector<double>& wall_u) const {
  if (x.size() != x0_.size() || wall_u.size() != u0_.size()) return true;
  double du = 0.0;
  for (std::size_t k = 0; k < wall_u.size(); ++k) du = std::max(du, std::abs(wall_u[k] - u0_[k]));
  const std::int64_t n = static_cast<std::int64_t>(x.size());
  // max-reductions are exact, so the decision does not depend on the thread count
  using Moves = std::array<double, 2>;  // {max |x - x0|^2, max r - r0}
  const Moves m = par::reduce(
      n, par::kLight, Moves{0.0, 0.0},
      [&](Moves& a, std::int64_t i) {
        a[0] = std::max(a[0], (x[i] - x0_[i]).squaredNorm());
        a[1] = std::max(a[1], r[i] - r0_[i]);
      },
      [](Moves& out, const Moves& a) {
        out[0] = std::max(out[0], a[0]);
        out[1] = std::max(out[1], a[1]);
      });
  return 2.0 * (std::sqrt(m[0]) + m[1] + du) > skin;
}

}  // namespace sparkdem
