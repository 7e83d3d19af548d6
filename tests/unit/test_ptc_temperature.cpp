// ptc_temperature: the matrix eigenstrain eps0(T) of a semicrystalline host (linear expansion,
// smoothed melting step with a strain jump and a change of expansion coefficient) and its inverse.
//
// Closed forms (physics/electrical/ptc_temperature.hpp):
//  (a) no melting step: eps0 = alpha_s (T - T_ref), T(eps) = T_ref + eps / alpha_s;
//  (b) sharp step: eps0 = alpha_s (T - T_ref) for T <= T_m and
//      alpha_s (T_m - T_ref) + Delta_m + alpha_l (T - T_m) above; every strain inside the jump
//      maps back to T_m;
//  (c) smoothed step of width w: identical to (b) outside [T_m - w/2, T_m + w/2]; at T_m,
//      S = 1/2 and I = 3 w / 32, so eps0(T_m) = alpha_s (T_m - T_ref) + (alpha_l - alpha_s) 3 w / 32
//      + Delta_m / 2; d eps0 / dT = alpha_s + (alpha_l - alpha_s) S + Delta_m 6 x (1 - x) / w;
//  (d) the inverse round-trips to 1e-9 K everywhere.
// Tolerances: closed forms to 1e-14 relative (a few roundings); the derivative by a central
// difference with step 1e-3 K: O(h^2 S''') ~ 1e-8 relative, 1e-6 used. Run time: < 1 ms.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <vector>

#include "engine/core/error.hpp"
#include "physics/electrical/ptc_local_strain.hpp"
#include "physics/electrical/ptc_temperature.hpp"
#include "tests/support/tolerance.hpp"

