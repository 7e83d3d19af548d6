/// Porosity of a compact in a die: the lens volume of two overlapping spheres against a numerical
/// integral, the solid volume of an overlapping simple-cubic lattice against its closed form, and
/// the CompactMonitor (die radius and punch offsets, wall caps, the interior region).
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "physics/packing/compact.hpp"
#include "support/scene.hpp"
#include "support/tolerance.hpp"

namespace test_compact {

using namespace sparkdem;
using namespace sparkdem::physics;

namespace {
constexpr double kPi = std::numbers::pi;
double sphere_volume(double r) { return 4.0 / 3.0 * kPi * r * r * r; }
/// Spherical cap of height h of a sphere of radius r: pi h^2 (3 r - h) / 3.
double cap_volume(double r, double h) { return kPi * h * h * (3.0 * r - h) / 3.0; }

/// Lens volume by numerical integration along the centre line, knowing nothing of the lens:
/// V = int pi rho(x)^2 dx, rho(x)^2 = min(r_i^2 - x^2, r_j^2 - (d - x)^2) where both are > 0;
/// composite Simpson over [d - r_j, r_i] with n intervals (the kink at the intersection plane
/// limits it to O(h^2): ~1e-12 relative for n = 2e6).
double lens_numerical(double ri, double rj, double d, int n = 2000000) {
  const double a = std::max(-ri, d - rj), b = std::min(ri, d + rj);
  if (!(b > a)) return 0.0;
  auto f = [&](double x) {
    const double q = std::min(ri * ri - x * x, rj * rj - (d - x) * (d - x));
    return q > 0.0 ? kPi * q : 0.0;
  };
  const double h = (b - a) / n;
  double s = f(a) + f(b);
  for (int k = 1; k < n; ++k) s += (k % 2 ? 4.0 : 2.0) * f(a + k * h);
  return s * h / 3.0;
}

/// Simple-cubic lattice of n^3 spheres of radius r, spacing a, centres (k + 1/2) a + offset.
void sc_lattice(int n, double a, double r, double offset, std::vector<Vec3>& x, std::vector<double>& rad) {
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        x.emplace_back((i + 0.5) * a + offset, (j + 0.5) * a + offset, (k + 0.5) * a + offset);
        rad.push_back(r);
      }
}
}  // namespace

TEST_CASE("lens volume of two overlapping spheres matches numerical integration", "[compact][packing]") {
  // The closed form against the Simpson integral to 1e-6 relative (the integral itself is good to
  // O(h^2) ~ 1e-12, so this is loose), over
  // equal and unequal radii and shallow to deep overlaps.
  struct C {
    double ri, rj, d;
  };
  for (const C c : {C{1.0, 1.0, 1.9}, C{1.0, 1.0, 1.2}, C{1.0, 0.4, 1.2}, C{2e-6, 7e-6, 8.5e-6}, C{3.0, 1.0, 2.5}, C{1.0, 1.0, 1.999}}) {
    const double v = lens_volume(c.ri, c.rj, c.d), ref = lens_numerical(c.ri, c.rj, c.d);
    INFO("r_i = " << c.ri << ", r_j = " << c.rj << ", d = " << c.d << ": " << v << " vs " << ref);
    CHECK(test::relative_error(v, ref) <= 1e-6);
    CHECK(lens_volume(c.rj, c.ri, c.d) == Approx(v).epsilon(1e-14));  // symmetric
  }
  // Equal spheres: the lens is two caps of height r - d/2 (independent closed form), 1e-13.
  CHECK(test::relative_error(lens_volume(1.0, 1.0, 1.4), 2.0 * cap_volume(1.0, 0.3)) <= 1e-13);
  // Limits: apart -> 0; one inside the other -> the smaller sphere, continuous at d = |r_i - r_j|.
  CHECK(lens_volume(1.0, 0.5, 1.5) == 0.0);
  CHECK(lens_volume(1.0, 0.5, 2.0) == 0.0);
  CHECK(lens_volume(1.0, 0.5, 0.2) == Approx(sphere_volume(0.5)).epsilon(1e-15));
  CHECK(test::relative_error(lens_volume(1.0, 0.5, 0.5 * (1.0 + 1e-12)), sphere_volume(0.5)) <= 1e-9);
  // Lens centre: the intersection plane, a = (d^2 + r_i^2 - r_j^2) / (2d) from x_i.
  const Vec3 lc = lens_centre(Vec3(0, 0, 0), 1.0, Vec3(1.2, 0, 0), 0.4);
  CHECK(lc.x() == Approx((1.44 + 1.0 - 0.16) / 2.4).epsilon(1e-15));
}

