// Unit tests for physics/packing/packing_metrics: sphere-region volumes against closed forms
// and an independent 1-D integral, lattice density and coordination, overlap statistics.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <vector>

#include "physics/packing/packing_metrics.hpp"

namespace test_packing_metrics {

using namespace sparkdem;
using namespace sparkdem::physics;

namespace {

constexpr double kPi = std::numbers::pi;

double sphere_volume(double r) { return 4.0 / 3.0 * kPi * r * r * r; }
/// Spherical cap of height h: pi h^2 (3r - h) / 3.
double cap_volume(double r, double h) { return kPi * h * h * (3.0 * r - h) / 3.0; }

/// Independent reference for a sphere (radius r, centre at distance q from the axis of an
/// infinitely long cylinder of radius R): integrate in polar coordinates (s, phi) about the
/// sphere centre's projection; the chord length through the sphere at distance s is
/// 2 sqrt(r^2 - s^2), and int_a^b 2 sqrt(r^2 - s^2) s ds = 2/3 [(r^2 - a^2)^{3/2} - (r^2 - b^2)^{3/2}].
/// The ray at angle phi is inside the circle for s in [s1, s2] (roots of |c + s u| = R).
/// Midpoint rule over phi with m points.
double sphere_in_infinite_cylinder_reference(double r, double big_r, double q, int m) {
  double sum = 0.0;
  for (int k = 0; k < m; ++k) {
    const double phi = 2.0 * kPi * (k + 0.5) / m;
    const double cu = q * std::cos(phi);
    const double disc = cu * cu - (q * q - big_r * big_r);
    if (disc <= 0.0) continue;
    const double s1 = std::max(0.0, -cu - std::sqrt(disc)), s2 = -cu + std::sqrt(disc);
    if (s2 <= 0.0) continue;
    const double a = std::min(r, s1), b = std::min(r, s2);
    sum += 2.0 / 3.0 * (std::pow(r * r - a * a, 1.5) - std::pow(r * r - b * b, 1.5));
  }
  return sum * 2.0 * kPi / m;
}

struct Lattice {
  std::vector<Vec3> x;
  std::vector<double> r;
  std::vector<std::array<Index, 2>> pairs;  // every pair closer than 3 r: includes non-touching diagonals
};

/// Simple-cubic lattice n x n x n of spheres of radius r, spacing 2 r (1 + gap), first centre at origin.
Lattice simple_cubic(int n, double r, double gap = 0.0) {
  Lattice l;
  const double a = 2.0 * r * (1.0 + gap);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        l.x.emplace_back(a * i, a * j, a * k);
        l.r.push_back(r);
      }
  for (std::size_t i = 0; i < l.x.size(); ++i)
    for (std::size_t j = i + 1; j < l.x.size(); ++j)
      if ((l.x[i] - l.x[j]).norm() < 3.0 * r) l.pairs.push_back({static_cast<Index>(i), static_cast<Index>(j)});
  return l;
}

}  // namespace

TEST_CASE("region volume, shrink and contains", "[packing_metrics]") {
  const Region box = BoxRegion{Vec3(0, 0, 0), Vec3(1, 2, 3)};
  CHECK(region_volume(box) == Approx(6.0).epsilon(1e-15));
  const auto inner = std::get<BoxRegion>(shrink(box, 0.25));
  CHECK(inner.lo.x() == Approx(0.25).epsilon(1e-15));
  CHECK(inner.hi.z() == Approx(2.75).epsilon(1e-15));
  CHECK(region_volume(inner) == Approx(0.5 * 1.5 * 2.5).epsilon(1e-14));
  CHECK_THROWS_AS(shrink(box, 0.5), ConfigError);  // x extent would be 0

  const Region cyl = CylinderRegion{Vec3(1, 1, 1), Vec3(1, 0, 0), 0.5, 2.0};
  CHECK(region_volume(cyl) == Approx(kPi * 0.25 * 2.0).epsilon(1e-15));
  const auto c2 = std::get<CylinderRegion>(shrink(cyl, 0.1));
  CHECK(c2.base.x() == Approx(1.1).epsilon(1e-15));
  CHECK(c2.radius == Approx(0.4).epsilon(1e-15));
  CHECK(c2.height == Approx(1.8).epsilon(1e-15));
  CHECK(contains(cyl, Vec3(2.0, 1.3, 1.3)));
  CHECK_FALSE(contains(cyl, Vec3(2.0, 1.4, 1.4)));  // radial distance 0.566 > 0.5
  CHECK_FALSE(contains(cyl, Vec3(3.1, 1.0, 1.0)));  // beyond the top
  CHECK_THROWS_AS(region_volume(CylinderRegion{Vec3::Zero(), Vec3(1, 1, 0), 1.0, 1.0}), ConfigError);
}

