// The heat_conduction module (issue 6) on small sphere assemblies in frozen stages.
//
// Closed forms:
//  - two spheres at different temperatures joined by G relax with dT(t) = dT0 exp(-t/tau),
//    tau = C1 C2 / (G (C1 + C2)); forward Euler gives exactly dT0 (1 - dt/tau)^n, backward Euler
//    dT0 / (1 + dt/tau)^n;
//  - a straight chain held at T0 at both ends and heated uniformly by the current through it
//    (Joule power from electrical_network): the steady temperature is the parabola
//    T(x) = T0 + q x (L - x) / (2 lambda), q = P_node / (S l), exactly at the nodes;
//  - adiabatic Joule heating of a random packing: heat stored = electrical energy in, to 1e-9;
//  - an explicit step above the stable one is refused, and with the override the blow-up stops
//    the run with the step, the particle ids and the quantity.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "engine/core/error.hpp"
#include "engine/simulation.hpp"
#include "engine/state/particle_set.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "physics/electrical/electrical_network.hpp"
#include "physics/thermal/heat_conduction.hpp"
#include "physics/thermal/thermal_kernels.hpp"
#include "tests/support/scene.hpp"
#include "tests/support/tolerance.hpp"

namespace test_heat_conduction {

using namespace sparkdem;
using namespace sparkdem::physics;

namespace {

constexpr double kRho = 7900.0, kC = 500.0, kLambda = 15.0;

HeatConduction::Params heat_params(const std::string& scheme) {
  HeatConduction::Params p;
  p.model = "transmission_surface";
  p.alpha_constant = 4.0;  // S = 4 r^2, f = 1 (cubic-lattice value)
  p.conductivity = kLambda;
  p.density = kRho;
  p.specific_heat = kC;
  p.scheme = scheme;
  return p;
}

void ids_set(State& s, const std::string& name, std::vector<Id> ids) {
  SetSelector sel;
  sel.kind = SetSelector::Kind::Ids;
  sel.ids = std::move(ids);
  assign_set(s, name, sel);
}

void set_temperatures(State& s, const std::vector<double>& T) {
  s.particles.fields.declare({"temperature", 1, "K", 0.0, true}, s.particles.size());
  s.particles.fields.data("temperature") = T;
}

}  // namespace

TEST_CASE("heat_conduction: two spheres relax exponentially with tau = C1 C2 / (G (C1 + C2))", "[thermal][heat]") {
  const double r1 = 1e-4, r2 = 0.7e-4, overlap = 1e-7;
  const double l = r1 + r2 - overlap;
  const double G = kLambda * 4.0 * r1 * r2 / l;  // lambda sqrt(S1 S2) / l, S = 4 r^2
  const double C1 = thermal::sphere_heat_capacity(kRho, kC, r1), C2 = thermal::sphere_heat_capacity(kRho, kC, r2);
  const double tau = thermal::two_body_time_constant(C1, C2, G);
  const double T1 = 400.0, T2 = 300.0;
  const double Tm = (C1 * T1 + C2 * T2) / (C1 + C2);
  for (const std::string scheme : {"explicit", "implicit"}) {
    DYNAMIC_SECTION(scheme) {
      State s;
      test::add_sphere(s, Vec3::Zero(), r1, kRho);
      test::add_sphere(s, Vec3(l, 0, 0), r2, kRho);
      set_temperatures(s, {T1, T2});
      HeatConduction heat(heat_params(scheme));
      ContactModelT<HertzMindlin> law{HertzMindlin::Params{}};
      Simulation sim(s, law);
      sim.add_module(&heat);
      const double dt = tau / 100.0;
      const Step n = 200;  // two time constants
      // The stable step of the explicit scheme is safety x min C_i / G (Gershgorin).
      test::NullObserver obs;
      if (scheme == "explicit") {
        sim.run_stage(test::frozen_stage(dt, 0), obs);  // builds the contact table of the packing
        CHECK(test::relative_error(heat.stable_dt(s), 0.9 * std::min(C1, C2) / G) <= 1e-12);
      }
      sim.run_stage(test::frozen_stage(dt, n), obs);
      const auto& T = s.particles.fields.data("temperature");
      const double dT = T[0] - T[1];
      const double discrete = scheme == "explicit" ? 100.0 * std::pow(1.0 - dt / tau, n) : 100.0 * std::pow(1.0 / (1.0 + dt / tau), n);
      const double exact = 100.0 * std::exp(-static_cast<double>(n) * dt / tau);
      INFO("dT = " << dT << ", discrete recurrence " << discrete << ", exp(-t/tau) " << exact);
      CHECK(test::relative_error(dT, discrete) <= 1e-9);
      // First-order schemes at dt = tau/100: |error| <= n (dt/tau)^2 / 2 x dT0 e^(-t/tau) x (1 + small) ~ 1 %.
      CHECK(std::abs(dT - exact) / exact <= 0.011);
      // Energy (capacity-weighted mean) is conserved to round-off.
      CHECK(test::relative_error((C1 * T[0] + C2 * T[1]) / (C1 + C2), Tm) <= 1e-13);
    }
  }
}

TEST_CASE("heat_conduction: a chain with fixed ends and uniform Joule heating reaches the parabola T0 + q x (L - x) / (2 k)",
          "[thermal][heat]") {
  const int n = 21;  // nodes 0..20, 20 intervals
  const double r = 5e-5, overlap = 1e-7, l = 2 * r - overlap;
  for (const std::string scheme : {"implicit", "explicit"}) {
    DYNAMIC_SECTION(scheme) {
      State s;
      for (int k = 0; k < n; ++k) test::add_sphere(s, Vec3(0, 0, k * l), r, kRho);
      set_temperatures(s, std::vector<double>(n, 300.0));
      ids_set(s, "ends", {0, n - 1});
      ids_set(s, "first", {0});
      ids_set(s, "last", {n - 1});
      ElectricalNetwork::Params ep;
      ep.model = "transmission_surface";
      ep.alpha_constant = 4.0;
      ep.resistivity = 0.73e-6;
      ep.conductivity = 1.0 / 0.73e-6;
      ep.high = "last";
      ep.low = "first";
      ep.voltage = 0.01;
      ElectricalNetwork el(ep);
      HeatConduction::Params hp = heat_params(scheme);
      hp.joule_heating = true;
      hp.fixed_sets = "ends";
      hp.fixed_temperatures = {300.0};
      HeatConduction heat(hp);
      ContactModelT<HertzMindlin> law{HertzMindlin::Params{}};
      Simulation sim(s, law);
      sim.add_module(&el);
      sim.add_module(&heat);
      // Diffusion time of the chain L^2 / D ~ 5 s; implicit: 40 steps of 2 s; explicit: its own
      // adaptive substeps, 200 steps of 0.25 s (then the slowest mode is down by e^-80).
      const double L = (n - 1) * l, D = kLambda / (kRho * kC);
      const bool impl = scheme == "implicit";
      test::NullObserver obs;
      sim.run_stage(test::frozen_stage(impl ? 0.5 * L * L / D : 0.05 * L * L / D, impl ? 40 : 200), obs);
      // Closed form: each interior node receives P = I^2 R_b (two half branches), R_b = rho_e l / S.
      const double S = 4.0 * r * r, Rb = 0.73e-6 * l / S, I = ep.voltage / ((n - 1) * Rb);
      const double P = I * I * Rb;
      const double G = kLambda * S / l;
      const double q = P / (S * l);  // [W/m^3]
      const auto& T = s.particles.fields.data("temperature");
      double worst = 0.0;
      for (int k = 0; k < n; ++k) {
        const double x = k * l;
        const double Tx = thermal::parabolic_rod_temperature(300.0, q, L, kLambda, x);
        CHECK(test::relative_error(Tx - 300.0 + 1.0, P * k * (n - 1 - k) / (2 * G) + 1.0) <= 1e-12);  // same closed form
        worst = std::max(worst, std::abs(T[k] - Tx) / (thermal::parabolic_rod_temperature(300.0, q, L, kLambda, L / 2) - 300.0));
      }
      INFO("largest deviation from the parabola / its peak rise: "
           << worst << " (peak rise " << thermal::parabolic_rod_temperature(300.0, q, L, kLambda, L / 2) - 300.0 << " K)");
      CHECK(worst <= 1e-9);
      // The heat generated leaves through the fixed ends: stored ~ 0 at steady state growth.
      const auto cols = heat.columns();
      const auto vals = heat.column_values(s);
      const double err = vals[std::find(cols.begin(), cols.end(), "heat_balance_error") - cols.begin()];
      CHECK(err <= 1e-9);
    }
  }
}

TEST_CASE("heat_conduction: adiabatic Joule heating of a random packing stores exactly the electrical energy", "[thermal][heat]") {
  // 400 spheres in a cube, radii 40-60 um, grown so that they overlap; current top -> bottom.
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const double L = 1.2e-3;
  for (const std::string scheme : {"explicit", "implicit"}) {
    DYNAMIC_SECTION(scheme) {
      State s;
      rng.seed(11);
      for (int k = 0; k < 400; ++k) test::add_sphere(s, Vec3(U(rng), U(rng), U(rng)) * L, 1.5 * (40e-6 + 20e-6 * U(rng)), kRho);
      set_temperatures(s, std::vector<double>(s.particles.size(), 293.15));
      SetSelector lo, hi;
      lo.kind = hi.kind = SetSelector::Kind::Box;
      lo.lo = Vec3(-1, -1, -1);
      lo.hi = Vec3(1, 1, 1.2e-4);
      hi.lo = Vec3(-1, -1, L - 1.2e-4);
      hi.hi = Vec3(1, 1, 1);
      assign_set(s, "bottom", lo);
      assign_set(s, "top", hi);
      ElectricalNetwork::Params ep;
      ep.model = "holm";
      ep.conductivity = 1.37e6;
      ep.high = "top";
      ep.low = "bottom";
      ep.voltage = 0.05;
      ElectricalNetwork el(ep);
      HeatConduction::Params hp = heat_params(scheme);
      hp.model = "batchelor_obrien";
      hp.joule_heating = true;
      HeatConduction heat(hp);
      ContactModelT<HertzMindlin> law{HertzMindlin::Params{}};
      Simulation sim(s, law);
      sim.add_module(&el);
      sim.add_module(&heat);
      test::NullObserver obs;
      sim.run_stage(test::frozen_stage(1e-3, 50), obs);
      const auto cols = heat.columns();
      const auto vals = heat.column_values(s);
      auto col = [&](const char* c) { return vals[std::find(cols.begin(), cols.end(), c) - cols.begin()]; };
      INFO("electrical energy " << col("heat_electrical_energy") << " J, stored " << col("heat_stored_energy") << " J");
      REQUIRE(col("heat_electrical_energy") > 0.0);
      CHECK(test::relative_error(col("heat_stored_energy"), col("heat_electrical_energy")) <= 1e-9);
      CHECK(test::relative_error(el.result().power * 0.05, col("heat_electrical_energy")) <= 1e-12);  // P t
      CHECK(col("heat_balance_error") <= 1e-9);
    }
  }
}

TEST_CASE("heat_conduction: an explicit step above the stable one is refused; with the override the blow-up is caught", "[thermal][heat]") {
  auto scene = [](State& s) {
    test::add_sphere(s, Vec3::Zero(), 1e-4, kRho);
    test::add_sphere(s, Vec3(2e-4 - 1e-7, 0, 0), 1e-4, kRho);
    test::add_sphere(s, Vec3(4e-4 - 2e-7, 0, 0), 1e-4, kRho);
    set_temperatures(s, {500.0, 300.0, 300.0});
  };
  State s;
  scene(s);
  HeatConduction::Params hp = heat_params("explicit");
  HeatConduction heat(hp);
  Clock one;
  one.kind = Clock::Kind::EveryStep;
  heat.set_clock(one);  // no adaptive substeps: the stage step is the module's step
  ContactModelT<HertzMindlin> law{HertzMindlin::Params{}};
  Simulation sim(s, law);
  sim.add_module(&heat);
  test::NullObserver obs;
  sim.run_stage(test::frozen_stage(1e-9, 0), obs);  // builds the contact table of the packing
  const double stable = heat.stable_dt(s);
  REQUIRE(std::isfinite(stable));
  CHECK_THROWS_AS(sim.run_stage(test::frozen_stage(3.0 * stable / 0.9, 50), obs), SetupError);
  StageConfig over = test::frozen_stage(3.0 * stable / 0.9, 400);
  over.allow_unstable_dt = true;
  try {
    sim.run_stage(over, obs);
    FAIL("the unstable run was not stopped");
  } catch (const PhysicsError& e) {
    const std::string what = e.what();
    INFO(what);
    CHECK(what.find("temperature") != std::string::npos);
    CHECK(what.find("step") != std::string::npos);
  }
  // At the stable step the same scene stays within its initial bounds (monotone scheme).
  State s2;
  scene(s2);
  HeatConduction heat2(hp);
  heat2.set_clock(one);
  Simulation sim2(s2, law);
  sim2.add_module(&heat2);
  sim2.run_stage(test::frozen_stage(stable, 400), obs);
  for (double T : s2.particles.fields.data("temperature")) {
    CHECK(T >= 300.0 - 1e-9);
    CHECK(T <= 500.0 + 1e-9);
  }
}

TEST_CASE("heat_conduction: report_sets gives the capacity-weighted mean temperature of each set", "[thermal][heat]") {
  // Invariants: the column equals sum_{i in set} C_i T_i / sum C_i computed from the fields (to
  // round-off); a set and its complement recombine to heat_temperature_mean; an empty set is NaN;
  // a set that is not in the stage is refused at bind.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const double L = 1.2e-3;
  State s;
  for (int k = 0; k < 300; ++k) test::add_sphere(s, Vec3(U(rng), U(rng), U(rng)) * L, 1.5 * (40e-6 + 20e-6 * U(rng)), kRho);
  std::vector<double> T0(s.particles.size());
  for (std::size_t i = 0; i < T0.size(); ++i) T0[i] = 293.15 + 100.0 * s.particles.position[i].z() / L;  // a gradient
  set_temperatures(s, T0);
  SetSelector lower, upper, none;
  lower.kind = upper.kind = none.kind = SetSelector::Kind::Box;
  lower.lo = Vec3(-1, -1, -1);
  lower.hi = Vec3(1, 1, 0.5 * L);
  upper.lo = Vec3(-1, -1, 0.5 * L);
  upper.hi = Vec3(1, 1, 1);
  none.lo = Vec3(5, 5, 5);
  none.hi = Vec3(6, 6, 6);
  assign_set(s, "lower", lower);
  assign_set(s, "upper", upper);
  assign_set(s, "nothing", none);
  HeatConduction::Params hp = heat_params("explicit");
  hp.capacity = "volume_fraction";  // unequal capacities: the weighting matters
  hp.report_sets = "lower, upper,nothing";
  HeatConduction heat(hp);
  ContactModelT<HertzMindlin> law{HertzMindlin::Params{}};
  Simulation sim(s, law);
  sim.add_module(&heat);
  test::NullObserver obs;
  sim.run_stage(test::frozen_stage(1e-4, 5), obs);
  const auto cols = heat.columns();
  const auto vals = heat.column_values(s);
  REQUIRE(cols.size() == vals.size());
  auto col = [&](const std::string& c) {
    const auto it = std::find(cols.begin(), cols.end(), c);
    REQUIRE(it != cols.end());
    return vals[it - cols.begin()];
  };
  const auto& T = s.particles.fields.data("temperature");
  const auto& C = s.particles.fields.data("heat_capacity");
  const auto& in_lower = s.particles.fields.data("set/lower");
  double cl = 0.0, ctl = 0.0, cu = 0.0, ctu = 0.0;
  std::size_t nl = 0;
  for (std::size_t i = 0; i < T.size(); ++i) {
    if (in_lower[i] > 0.5) {
      cl += C[i];
      ctl += C[i] * T[i];
      ++nl;
    } else {
      cu += C[i];
      ctu += C[i] * T[i];
    }
  }
  REQUIRE(nl > 50);
  REQUIRE(nl < T.size() - 50);
  const double ml = col("heat_temperature_mean_lower"), mu = col("heat_temperature_mean_upper");
  INFO("lower " << ml << " K, upper " << mu << " K, all " << col("heat_temperature_mean") << " K");
  CHECK(test::relative_error(ml, ctl / cl) <= 1e-13);
  CHECK(test::relative_error(mu, ctu / cu) <= 1e-13);
  CHECK(mu - ml > 20.0);  // the gradient is still there after 5 steps (conduction time ~ L^2/D ~ 0.4 s)
  CHECK(test::relative_error((cl * ml + cu * mu) / (cl + cu), col("heat_temperature_mean")) <= 1e-13);
  CHECK(std::isnan(col("heat_temperature_mean_nothing")));

  HeatConduction::Params bad = hp;
  bad.report_sets = "lower,missing";
  HeatConduction heat_bad(bad);
  State s2 = s;
  ContactModelT<HertzMindlin> law2{HertzMindlin::Params{}};
  Simulation sim2(s2, law2);
  sim2.add_module(&heat_bad);
  CHECK_THROWS_WITH(sim2.run_stage(test::frozen_stage(1e-4, 1), obs), Catch::Contains("'missing' is not a particle set"));
  hp.report_sets = "lower,lower";
  CHECK_THROWS_WITH(HeatConduction(hp), Catch::Contains("listed twice"));
}

}  // namespace test_heat_conduction