TEST_CASE("solid volume of an overlapping simple-cubic lattice has its closed form", "[compact][packing]") {
  // n^3 spheres, spacing a = 1, radius r = 0.55 (overlap with the 6 face neighbours: lens
  // V_L = 2 cap(r - a/2); no triple overlaps for r < a / sqrt(2)).
  const int n = 6;
  const double a = 1.0, r = 0.55;
  const double VL = 2.0 * cap_volume(r, r - 0.5 * a);
  SECTION("box clear of the spheres: 1 - (n^3 V - 3 n^2 (n-1) V_L) / V_box to 1e-12") {
    std::vector<Vec3> x;
    std::vector<double> rad;
    sc_lattice(n, a, r, 0.0, x, rad);
    const BoxRegion box{Vec3::Constant(-0.2), Vec3::Constant(n * a + 0.3)};
    const double vbox = std::pow(n * a + 0.5, 3);
    const double expect = 1.0 - (n * n * n * sphere_volume(r) - 3.0 * n * n * (n - 1) * VL) / vbox;
    const auto pairs = find_pairs(x, rad, 0.0);
    CHECK(pairs.size() == static_cast<std::size_t>(3 * n * n * (n - 1)));
    const double got = 1.0 - compact_solid_volume(x, rad, pairs, box) / region_volume(box);
    INFO("porosity " << got << ", closed form " << expect);
    CHECK(std::abs(got - expect) <= 1e-12);
  }
  SECTION("box faces through the outer cell faces: the infinite lattice's 1 - (V - 3 V_L) / a^3") {
    // The boundary spheres are clipped by the faces (caps of height r - a/2 cut off: exactly the
    // half-lenses the missing outside neighbours would have shared), so the box holds n^3 unit
    // cells of the infinite lattice. Spheres cut by one face use the exact slab formula, those
    // at edges and corners quadrature (~1e-11 of a sphere, see packing_metrics.hpp): 1e-11.
    std::vector<Vec3> x;
    std::vector<double> rad;
    sc_lattice(n, a, r, 0.0, x, rad);
    const BoxRegion box{Vec3::Zero(), Vec3::Constant(n * a)};
    const double expect = 1.0 - (sphere_volume(r) - 3.0 * VL) / (a * a * a);
    const double got = 1.0 - compact_solid_volume(x, rad, find_pairs(x, rad, 0.0), box) / region_volume(box);
    INFO("porosity " << got << ", closed form " << expect);
    CHECK(std::abs(got - expect) <= 1e-11);
  }
}

