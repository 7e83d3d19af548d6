#pragma once
/// Neighbour search for polydisperse spheres: a hierarchy of cell grids (one per size level,
/// radii binned by factors of 2), so that a size ratio of 15 or 50 does not force a single grid
/// sized by the largest particle. Candidate pairs are those with d < r_i + r_j + skin.
///
/// A particle queries the grids of its own level (taking only j > i) and of every coarser level;
/// each pair is therefore found exactly once. Pairs come out sorted by the first index, and the
/// order does not depend on the thread count.
#include <array>
#include <vector>

#include "engine/core/types.hpp"
#include "engine/walls/wall.hpp"

namespace sparkdem {

struct NeighborStats {
  int levels = 0;
  std::size_t cells = 0;
  std::size_t pairs = 0;
};

/// All pairs (i, j), i != j, with |x_i - x_j| < r_i + r_j + skin.
std::vector<std::array<Index, 2>> find_pairs(const std::vector<Vec3>& x, const std::vector<double>& r, double skin,
                                             NeighborStats* stats = nullptr);

/// Per wall, the particles whose centre lies within r + skin of it (signed distance), in ascending
/// index order whatever the thread count: one pass over the particles for all walls.
std::vector<std::vector<Index>> wall_candidates(const std::vector<Wall>& walls, const std::vector<Vec3>& x, const std::vector<double>& r,
                                                double skin);

/// O(N^2) reference used by the tests.
std::vector<std::array<Index, 2>> find_pairs_brute_force(const std::vector<Vec3>& x, const std::vector<double>& r, double skin);

/// Verlet bookkeeping: positions, radii and wall offsets at the last build; a rebuild is due
/// when 2 (max displacement + max radius growth + max wall travel) > skin. This keeps both the
/// pair list and the per-wall candidate lists (particles within r + skin of a wall) complete.
class VerletTracker {
 public:
  void mark_built(const std::vector<Vec3>& x, const std::vector<double>& r, std::vector<double> wall_u = {}) {
    x0_ = x;
    r0_ = r;
    u0_ = std::move(wall_u);
  }
  bool needs_rebuild(const std::vector<Vec3>& x, const std::vector<double>& r, double skin, const std::vector<double>& wall_u = {}) const;
  std::vector<Vec3>& x0() { return x0_; }
  std::vector<double>& r0() { return r0_; }
  std::vector<double>& u0() { return u0_; }

 private:
  std::vector<Vec3> x0_;
  std::vector<double> r0_;
  std::vector<double> u0_;
};

}  // namespace sparkdem