TEST_CASE("sphere fully inside or fully outside a region", "[packing_metrics]") {
  const double r = 1e-3;
  const Region box = BoxRegion{Vec3(0, 0, 0), Vec3(0.01, 0.01, 0.01)};
  const Region cyl = CylinderRegion{Vec3(0.005, 0.005, 0), Vec3::UnitZ(), 0.004, 0.01};
  // exact counts: 4/3 pi r^3 or 0, no quadrature involved (1e-15 relative)
  CHECK(sphere_volume_in_region(Vec3(0.005, 0.005, 0.005), r, box) == Approx(sphere_volume(r)).epsilon(1e-15));
  CHECK(sphere_volume_in_region(Vec3(0.001, 0.001, 0.001), r, box) == Approx(sphere_volume(r)).epsilon(1e-15));  // touching 3 faces
  CHECK(sphere_volume_in_region(Vec3(-0.001, 0.005, 0.005), r, box) == Approx(0.0).margin(1e-30));               // touching from outside
  CHECK(sphere_volume_in_region(Vec3(0.02, 0.02, 0.02), r, box) == Approx(0.0).margin(1e-30));
  CHECK(sphere_volume_in_region(Vec3(0.005, 0.005, 0.005), r, cyl) == Approx(sphere_volume(r)).epsilon(1e-15));
  CHECK(sphere_volume_in_region(Vec3(0.005, 0.008, 0.005), r, cyl) == Approx(sphere_volume(r)).epsilon(1e-15));  // touching wall
  CHECK(sphere_volume_in_region(Vec3(0.005, 0.0100001, 0.005), r, cyl) == Approx(0.0).margin(1e-30));
  // a sphere near a box corner but outside it (in every slab's bounding range, outside the box)
  // is handled by the quadrature: distance to the corner 1.5 r
  const double o = -1.5 * r / std::sqrt(3.0);
  CHECK(sphere_volume_in_region(Vec3(o, o, o), r, box) == Approx(0.0).margin(1e-12 * sphere_volume(r)));
}

TEST_CASE("sphere cut by one plane: spherical cap closed form", "[packing_metrics]") {
  const double r = 2e-4;
  const Region box = BoxRegion{Vec3(-1, -1, -1), Vec3(1, 1, 0)};  // top face z = 0
  const Region cyl = CylinderRegion{Vec3(0, 0, -1), Vec3::UnitZ(), 1.0, 1.0};
  const Region side = BoxRegion{Vec3(-1, -1, -1), Vec3(0, 1, 1)};  // face x = 0
  for (double h : {1e-6 * r, 1e-3 * r, 0.3 * r, r, 1.7 * r, (2.0 - 1e-6) * r}) {
    // centre placed so that a cap of height h sticks out above z = 0 (or beyond x = 0)
    const double expected = cap_volume(r, 2.0 * r - h);  // the part left inside is a cap of height 2r - h
    // Tolerance 1e-9 relative (brief asks 1e-6): the slab formula is exact up to rounding. The
    // margin 1e-15 of the sphere volume covers the thinnest cap (2e-10 m) in the cylinder, whose
    // base is 1 m away: the axial coordinate c.z + 1 is rounded to ~1e-16 m (error ~ pi 2 r h 1e-16).
    const double tiny = 1e-15 * sphere_volume(r);
    CHECK(sphere_volume_in_region(Vec3(0.1, 0.2, h - r), r, box) == Approx(expected).epsilon(1e-9).margin(tiny));
    CHECK(sphere_volume_in_region(Vec3(0.1, 0.2, h - r), r, cyl) == Approx(expected).epsilon(1e-9).margin(tiny));
    CHECK(sphere_volume_in_region(Vec3(h - r, 0.2, 0.1), r, side) == Approx(expected).epsilon(1e-9).margin(tiny));
    // the complementary region holds the cap
    const Region above = BoxRegion{Vec3(-1, -1, 0), Vec3(1, 1, 1)};
    CHECK(sphere_volume_in_region(Vec3(0.1, 0.2, h - r), r, above) == Approx(cap_volume(r, h)).epsilon(1e-9));
  }
}

