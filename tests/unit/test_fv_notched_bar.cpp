/// The finite-volume reference of the notched rod (tests/support/fv_notched_bar.hpp; physics note
/// §7.4): closed forms of the plain bar, conservation, symmetry, variational bounds on R_eq of
/// the notched bar and grid convergence.
#include <catch2/catch.hpp>

#include <cmath>

#include "support/fv_notched_bar.hpp"

namespace test_fv_notched_bar {

using namespace sparkdem;

namespace {
fv::NotchedBar plain() {
  fv::NotchedBar g;
  g.notched = false;
  return g;
}
/// Planes at positions no grid line passes through (the DEM's measured electrode heights).
fv::Loading loading() {
  fv::Loading ld;
  ld.z_lo = 61.3e-6;
  ld.z_hi = 6.9371e-3;
  return ld;
}
fv::Numerics grid(double h, int steps) {
  fv::Numerics n;
  n.h = h;
  n.steps = steps;
  return n;
}
}  // namespace

TEST_CASE("fv plain bar: R, Joule power and the uniform rise match the closed forms", "[fv][unit]") {
  // R = rho_e (z_hi - z_lo) / (lx depth) exactly: the discrete potential of the plain bar is the
  // exact linear one, whatever the plane positions (tolerance 1e-10 relative, round-off).
  // Energy: Joule power = V I and heat stored = V I t_end (1e-9 relative).
  // Far from the ends (the notch slab at 3.5 mm, 3.4 mm from the planes, >> sqrt(D t) = 0.2 mm)
  // the rise is the uniform dT = V^2 t / (R rho c V_heated), V_heated = lx depth (z_hi - z_lo)
  // (1e-9 relative: the unheated ends cannot reach it).
  const fv::NotchedBar g = plain();
  const fv::Material m;
  const fv::Loading ld = loading();
  const fv::Result r = fv::solve(g, m, ld, grid(25e-6, 20));
  const double R = m.resistivity * (ld.z_hi - ld.z_lo) / (g.lx * g.depth);
  CHECK(r.resistance == Approx(R).epsilon(1e-10));
  CHECK(r.current_high == Approx(r.current).epsilon(1e-10));
  CHECK(r.power_joule == Approx(ld.voltage * r.current).epsilon(1e-9));
  CHECK(r.heat_stored == Approx(r.power_vi * ld.t_end).epsilon(1e-9));
  const double v_heated = g.lx * g.depth * (ld.z_hi - ld.z_lo);
  const double dT = ld.voltage * ld.voltage * ld.t_end / (R * m.density * m.heat_capacity * v_heated);
  CHECK(r.T_slab_mean - ld.T0 == Approx(dT).epsilon(1e-9));
  CHECK(r.T_notch_centre - ld.T0 == Approx(dT).epsilon(1e-9));
  // The whole bar (unheated ends included) holds the same energy at a lower mean temperature.
  CHECK(r.T_mean - ld.T0 == Approx(dT * v_heated / (g.lx * g.depth * g.lz)).epsilon(1e-9));
}

TEST_CASE("fv plain bar: the unheated end follows the 1-D image solution", "[fv][unit]") {
  // The end piece z < z_lo carries no current but conducts and stores heat; at the adiabatic
  // face z = 0 the continuum rise is dT(0, t) = (q t / rho c) 4 i2erfc(a / (2 sqrt(D t))),
  // a = z_lo. The end cells' mean over [0, h] is compared (h = 5 um, a = 61.3 um, sqrt(D t) =
  // 195 um): 1 % (cell averaging O(h^2 T'') and the plane splitting a cell).
  const fv::NotchedBar g = plain();
  const fv::Material m;
  const fv::Loading ld = loading();
  fv::Numerics n = grid(5e-6, 40);
  n.keep_fields = true;
  const fv::Result r = fv::solve(g, m, ld, n);
  const double D = m.conductivity / (m.density * m.heat_capacity);
  const double uniform = r.T_slab_mean - ld.T0;  // q t / (rho c)
  const double face = uniform * 4.0 * fv::i2erfc(ld.z_lo / (2.0 * std::sqrt(D * ld.t_end)));
  CHECK(face / uniform == Approx(0.5).margin(0.2));  // the end is well inside the diffusion length
  CHECK(r.T[0] - ld.T0 == Approx(face).epsilon(0.01));
  CHECK(r.T[static_cast<std::size_t>(r.nx) * (r.nz - 1)] - ld.T0 ==
        Approx(uniform * 4.0 * fv::i2erfc((g.lz - ld.z_hi) / (2.0 * std::sqrt(D * ld.t_end)))).epsilon(0.01));
}

TEST_CASE("fv notched bar: conservation, mirror symmetry and the variational bounds of R_eq", "[fv][unit]") {
  // Conservation (1e-9): I(z_lo) = I(z_hi), Joule power = V I, heat stored = V I t_end.
  // Mirror symmetry (1e-9): the half solve x <= lx/2 equals the full-width solve.
  // Bounds: the z-only trial potential (Dirichlet principle) gives R >= R_series = rho_e
  // [(L - w) / A + w / A_lig] (w = slot width, A_lig = ligament section); the admissible flow
  // confined to a straight strip of the ligament width (Thomson's principle) gives
  // R <= rho_e L / A_lig; L = z_hi - z_lo.
  const fv::NotchedBar g;
  const fv::Material m;
  const fv::Loading ld = loading();
  fv::Numerics n = grid(25e-6, 20);
  const fv::Result half = fv::solve(g, m, ld, n);
  n.use_x_symmetry = false;
  const fv::Result full = fv::solve(g, m, ld, n);
  CHECK(half.current_high == Approx(half.current).epsilon(1e-9));
  CHECK(half.power_joule == Approx(half.power_vi).epsilon(1e-9));
  CHECK(half.heat_stored == Approx(half.power_vi * ld.t_end).epsilon(1e-9));
  CHECK(full.heat_stored == Approx(full.power_vi * ld.t_end).epsilon(1e-9));
  CHECK(half.resistance == Approx(full.resistance).epsilon(1e-9));
  CHECK(half.T_slab_mean == Approx(full.T_slab_mean).epsilon(1e-9));
  CHECK(half.T_max == Approx(full.T_max).epsilon(1e-9));
  CHECK(half.T_notch_centre == Approx(full.T_notch_centre).epsilon(1e-9));
  CHECK(half.solid_volume == Approx(g.solid_volume()).epsilon(1e-12));
  CHECK(g.solid_volume() == Approx(6.775e-9).epsilon(1e-12));
  const double L = ld.z_hi - ld.z_lo, w = g.notch_z_hi - g.notch_z_lo;
  const double A = g.lx * g.depth, A_lig = (g.lx - 2.0 * g.notch_depth) * g.depth;
  CHECK(A_lig == Approx(0.55e-6).epsilon(1e-12));
  const double R_series = m.resistivity * ((L - w) / A + w / A_lig);
  CHECK(half.resistance > R_series);
  CHECK(half.resistance < m.resistivity * L / A_lig);
  // The slab is 4 x 59 um thick at the ligament: its solid volume is 0.236 mm x 0.55 mm^2.
  CHECK(half.slab_volume == Approx(2.0 * ld.slab_half_width * A_lig).epsilon(1e-9));
  // The ligament is hotter than the far field and the corners are the hottest.
  CHECK(half.T_slab_mean > ld.T0 + 1.5 * (half.T_mean - ld.T0));
  CHECK(half.T_max > half.T_notch_centre);
}

TEST_CASE("fv notched bar: R_eq converges under grid refinement (Richardson)", "[fv][unit]") {
  // Three grids h = 25, 12.5, 6.25 um: R decreases monotonically with an observed order between
  // 1 and 2 (the re-entrant slot corners, phi ~ r^(2/3), give 4/3 asymptotically), and the
  // extrapolated value is within 0.1 % of the finest.
  const fv::NotchedBar g;
  const fv::Material m;
  const fv::Loading ld = loading();
  double R[3];
  for (int k = 0; k < 3; ++k) R[k] = fv::solve(g, m, ld, grid(25e-6 / (1 << k), 2)).resistance;
  CHECK(R[0] > R[1]);
  CHECK(R[1] > R[2]);
  const fv::Richardson rr = fv::richardson(R[0], R[1], R[2]);
  CHECK(rr.observed_order > 1.0);
  CHECK(rr.observed_order < 2.0);
  CHECK(rr.extrapolated == Approx(R[2]).epsilon(1e-3));
  // richardson() itself on f = 1 + h^1.5 (exact order and limit).
  const fv::Richardson s = fv::richardson(1.0 + std::pow(0.4, 1.5), 1.0 + std::pow(0.2, 1.5), 1.0 + std::pow(0.1, 1.5));
  CHECK(s.observed_order == Approx(1.5).epsilon(1e-12));
  CHECK(s.extrapolated == Approx(1.0).epsilon(1e-12));
}

TEST_CASE("fv notched bar: a grid that does not resolve the slots is rejected", "[fv][unit]") {
  const fv::NotchedBar g;
  CHECK_THROWS_AS(fv::solve(g, fv::Material{}, loading(), grid(30e-6, 10)), std::invalid_argument);
  fv::Loading bad = loading();
  bad.z_hi = bad.z_lo;
  CHECK_THROWS_AS(fv::solve(g, fv::Material{}, bad, grid(25e-6, 10)), std::invalid_argument);
}

}  // namespace test_fv_notched_bar