namespace test_ptc_temperature {

using namespace sparkdem;
using namespace sparkdem::physics;

TEST_CASE("ptc_temperature: linear expansion without melting", "[ptc][cpc]") {
  ptc::ThermalStrainLaw l;
  l.alpha_solid = 1.9e-4;
  l.alpha_melt = 5e-4;  // unused without a melting step
  l.reference_temperature = 293.15;
  for (double T : {200.0, 293.15, 350.0, 500.0}) {
    CHECK(ptc::thermal_strain(l, T) == Approx(1.9e-4 * (T - 293.15)).margin(1e-16));
    CHECK(ptc::melting_fraction(l, T) == 0.0);
  }
  CHECK(ptc::temperature_at_strain(l, 0.023) == Approx(293.15 + 0.023 / 1.9e-4).epsilon(1e-14));
  CHECK(ptc::temperature_at_strain(l, -0.01) == Approx(293.15 - 0.01 / 1.9e-4).epsilon(1e-14));
}

TEST_CASE("ptc_temperature: sharp melting jump", "[ptc][cpc]") {
  ptc::ThermalStrainLaw l;
  l.alpha_solid = 2e-4;
  l.alpha_melt = 3e-4;
  l.reference_temperature = 300.0;
  l.melting_temperature = 400.0;
  l.melting_strain = 0.03;
  l.melting_width = 0.0;
  ptc::validate(l);
  CHECK(test::relative_error(ptc::thermal_strain(l, 350.0), 2e-4 * 50.0) < 1e-13);
  CHECK(test::relative_error(ptc::thermal_strain(l, 400.0), 2e-4 * 100.0) < 1e-13);  // S(T_m) = 0
  CHECK(test::relative_error(ptc::thermal_strain(l, 420.0), 0.02 + 0.03 + 3e-4 * 20.0) < 1e-13);
  // inverse: below, inside and above the jump
  CHECK(test::relative_error(ptc::temperature_at_strain(l, 0.01), 350.0) < 1e-13);
  CHECK(ptc::temperature_at_strain(l, 0.02) == Approx(400.0).epsilon(1e-14));
  CHECK(ptc::temperature_at_strain(l, 0.023) == 400.0);
  CHECK(ptc::temperature_at_strain(l, 0.05) == 400.0);
  CHECK(test::relative_error(ptc::temperature_at_strain(l, 0.056), 420.0) < 1e-13);
}

TEST_CASE("ptc_temperature: smoothed melting step", "[ptc][cpc]") {
  ptc::ThermalStrainLaw sharp;
  sharp.alpha_solid = 1.9e-4;
  sharp.alpha_melt = 2.5e-4;
  sharp.reference_temperature = 293.15;
  sharp.melting_temperature = 403.15;
  sharp.melting_strain = 0.03;
  ptc::ThermalStrainLaw l = sharp;
  l.melting_width = 10.0;
  ptc::validate(l);
  SECTION("equals the sharp law outside the step") {
    for (double T : {250.0, 293.15, 350.0, 398.15, 408.15, 450.0})
      CHECK(test::relative_error(ptc::thermal_strain(l, T), ptc::thermal_strain(sharp, T)) < 1e-12);
  }
  SECTION("value and slope at the melting point") {
    const double e = 1.9e-4 * 110.0 + (2.5e-4 - 1.9e-4) * 3.0 * 10.0 / 32.0 + 0.015;
    CHECK(test::relative_error(ptc::thermal_strain(l, 403.15), e) < 1e-13);
    CHECK(ptc::melting_fraction(l, 403.15) == Approx(0.5).epsilon(1e-14));
    for (double T : {399.0, 403.15, 406.0}) {
      const double x = (T - 403.15) / 10.0 + 0.5;
      const double S = x * x * (3.0 - 2.0 * x);
      const double slope = 1.9e-4 + (2.5e-4 - 1.9e-4) * S + 0.03 * 6.0 * x * (1.0 - x) / 10.0;
      const double h = 1e-3;
      const double fd = (ptc::thermal_strain(l, T + h) - ptc::thermal_strain(l, T - h)) / (2.0 * h);
      CHECK(test::relative_error(fd, slope) < 1e-6);
    }
  }
  SECTION("the inverse round-trips") {
    for (double T = 250.0; T <= 460.0; T += 0.37) CHECK(std::abs(ptc::temperature_at_strain(l, ptc::thermal_strain(l, T)) - T) < 1e-9);
    for (double T = 250.0; T <= 460.0; T += 0.37)
      if (std::abs(T - 403.15) > 1e-9) CHECK(std::abs(ptc::temperature_at_strain(sharp, ptc::thermal_strain(sharp, T)) - T) < 1e-9);
  }
  SECTION("reference temperature above the melt: negative strains below") {
    ptc::ThermalStrainLaw hot = l;
    hot.reference_temperature = 420.0;
    CHECK(test::relative_error(ptc::thermal_strain(hot, 300.0), ptc::thermal_strain(l, 300.0) - ptc::thermal_strain(l, 420.0)) < 1e-12);
    CHECK(ptc::thermal_strain(hot, 300.0) < -0.03);
    CHECK(std::abs(ptc::temperature_at_strain(hot, ptc::thermal_strain(hot, 401.0)) - 401.0) < 1e-9);
  }
}

TEST_CASE("ptc_temperature: invalid laws are rejected", "[ptc][cpc]") {
  ptc::ThermalStrainLaw l;
  l.alpha_solid = 0.0;
  CHECK_THROWS_AS(ptc::validate(l), SetupError);
  l.alpha_solid = 1e-4;
  l.melting_strain = -0.01;
  CHECK_THROWS_AS(ptc::validate(l), SetupError);
  l.melting_strain = 0.0;
  l.melting_width = -1.0;
  CHECK_THROWS_AS(ptc::validate(l), SetupError);
}

// ptc_local_strain: the same matrix under one eps0 per spring, factorised once.
//  (a) uniform eps0: displacements and openings are eps0 times ptc::solve_unit's (same matrix,
//      right-hand side scaled): 1e-10 relative (the two solves differ only by rounding);
//  (b) superposition of the openings: solve(e1) + solve(e2) = solve(e1 + e2) (linearity, 1e-9 of
//      the largest opening);
//  (c) a free 1-D chain 0 -(h1)- 1 =touching= 2 -(h3)- 3 with per-spring strains e1, e3: it
//      expands freely (statically determinate, no stress): spring openings e1 h1 and e3 h3, the
//      contact opening 0 (1e-8 relative: ground-spring regularisation 1e-12).
TEST_CASE("ptc_local_strain: per-spring eigenstrains with one factorisation", "[ptc][cpc]") {
  SECTION("uniform strain equals the unit solve scaled; superposition") {
    const double R = 1.0;
    std::vector<Vec3> x;
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> U(-0.15, 0.15);
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        for (int k = 0; k < 3; ++k) x.emplace_back(2.3 * i + U(rng), 2.3 * j + U(rng), 2.3 * k + U(rng));
    const std::vector<double> r(x.size(), R);
    ptc::MatrixParams p;
    p.min_gap_rel = 0.05;  // h_min = 0.1 R
    p.cutoff_gap_rel = 0.5;  // h_max = 1 R
    p.regularisation = 1e-9;
    const ptc::SpringNetwork net = ptc::build_network(x, r, p);
    REQUIRE(net.size() > x.size());
    const ptc::UnitSolution unit = ptc::solve_unit(x.size(), net, p);
    ptc::LocalStrainSolver ls;
    ls.factorize(x.size(), net, p);
    std::vector<Vec3> u;
    std::vector<double> open;
    ls.solve(std::vector<double>(net.size(), 0.02), u, open);
    double scale = 0.0;
    for (double d : unit.opening) scale = std::max(scale, std::abs(d));
    for (std::size_t e = 0; e < net.size(); ++e) CHECK(std::abs(open[e] - 0.02 * unit.opening[e]) < 1e-10 * 0.02 * scale);
    std::vector<double> e1(net.size()), e2(net.size()), e12(net.size());
    for (std::size_t e = 0; e < net.size(); ++e) {
      e1[e] = 0.01 * U(rng);
      e2[e] = 0.02 * U(rng);
      e12[e] = e1[e] + e2[e];
    }
    std::vector<Vec3> u1, u2, u12;
    std::vector<double> o1, o2, o12;
    ls.solve(e1, u1, o1);
    ls.solve(e2, u2, o2);
    ls.solve(e12, u12, o12);
    // Openings (B u): the displacements themselves carry floppy-mode components fixed only by
    // the 1e-9 ground springs (condition ~1e9), which the openings do not see.
    double err = 0.0, norm = 0.0;
    for (std::size_t e = 0; e < net.size(); ++e) {
      err = std::max(err, std::abs(o1[e] + o2[e] - o12[e]));
      norm = std::max(norm, std::abs(o12[e]));
    }
    INFO("superposition error " << err << " of max opening " << norm);
    CHECK(norm > 0.0);
    CHECK(err < 1e-9 * norm);
    CHECK_THROWS_AS(ls.solve(std::vector<double>(3, 0.0), u, open), SetupError);
  }
  SECTION("free chain with two strains") {
    const double R = 1.0, h1 = 0.3, h3 = 0.5;
    const std::vector<Vec3> x = {Vec3(0, 0, 0), Vec3(2 * R + h1, 0, 0), Vec3(4 * R + h1, 0, 0), Vec3(6 * R + h1 + h3, 0, 0)};
    ptc::MatrixParams p;
    p.min_gap_rel = 0.005;  // h_min = 0.01 R
    p.cutoff_gap_rel = 0.5;
    p.regularisation = 1e-12;
    const ptc::SpringNetwork net = ptc::build_network(x, std::vector<double>(4, R), p);
    REQUIRE(net.size() == 3);
    ptc::LocalStrainSolver ls;
    ls.factorize(4, net, p);
    std::vector<Vec3> u;
    std::vector<double> open;
    ls.solve(std::vector<double>{0.01, 0.5, 0.03}, u, open);  // the contact's strain has no polymer to act on
    CHECK(test::relative_error(open[0], 0.01 * h1) < 1e-8);
    CHECK(std::abs(open[1]) < 1e-8 * h1);
    CHECK(test::relative_error(open[2], 0.03 * h3) < 1e-8);
  }
}

}  // namespace test_ptc_temperature
