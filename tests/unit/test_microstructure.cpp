// Unit tests for physics/packing/microstructure: seed 001's neighbour / eccentricity figures and
// the wall density profile on a simple cubic lattice, where every figure has a closed form.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <vector>

#include "physics/packing/microstructure.hpp"

namespace test_microstructure {

using namespace sparkdem;
using namespace sparkdem::physics;

namespace {

/// k^3 spheres of radius r, spacing 2r, filling the box [0, 2rk]^3 exactly (touching its faces).
struct Lattice {
  std::vector<Vec3> x;
  std::vector<double> r;
  BoxRegion box;
};
Lattice cubic(int k, double r) {
  Lattice l;
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j)
      for (int m = 0; m < k; ++m) {
        l.x.emplace_back(r * (2 * i + 1), r * (2 * j + 1), r * (2 * m + 1));
        l.r.push_back(r);
      }
  l.box = BoxRegion{Vec3::Zero(), Vec3::Constant(2.0 * r * k)};
  return l;
}

}  // namespace

TEST_CASE("neighbour_stats: cubic lattice, counts 3/4/5/6 and the face / edge / corner eccentricities (Eq. 2)",
          "[packing][microstructure]") {
  const int k = 6;
  const Lattice l = cubic(k, 1e-4);
  // Touching lattice pairs have gap 0; a tolerance of 1 % of r keeps the diagonal (gap 0.83 r) out.
  const NeighbourStats s = neighbour_stats(l.x, l.r, 0.01, l.box);
  // Corners 8 (3 neighbours), edges 12 (k - 2) (4), faces 6 (k - 2)^2 (5), inside (k - 2)^3 (6).
  REQUIRE(s.histogram.size() == 7);
  CHECK(s.histogram[3] == 8);
  CHECK(s.histogram[4] == 12 * (k - 2));
  CHECK(s.histogram[5] == 6 * (k - 2) * (k - 2));
  CHECK(s.histogram[6] == (k - 2) * (k - 2) * (k - 2));
  const double n = k * k * k;
  CHECK(s.mean == Approx((3.0 * 8 + 4.0 * 12 * (k - 2) + 5.0 * 6 * (k - 2) * (k - 2) + 6.0 * std::pow(k - 2, 3)) / n).epsilon(1e-14));
  // Every surface element is eccentric (face 0.4 >= 0.4, edge 0.707, corner 1.155), no inner one.
  CHECK(s.eccentric_share == Approx((n - std::pow(k - 2, 3)) / n).epsilon(1e-14));
  // Interior: centre farther than r + 2 r_mean = 3r from every face. The second layer's centres
  // sit at exactly 3r, on the threshold (either side in floating point): the interior is the
  // (k - 4)^3 or the (k - 2)^3 block, neither with an eccentric element.
  CHECK((s.interior_share == Approx(std::pow(k - 4, 3) / n).epsilon(1e-14) ||
         s.interior_share == Approx(std::pow(k - 2, 3) / n).epsilon(1e-14)));
  CHECK(s.eccentric_share_interior == 0.0);
  // Fig. 4 bins of 0.1: inside -> bin 0, faces -> bin 4 (e = 0.4), edges -> 7, corners -> 11.
  REQUIRE(s.eccentricity_histogram.size() == 15);
  CHECK(s.eccentricity_histogram[0] == Approx(std::pow(k - 2, 3) / n));
  CHECK(s.eccentricity_histogram[7] == Approx(12 * (k - 2) / n));
  CHECK(s.eccentricity_histogram[11] == Approx(8 / n));
  CHECK(s.eccentricity_histogram[4] + s.eccentricity_histogram[3] == Approx(6 * (k - 2) * (k - 2) / n));
}

TEST_CASE("neighbour_stats: the gap tolerance is relative to the mean radius", "[packing][microstructure]") {
  // Two spheres r = 1 mm with a gap of 0.05 mm = 0.05 r_mean: neighbours at 0.05, not at 0.049.
  const std::vector<Vec3> x = {Vec3(0, 0, 0), Vec3(2.05e-3, 0, 0)};
  const std::vector<double> r = {1e-3, 1e-3};
  const BoxRegion box{Vec3::Constant(-1e-2), Vec3::Constant(1e-2)};
  CHECK(neighbour_stats(x, r, 0.0501, box).mean == 1.0);
  CHECK(neighbour_stats(x, r, 0.049, box).mean == 0.0);
  CHECK_THROWS_AS(neighbour_stats(x, r, -0.1, box), ConfigError);
}

TEST_CASE("wall_density_profile: a cubic lattice has pi/6 in every layer of half a diameter", "[packing][microstructure]") {
  // Every layer between box shrinks by multiples of r is a union of cubes of side r aligned with
  // the lattice; each such cube holds one eighth of one sphere: solid fraction pi/6 exactly.
  const double r = 1e-4;
  const Lattice l = cubic(8, r);
  const DensityProfile p = wall_density_profile(l.x, l.r, l.box, r, 0.0, 4.0 * r);
  REQUIRE(p.density.size() == 7);  // depth 8r, layers [0, r), ..., [6r, 7r); the last [7r, 8r) is the core
  for (double d : p.density) CHECK(d == Approx(std::numbers::pi / 6.0).epsilon(1e-9));
  CHECK(p.interior == Approx(std::numbers::pi / 6.0).epsilon(1e-9));
  CHECK(p.max_deviation_beyond < 1e-9);
}

TEST_CASE("wall_density_profile: cylinder annuli conserve the solid volume", "[packing][microstructure]") {
  // Spheres on a ring pattern inside a cylinder: sum over annuli of density x annulus volume plus
  // the core equals the solid volume of the body between the end margins.
  std::vector<Vec3> x;
  std::vector<double> r;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 5; ++j) {
      const double a = 0.7 * i, rho = 0.15e-3 + 0.17e-3 * j;
      x.emplace_back(rho * std::cos(a), rho * std::sin(a), 0.2e-3 + 0.1e-3 * (i % 20));
      r.push_back(0.06e-3);
    }
  const CylinderRegion c{Vec3::Zero(), Vec3::UnitZ(), 1e-3, 2.4e-3};
  const double w = 0.1e-3, end = 0.3e-3;
  const DensityProfile p = wall_density_profile(x, r, c, w, end, 0.4e-3);
  const CylinderRegion body{Vec3(0, 0, end), Vec3::UnitZ(), 1e-3, 2.4e-3 - 2 * end};
  double sum = 0.0, ro = 1e-3;
  for (double d : p.density) {
    sum += d * std::numbers::pi * (ro * ro - (ro - w) * (ro - w)) * body.height;
    ro -= w;
  }
  const CylinderRegion core{body.base, body.axis, ro, body.height};
  sum += solid_volume_in_region(x, r, core);
  CHECK(sum == Approx(solid_volume_in_region(x, r, body)).epsilon(1e-10));
}

}  // namespace test_microstructure