TEST_CASE("compact monitor: porosity in the die between the punches at their current offsets", "[compact][packing]") {
  // Die: cylinder R0 = 5 mm about the z axis with offset u = 0.5 mm (R = 4.5 mm). Punches: bottom
  // plane z = 0 moved up by 0.2 mm, top plane z = 10 mm moved down by 1 mm: H = 8.8 mm from
  // z = 0.2 mm. Spheres (r = 1 mm): an overlapping pair A, B on the axis (d = 1.6 mm), a
  // sphere C near the die wall but inside it, and a sphere D pushed 0.3 mm into the bottom
  // punch. Closed forms (1e-12 absolute in porosity):
  //   V_s = 4 V - V_L(1, 1, 1.6 mm) - cap(h = 0.3 mm)
  //   interior (margin 2.2 mm: R = 2.3 mm, z in [2.4, 6.8] mm): only A and B, 2 V - V_L.
  State s;
  const double r = 1e-3;
  test::add_sphere(s, Vec3(0, 0, 4.0e-3), r, 5910.0);             // A
  test::add_sphere(s, Vec3(0, 0, 5.6e-3), r, 5910.0);             // B
  test::add_sphere(s, Vec3(3.4e-3, 0, 5.0e-3), r, 5910.0);        // C: 0.1 mm from the die wall
  test::add_sphere(s, Vec3(-2.0e-3, 1.0e-3, 0.9e-3), r, 5910.0);  // D: bottom punch at z = 0.2 mm
  Wall die;
  die.name = "die";
  die.shape = CylinderShape{Vec3::Zero(), Vec3::UnitZ(), 5e-3};
  die.u = 0.5e-3;
  s.walls.push_back(die);
  s.walls.push_back(test::plane_wall("bottom", Vec3::Zero(), Vec3::UnitZ()));
  s.walls.back().u = 0.2e-3;
  s.walls.push_back(test::plane_wall("top", Vec3(0, 0, 10e-3), -Vec3::UnitZ()));
  s.walls.back().u = 1e-3;
  CompactParams cp;
  cp.interior_margin = 2.2e-3;
  const CompactMonitor mon(cp);
  const auto cols = mon.columns(s);
  const auto vals = mon.values(s);
  REQUIRE(cols == std::vector<std::string>{"porosity", "porosity_interior", "relative_density", "compact_height", "porosity_mass",
                                           "envelope_radius", "porosity_envelope", "die_radius", "porosity_mass_interior",
                                           "envelope_p995_radius"});
  const double V = sphere_volume(r), VL = lens_volume(r, r, 1.6e-3);
  const double H = 8.8e-3, R = 4.5e-3;
  const double porosity = 1.0 - (4.0 * V - VL - cap_volume(r, 0.3e-3)) / (kPi * R * R * H);
  const double interior = 1.0 - (2.0 * V - VL) / (kPi * 2.3e-3 * 2.3e-3 * (H - 4.4e-3));
  CHECK(std::abs(vals[0] - porosity) <= 1e-12);
  CHECK(std::abs(vals[1] - interior) <= 1e-12);
  CHECK(std::abs(vals[2] - (1.0 - porosity)) <= 1e-15);
  CHECK(std::abs(vals[3] - H) <= 1e-18);
  // By mass: the lens is not subtracted.
  CHECK(std::abs(vals[4] - (1.0 - (4.0 * V - cap_volume(r, 0.3e-3)) / (kPi * R * R * H))) <= 1e-12);
  // Envelope columns: the profiled envelope of the spheres (envelope_volume, tested below) and
  // the solid by mass in it (no sphere clipped radially; D's cap below the bottom punch is not solid).
  const double v_env = envelope_volume(s.particles.position, s.particles.radius, compact_region(s, cp), cp.envelope_cell);
  CHECK(std::abs(vals[5] - std::sqrt(v_env / (kPi * H))) <= 1e-15);
  CHECK(std::abs(vals[6] - (1.0 - (4.0 * V - cap_volume(r, 0.3e-3)) / v_env)) <= 1e-12);
  CHECK(std::abs(vals[7] - R) <= 1e-18);
  // Interior by mass: A and B whole (the lens not subtracted).
  CHECK(std::abs(vals[8] - (1.0 - 2.0 * V / (kPi * 2.3e-3 * 2.3e-3 * (H - 4.4e-3)))) <= 1e-12);
  // 99.5th percentile of axis distance + radius, linear between order statistics (numpy's rule):
  // sorted 1, 1, 1 + sqrt(5), 4.4 mm; position 0.995 x 3 = 2.985 between the third and the fourth.
  const double third = (1.0 + std::sqrt(5.0)) * 1e-3, fourth = 4.4e-3;
  CHECK(std::abs(vals[9] - (third + 0.985 * (fourth - third))) <= 1e-15);
  // The die axis may point either way; the punches must face each other across it.
  std::get<CylinderShape>(s.walls[0].shape).axis = -Vec3::UnitZ();
  CHECK(std::abs(mon.values(s)[0] - porosity) <= 1e-12);
  cp.top = "bottom";  // both punches the same wall: refused when the monitor is built (the loader's check)
  CHECK_THROWS_AS(CompactMonitor(cp), ConfigError);
  cp.top = "die";
  CHECK_THROWS_AS(CompactMonitor(cp).values(s), SetupError);
  cp.top = "lid";
  CHECK_THROWS_AS(CompactMonitor(cp).values(s), SetupError);
}

