// Neighbour search: the multi-level cell grid finds exactly the pairs of the O(N^2) reference
// for strongly polydisperse sets (size ratios 15 and 50), before and after random motion, and
// the Verlet criterion guarantees that no contact is missed between rebuilds.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include <omp.h>

#include "engine/neighbor/neighbor_search.hpp"
#include "tests/support/scene.hpp"

namespace test_neighbor {

using namespace sparkdem;

namespace {

using PairList = std::vector<std::array<Index, 2>>;

/// Pairs as sorted unordered pairs (min, max).
std::vector<std::pair<Index, Index>> normalised(const PairList& in) {
  std::vector<std::pair<Index, Index>> out;
  out.reserve(in.size());
  for (const auto& p : in) out.emplace_back(std::min(p[0], p[1]), std::max(p[0], p[1]));
  std::sort(out.begin(), out.end());
  return out;
}

/// Move every particle by a random vector of length up to `amax`.
void jiggle(std::vector<Vec3>& x, double amax, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (auto& xi : x) {
    const Vec3 dir = Vec3(g(rng), g(rng), g(rng)).normalized();
    xi += amax * u(rng) * dir;
  }
}

}  // namespace

TEST_CASE("find_pairs equals brute force for polydisperse sets (ratios 15, 50)", "[neighbor]") {
  for (double ratio : {15.0, 50.0}) {
    for (double skin_factor : {0.0, 0.3}) {
      const std::size_t n = 3000;
      const double rmin = 1e-4;
      std::vector<Vec3> x;
      std::vector<double> r;
      // Sphere volume equal to the box volume (overlaps allowed): a few neighbours per particle.
      test::random_polydisperse(n, rmin, ratio, 1.0, 77 + static_cast<std::uint64_t>(ratio), x, r);
      const double skin = skin_factor * rmin;
      INFO("ratio " << ratio << " skin " << skin);
      NeighborStats st;
      const auto fast = normalised(find_pairs(x, r, skin, &st));
      const auto ref = normalised(find_pairs_brute_force(x, r, skin));
      // Exact comparison of the two sets (integer pairs); the list must be non-trivial.
      REQUIRE(ref.size() > n);
      CHECK(st.levels >= 4);                                              // several size levels are really exercised (log2 15 ~ 3.9)
      CHECK(std::adjacent_find(fast.begin(), fast.end()) == fast.end());  // each pair once
      CHECK(fast == ref);
      // After random motion of up to 3 rmin (the cells and levels are rebuilt from scratch).
      jiggle(x, 3.0 * rmin, 5);
      CHECK(normalised(find_pairs(x, r, skin)) == normalised(find_pairs_brute_force(x, r, skin)));
    }
  }
}

TEST_CASE("find_pairs and wall_candidates give the brute-force lists in the same order on 1 and 2 threads", "[neighbor]") {
  // One size class (radii within a factor 2: the grid path without size levels), 12,000 spheres in
  // a cube, six planes and a cylinder; 12,000 x 7 wall tests are above the light-loop minimum
  // of either wait policy, so two threads really split the wall pass. Exact integer comparison.
  const std::size_t n = 12000;
  std::vector<Vec3> x;
  std::vector<double> r;
  const double box = test::random_polydisperse(n, 0.02, 1.8, 1.0, 4242, x, r);
  const double skin = 0.004;
  std::vector<Wall> walls;
  for (int d = 0; d < 3; ++d)
    for (int side = 0; side < 2; ++side) {
      Wall w;
      w.name = "p" + std::to_string(2 * d + side);
      Vec3 nrm = Vec3::Zero();
      nrm[d] = side == 0 ? 1.0 : -1.0;
      w.shape = PlaneShape{side == 0 ? Vec3::Zero() : Vec3(box * Vec3::Ones()), nrm};
      walls.push_back(w);
    }
  Wall cyl;
  cyl.name = "cyl";
  cyl.shape = CylinderShape{Vec3(0.5 * box, 0.5 * box, 0.0), Vec3::UnitZ(), 0.45 * box};
  cyl.u = 0.01;
  walls.push_back(cyl);
  // The reference: every particle against every wall, in index order.
  std::vector<std::vector<Index>> ref(walls.size());
  for (std::size_t k = 0; k < walls.size(); ++k)
    for (std::size_t i = 0; i < n; ++i) {
      Vec3 nrm;
      double d;
      walls[k].distance(x[i], nrm, d);
      if (d < r[i] + skin) ref[k].push_back(static_cast<Index>(i));
    }
  const PairList brute = find_pairs_brute_force(x, r, skin);
  REQUIRE(brute.size() > n);
  for (std::size_t k = 0; k < walls.size(); ++k) REQUIRE(ref[k].size() > 100);
  const int before = omp_get_max_threads();
  for (int threads : {1, 2}) {
    INFO("threads " << threads);
    omp_set_num_threads(threads);
    NeighborStats st;
    CHECK(find_pairs(x, r, skin, &st) == brute);  // one level: (i, j), j > i, sorted, as brute force lists them
    CHECK(st.levels == 1);
    CHECK(wall_candidates(walls, x, r, skin) == ref);
  }
  omp_set_num_threads(before);
  CHECK(wall_candidates({}, x, r, skin).empty());
}

TEST_CASE("find_pairs handles degenerate inputs", "[neighbor]") {
  // Coincident centres, all particles on a line (flat bounding box) and a lone particle: exact
  // comparison with brute force.
  std::vector<Vec3> x{Vec3::Zero(), Vec3::Zero(), Vec3(1e-3, 0, 0), Vec3(2.5e-3, 0, 0), Vec3(40e-3, 0, 0)};
  std::vector<double> r{1e-3, 0.2e-3, 0.5e-3, 1e-3, 0.02e-3};
  CHECK(normalised(find_pairs(x, r, 0.0)) == normalised(find_pairs_brute_force(x, r, 0.0)));
  CHECK(find_pairs({Vec3::Zero()}, {1.0}, 0.1).empty());
}

TEST_CASE("Verlet criterion: moves below skin/2 keep every contact in the old list", "[neighbor]") {
  const std::size_t n = 2000;
  const double rmin = 1e-4, skin = 0.3 * rmin;
  std::vector<Vec3> x;
  std::vector<double> r;
  // A dense set (many near-contacts), size ratio 15.
  test::random_polydisperse(n, rmin, 15.0, 0.4, 11, x, r);
  const auto list = find_pairs(x, r, skin);
  std::set<std::pair<Index, Index>> old;
  for (const auto& p : list) old.emplace(std::min(p[0], p[1]), std::max(p[0], p[1]));
  VerletTracker vt;
  vt.mark_built(x, r);
  CHECK_FALSE(vt.needs_rebuild(x, r, skin));

  for (std::uint64_t seed : {1, 2, 3}) {
    std::vector<Vec3> y = x;
    // Every particle moves by (almost) the largest allowed amount, skin/2, in a random direction.
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> g(0.0, 1.0);
    for (auto& yi : y) yi += 0.4999 * skin * Vec3(g(rng), g(rng), g(rng)).normalized();
    REQUIRE_FALSE(vt.needs_rebuild(y, r, skin));
    // Every pair in contact now (d < r_i + r_j) was in the old candidate list.
    const auto touching = find_pairs_brute_force(y, r, 0.0);
    REQUIRE(touching.size() > n / 2);
    std::size_t missing = 0;
    for (const auto& p : touching) missing += old.count({std::min(p[0], p[1]), std::max(p[0], p[1])}) == 0;
    CHECK(missing == 0);
  }
  // Moving two facing particles by slightly more than skin/2 each can create a contact absent
  // from the list: the tracker must ask for a rebuild.
  std::vector<Vec3> y = x;
  y[7] += Vec3(0.51 * skin, 0, 0);
  CHECK(vt.needs_rebuild(y, r, skin));
  // Radius growth counts like displacement: growth of skin/2 (plus a hair) triggers a rebuild.
  std::vector<double> r2 = r;
  r2[3] += 0.51 * skin;
  CHECK(vt.needs_rebuild(x, r2, skin));
  r2[3] = r[3] + 0.49 * skin;
  CHECK_FALSE(vt.needs_rebuild(x, r2, skin));
}

}  // namespace test_neighbor