TEST_CASE("quadrature for spheres cut by several box faces", "[packing_metrics]") {
  const double r = 1.0;
  const double v = sphere_volume(r);
  // Centre on an edge / at a corner: exactly 1/4 and 1/8 of the sphere (tolerance 1e-12 relative).
  CHECK(sphere_volume_in_region(Vec3(0, 0, 0.5), r, BoxRegion{Vec3(0, 0, -5), Vec3(5, 5, 5)}) == Approx(v / 4.0).epsilon(1e-12));
  CHECK(sphere_volume_in_region(Vec3(0, 0, 0), r, BoxRegion{Vec3(0, 0, 0), Vec3(5, 5, 5)}) == Approx(v / 8.0).epsilon(1e-12));
  // Eight octant boxes meeting at an arbitrary point p inside the sphere partition it: the sum of
  // the eight numerically integrated pieces is the whole sphere (1e-12 relative).
  const Vec3 c(0.0, 0.0, 0.0);
  for (const Vec3& p : {Vec3(0.3, -0.2, 0.45), Vec3(-0.7, 0.1, 0.2), Vec3(0.05, 0.6, -0.65)}) {
    double sum = 0.0;
    for (int sx = 0; sx < 2; ++sx)
      for (int sy = 0; sy < 2; ++sy)
        for (int sz = 0; sz < 2; ++sz) {
          Vec3 lo, hi;
          const int s[3] = {sx, sy, sz};
          for (int k = 0; k < 3; ++k) {
            lo[k] = s[k] ? p[k] : -3.0;
            hi[k] = s[k] ? 3.0 : p[k];
          }
          sum += sphere_volume_in_region(c, r, BoxRegion{lo, hi});
        }
    CHECK(sum == Approx(v).epsilon(1e-12));
  }
  // Sphere cut by four side faces of a narrow column (x, y in [-0.4, 0.5] x [-0.3, 0.6]) against
  // the independent polar-angle integral of the column (midpoint rule, 2e5 angles):
  // V = int_0^{2 pi} 2/3 (r^3 - (r^2 - m^2)^{3/2}) dphi, m = min(r, distance to the rectangle edge).
  {
    const double xl = -0.4, xh = 0.5, yl = -0.3, yh = 0.6;
    const int m = 200'000;
    double ref = 0.0;
    for (int k = 0; k < m; ++k) {
      const double phi = 2.0 * kPi * (k + 0.5) / m;
      const double ux = std::cos(phi), uy = std::sin(phi);
      double s = r;
      if (ux > 0) s = std::min(s, xh / ux);
      if (ux < 0) s = std::min(s, xl / ux);
      if (uy > 0) s = std::min(s, yh / uy);
      if (uy < 0) s = std::min(s, yl / uy);
      ref += 2.0 / 3.0 * (r * r * r - std::pow(r * r - s * s, 1.5));
    }
    ref *= 2.0 * kPi / m;
    // tolerance 1e-9: limited by the midpoint-rule reference (kinks where s = r), whose own
    // error at 2e5 angles is ~5e-11 (from runs with 8e5 and 3.2e6 angles)
    CHECK(sphere_volume_in_region(c, r, BoxRegion{Vec3(xl, yl, -2), Vec3(xh, yh, 2)}) == Approx(ref).epsilon(1e-9));
  }
}