TEST_CASE("sample envelope: caliper profile of rings, a barrel and an outlier", "[compact][packing]") {
  // Region: R = 10 mm, H = 2 mm about z from the origin; spheres r = 1 mm: one slice (n_z =
  // round(H / 2 r) = 1) and n_t = round(2 pi R / 2 r) = 31 sectors. A ring of 3 n_t spheres at
  // rho = 8 mm fills every sector with spheres reaching rho + r: V = pi (rho + r)^2 H exactly.
  const double r = 1e-3, H = 2e-3, R = 10e-3;
  const CylinderRegion region{Vec3::Zero(), Vec3::UnitZ(), R, H};
  const int nt = 31;
  auto ring = [&](double rho, double z, int count, std::vector<Vec3>& x, std::vector<double>& rad) {
    for (int k = 0; k < count; ++k) {
      const double t = 2.0 * kPi * (k + 0.37) / count;
      x.emplace_back(rho * std::cos(t), rho * std::sin(t), z);
      rad.push_back(r);
    }
  };
  std::vector<Vec3> x;
  std::vector<double> rad;
  ring(8e-3, 1e-3, 3 * nt, x, rad);
  CHECK(envelope_volume(x, rad, region, 1.0) == Approx(kPi * 9e-3 * 9e-3 * H).epsilon(1e-12));
  // One outlier 1 mm farther out in one sector moves that sector's extent by 1 mm: the slice
  // radius by 1 mm / n_t, not to the outlier.
  x.emplace_back(9e-3, 0.0, 1e-3);
  rad.push_back(r);
  CHECK(envelope_volume(x, rad, region, 1.0) == Approx(kPi * std::pow(9e-3 + 1e-3 / nt, 2) * H).epsilon(1e-12));
  // A barrel: H = 4 mm gives two slices; rings at rho = 8 mm (lower) and 6 mm (upper).
  const CylinderRegion tall{Vec3::Zero(), Vec3::UnitZ(), R, 4e-3};
  std::vector<Vec3> xb;
  std::vector<double> rb;
  ring(8e-3, 1e-3, 3 * nt, xb, rb);
  ring(6e-3, 3e-3, 3 * nt, xb, rb);
  CHECK(envelope_volume(xb, rb, tall, 1.0) == Approx(kPi * (9e-3 * 9e-3 + 7e-3 * 7e-3) * 2e-3).epsilon(1e-12));
  CHECK(envelope_volume({}, {}, tall, 1.0) == 0.0);
  // Cells of 3 diameters: n_z = 1, n_t = round(2 pi R / 6 r) = 10: the barrel is one slice whose
  // sectors each reach the outer ring, rho = 8 mm + r.
  CHECK(envelope_volume(xb, rb, tall, 3.0) == Approx(kPi * 9e-3 * 9e-3 * 4e-3).epsilon(1e-12));
}

}  // namespace test_compact