TEST_CASE("sphere cut by the curved wall of a cylinder", "[packing_metrics]") {
  const double r = 1.0;
  // On the axis with R < r, cylinder longer than the sphere: closed form
  //   V = 4/3 pi (r^3 - (r^2 - R^2)^{3/2}).
  for (double big_r : {0.2, 0.5, 0.99}) {
    const Region cyl = CylinderRegion{Vec3(0, 0, -3), Vec3::UnitZ(), big_r, 6.0};
    const double expected = 4.0 / 3.0 * kPi * (r * r * r - std::pow(r * r - big_r * big_r, 1.5));
    CHECK(sphere_volume_in_region(Vec3::Zero(), r, cyl) == Approx(expected).epsilon(1e-12));
  }
  // Off the axis (centre inside and outside the circle; small and large R) against the polar
  // reference with 1e6 angles. Tolerance 1e-9: the midpoint reference converges like m^-1.5 at
  // tangent rays; for these cases it agrees with a 4e6-angle run to < 4e-11.
  struct Case {
    double big_r, q;
  };
  for (const Case cs : {Case{0.8, 0.5}, Case{3.0, 2.5}, Case{3.0, 3.6}, Case{0.5, 1.2}, Case{0.3, 0.1}}) {
    const Vec3 axis = Vec3(1, 2, 2).normalized();
    const Vec3 perp = Vec3(2, -1, 0).normalized();  // perpendicular to axis
    const Region cyl = CylinderRegion{-5.0 * axis + cs.q * perp, axis, cs.big_r, 10.0};
    const double ref = sphere_in_infinite_cylinder_reference(r, cs.big_r, cs.q, 1'000'000);
    CHECK(sphere_volume_in_region(Vec3::Zero(), r, cyl) == Approx(ref).epsilon(1e-9));
  }
  // Curved wall and an end face together: the half-space z >= 0 of the on-axis case is exactly half.
  {
    const double big_r = 0.6;
    const Region half = CylinderRegion{Vec3(0, 0, 0), Vec3::UnitZ(), big_r, 5.0};
    const double expected = 2.0 / 3.0 * kPi * (r * r * r - std::pow(r * r - big_r * big_r, 1.5));
    CHECK(sphere_volume_in_region(Vec3::Zero(), r, half) == Approx(expected).epsilon(1e-12));
  }
}

TEST_CASE("simple-cubic lattice of touching spheres: density pi/6 and coordination 6", "[packing_metrics]") {
  const int n = 8;
  const double r = 5e-4;
  const auto l = simple_cubic(n, r);
  const double a = 2.0 * r;
  // Whole lattice in its bounding box: n^3 spheres in (2 r n)^3 -> pi/6 exactly.
  const Region bounding = BoxRegion{Vec3::Constant(-r), Vec3::Constant(a * (n - 1) + r)};
  // Tolerances are far below the brief's 1e-3 because the regions are aligned with the lattice:
  // the result is pi/6 exactly up to rounding (1e-12) or quadrature (1e-9).
  CHECK(packing_density(l.x, l.r, bounding) == Approx(kPi / 6.0).epsilon(1e-12));
  // Interior region, faces on tangent planes (one cell in from every side): no sphere is cut.
  CHECK(packing_density(l.x, l.r, shrink(bounding, a)) == Approx(kPi / 6.0).epsilon(1e-12));
  // Interior region with faces through sphere centres: face spheres count 1/2, edge spheres 1/4
  // (quadrature), corner spheres 1/8 (quadrature); the total is still pi/6 of the box.
  const Region through_centres = BoxRegion{Vec3::Constant(a), Vec3::Constant(a * (n - 2))};
  CHECK(packing_density(l.x, l.r, through_centres) == Approx(kPi / 6.0).epsilon(1e-9));
  // Solid volume in the bounding box = sum of sphere volumes (1e-12).
  CHECK(solid_volume_in_region(l.x, l.r, bounding) == Approx(n * n * n * sphere_volume(r)).epsilon(1e-12));

  // Coordination: every touching neighbour pair is in `pairs`, together with the non-touching
  // face diagonals (2 sqrt 2 r); the exact distance test must reject the latter.
  const auto all = coordination(l.x, l.r, l.pairs, 1e-9);
  // 3 n^2 (n - 1) contacts over n^3 particles: mean 6 (n - 1) / n (exact integer ratio).
  CHECK(all.mean == Approx(6.0 * (n - 1) / n).epsilon(1e-14));
  REQUIRE(all.histogram.size() == 7);
  CHECK(all.histogram[3] == 8);                      // corners
  CHECK(all.histogram[4] == 12 * (n - 2));           // edges
  CHECK(all.histogram[5] == 6 * (n - 2) * (n - 2));  // faces
  CHECK(all.histogram[6] == (n - 2) * (n - 2) * (n - 2));
  CHECK(all.rattlers == 0);
  // Interior particles only (centres at least one spacing from the lattice boundary).
  const Region interior = BoxRegion{Vec3::Constant(0.5 * a), Vec3::Constant(a * (n - 1.5))};
  const auto in = coordination_in_region(l.x, l.r, l.pairs, 1e-9, interior);
  CHECK(in.mean == Approx(6.0).epsilon(1e-14));
  REQUIRE(in.histogram.size() == 7);
  CHECK(in.histogram[6] == (n - 2) * (n - 2) * (n - 2));
}

TEST_CASE("coordination gap tolerance", "[packing_metrics]") {
  const int n = 4;
  const double r = 1e-3;
  const auto l = simple_cubic(n, r, 1e-4);  // neighbours separated by a relative gap of 1e-4
  const auto loose = coordination(l.x, l.r, l.pairs, 1e-3);
  CHECK(loose.mean == Approx(6.0 * (n - 1) / n).epsilon(1e-14));
  const auto strict = coordination(l.x, l.r, l.pairs, 0.0);
  CHECK(strict.mean == Approx(0.0).margin(1e-15));
  CHECK(strict.rattlers == static_cast<std::size_t>(n * n * n));
  REQUIRE(strict.histogram.size() == 1);
  CHECK(strict.histogram[0] == n * n * n);
}

TEST_CASE("overlap statistics of known pairs", "[packing_metrics]") {
  // Pair (0,1): r = 1 mm and 2 mm at 2.9 mm -> overlap 0.1 mm, relative to min r = 0.1.
  // Pair (1,2): r = 2 mm and 0.5 mm at 2.47 mm -> overlap 0.03 mm, relative 0.03 / 0.5 = 0.06.
  // Pair (0,2): far apart, not overlapping.
  const std::vector<Vec3> x = {Vec3(0, 0, 0), Vec3(2.9e-3, 0, 0), Vec3(2.9e-3, 2.47e-3, 0)};
  const std::vector<double> r = {1e-3, 2e-3, 0.5e-3};
  const std::vector<std::array<Index, 2>> pairs = {{0, 1}, {1, 2}, {0, 2}};
  const auto s = overlap_stats(x, r, pairs);
  // tolerances 1e-9: subtraction of nearly equal lengths in double
  CHECK(s.max_relative == Approx(0.1).epsilon(1e-9));
  CHECK(s.i == 0);
  CHECK(s.j == 1);
  CHECK(s.n_overlapping == 2);
  CHECK(s.mean_relative == Approx(0.5 * (0.1 + 0.06)).epsilon(1e-9));
  const auto none = overlap_stats(x, r, {{0, 2}});
  CHECK(none.max_relative == Approx(0.0).margin(1e-30));
  CHECK(none.i == -1);
  CHECK(none.n_overlapping == 0);
}

TEST_CASE("invalid packing-metric arguments throw ConfigError", "[packing_metrics]") {
  const std::vector<Vec3> x = {Vec3(0, 0, 0), Vec3(1, 0, 0)};
  const std::vector<double> r = {0.6, 0.6};
  const Region box = BoxRegion{Vec3(-1, -1, -1), Vec3(2, 1, 1)};
  CHECK_THROWS_AS(solid_volume_in_region(x, {0.6}, box), ConfigError);
  CHECK_THROWS_AS(solid_volume_in_region(x, {0.6, -0.1}, box), ConfigError);
  CHECK_THROWS_AS(coordination(x, r, {{0, 2}}, 0.0), ConfigError);
  CHECK_THROWS_AS(coordination(x, r, {{1, 1}}, 0.0), ConfigError);
  CHECK_THROWS_AS(coordination(x, r, {{0, 1}}, -0.1), ConfigError);
  CHECK_THROWS_AS(overlap_stats(x, r, {{-1, 1}}), ConfigError);
  CHECK_THROWS_AS(packing_density(x, r, BoxRegion{Vec3(0, 0, 0), Vec3(1, 0, 1)}), ConfigError);
  CHECK_THROWS_AS(shrink(box, -0.1), ConfigError);
}

}  // namespace test_packing_metrics
