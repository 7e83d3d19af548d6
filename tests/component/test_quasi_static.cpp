// The inertia-free path (engine/integrate/quasi_static.hpp, StageConfig::quasi_static):
//  - two free spheres sintering follow the closed-form neck growth dh/dt = F_s / eta;
//  - every particle of a sintering cluster ends each step with zero net force (the balance the
//    solve imposes, measured on the law's own forces), and the kinetic energy is only that of the
//    creep rates;
//  - a force-controlled punch on a column of cold spheres: every contact carries the load, at
//    the Hertz overlap of the closed form, and the punch's wall force equals p A;
//  - a neck's rolling and twisting resistance turns two particles at torque / resistance;
//  - Coulomb sliding against a viscous drag reaches its closed form for every slip_relaxation;
//  - what the path cannot take is refused before step 0.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <random>

#include "engine/contact/contact_model.hpp"
#include "engine/integrate/quasi_static.hpp"
#include "engine/simulation.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "physics/contact/sintering.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/register_all.hpp"
#include "support/free_pair.hpp"
#include "support/scratch.hpp"
#include "support/scene.hpp"

namespace test_quasi_static {

using namespace sparkdem;
using physics::Sintering;

namespace {

using test::free_pair::kR;
using test::free_pair::kRho;
using test::free_pair::rk4;
Sintering::Params hot_params() { return test::free_pair::law_params(); }

StageConfig qs_stage(double dt, Step steps) {
  StageConfig c = test::stage(dt, steps, 0.2 * kR);
  c.quasi_static = true;
  return c;
}

}  // namespace

namespace {
/// Two free spheres sintering through a quasi-static stage of 100 steps of 1e-4 s at the given
/// max_strain_increment; returns the worst relative error of the growth h(t) - h(1 ms) against RK4
/// of the closed form from the state at 1 ms, and the stage result.
double free_pair_error(double max_strain_increment, StageResult& res, Vec3& mid) {
  State s;
  test::free_pair::add_pair(s);
  const double h0 = test::free_pair::kH0;
  const ContactModelT<Sintering> law(hot_params());
  Simulation sim(s, law);
  const double dt = 1e-4;
  std::vector<std::pair<double, double>> run;  // (t, h)
  test::StepObserver obs([&](const State& st, Step n) {
    run.emplace_back(static_cast<double>(n) * dt, 2 * kR - (st.particles.position[0] - st.particles.position[1]).norm());
  });
  StageConfig cfg = qs_stage(dt, 100);
  cfg.quasi.max_strain_increment = max_strain_increment;
  res = sim.run_stage(cfg, obs);
  REQUIRE(run.size() == 100);
  CHECK(run.back().second > 10.0 * h0);
  const auto [t0, hs0] = run[9];  // t = 1 ms
  double worst = 0.0;
  for (std::size_t k = 10; k < run.size(); ++k)
    worst = std::max(worst, std::abs((run[k].second - hs0) / (rk4(hs0, t0, run[k].first, 2000) - hs0) - 1.0));
  mid = 0.5 * (s.particles.position[0] + s.particles.position[1]);
  return worst;
}
}  // namespace

TEST_CASE("Quasi-static sintering pair: neck growth follows the closed form, to first order in the increment", "[quasi_static]") {
  // 10 ms of free sintering (h from 0.002 r to ~0.07 r) in steps of 1e-4 s, no mass (the explicit
  // test of test_sintering_law.cpp needs 4e4 steps of 2.5e-7 s at time scale 1250), the substeps
  // set by the flow limit. The step is first order (each substep's dashpot is that of its start,
  // eta ~ a^4): against RK4 of dh/dt = F_s / eta from the state at 1 ms, the growth error falls
  // with the limit (measured 3.1 % at 2e-3 in 120 substeps, 0.17 % at 5e-5 in 1747).
  StageResult coarse, fine;
  Vec3 mid_c, mid_f;
  const double e_coarse = free_pair_error(2e-3, coarse, mid_c), e_fine = free_pair_error(5e-5, fine, mid_f);
  WARN("quasi-static pair: worst growth error " << e_coarse << " (" << coarse.quasi_static.substeps << " substeps) at a limit of 2e-3, "
                                                << e_fine << " (" << fine.quasi_static.substeps << ") at 5e-5");
  CHECK(e_fine < 0.002);
  CHECK(e_coarse / e_fine > 10.0);  // first order: 40x the limit, > 10x the error
  CHECK(coarse.quasi_static.max_strain_increment <= 2e-3);
  CHECK(fine.quasi_static.max_strain_increment <= 5e-5);
  // No rigid drift: the free modes (the translation of the pair) stay at rest, to the solve's rounding.
  INFO("pair centre moved by " << mid_c.norm() << " m");
  CHECK(mid_c.norm() < 1e-12);  // measured 2e-13 m against an approach of 7e-8 m
}

TEST_CASE("Quasi-static sintering cluster: every particle ends each step in balance", "[quasi_static]") {
  // 27 overlapping spheres sintering free at 1500 K: after every step the net force
  // on each particle, summed from the law's own pair pass, is below 1e-8 of the mean contact force
  // (what is left is the law's numerical dashpots on the creep rates); the forces sum to zero
  // (action = reaction) and the kinetic energy is that of the creep rates, below 1e-20 J.
  // A 3 x 3 x 3 cube of spheres of radii 1-1.3 um, 1.9 um apart, each moved by up to 0.03 um.
  State s;
  test::free_pair::add_cluster27(s, 1.9, 1.15, 0.15);
  const ContactModelT<Sintering> law(hot_params());
  Simulation sim(s, law);
  double worst = 0.0, ke = 0.0;
  Vec3 total = Vec3::Zero();
  test::StepObserver obs([&](const State& st, Step) {
    const auto& p = st.particles;
    double fmax = 0.0, sum = 0.0, rows = 0.0;
    Vec3 t = Vec3::Zero();
    for (std::size_t i = 0; i < p.size(); ++i) {
      fmax = std::max(fmax, p.force[i].norm());
      t += p.force[i];
      ke = std::max(ke, 0.5 * p.mass[i] * p.velocity[i].squaredNorm());
    }
    for (std::size_t q = 0; q < st.contacts.size(); ++q)
      if (st.contacts.force()[q].norm() > 0.0) {
        sum += st.contacts.force()[q].norm();
        rows += 1.0;
      }
    REQUIRE(rows >= 54.0);
    worst = std::max(worst, fmax / (sum / rows));
    total = t;
  });
  const StageResult res = sim.run_stage(qs_stage(1e-4, 20), obs);
  WARN("cluster: worst net force / mean contact force " << worst << ", largest particle kinetic energy " << ke << " J");
  CHECK(worst < 1e-8);
  CHECK(total.norm() < 1e-12 * worst + 1e-18);
  CHECK(ke < 1e-20);
  CHECK(res.quasi_static.max_residual == Approx(worst).epsilon(1e-9));
}

TEST_CASE("Quasi-static substeps: the mean flow of the contacts (densification increment) is bounded when asked", "[quasi_static]") {
  // The free pair of the first test, 30 steps of 1e-4 s: with max_mean_strain_increment the
  // substeps keep every accepted substep's mean flow / r_min below it (one contact: mean = max),
  // with more substeps than the per-contact limit alone asks for when that one is looser.
  auto run = [](double max_c, double mean_c) {
    State s;
    test::free_pair::add_pair(s);
    const ContactModelT<Sintering> law(hot_params());
    Simulation sim(s, law);
    StageConfig cfg = qs_stage(1e-4, 30);
    cfg.quasi.max_strain_increment = max_c;
    cfg.quasi.max_mean_strain_increment = mean_c;
    test::NullObserver obs;
    return sim.run_stage(cfg, obs).quasi_static;
  };
  const auto loose = run(1e-2, 0.0), bounded = run(1e-2, 5e-4);
  CHECK(bounded.max_mean_strain_increment <= 5e-4);
  CHECK(loose.max_mean_strain_increment > 5e-4);
  CHECK(bounded.substeps > loose.substeps);
}

TEST_CASE("Quasi-static punch: a force-controlled wall presses a column at the closed-form Hertz overlaps", "[quasi_static]") {
  // Three equal cold spheres stacked on a fixed plane under a pressure-controlled punch (load L =
  // p A): every contact carries L, so each pair overlaps by d_p = (L / (4/3 E* sqrt(r/2)))^(2/3) and
  // each wall contact by d_w = (L / (4/3 E* sqrt(r)))^(2/3); the punch's wall force equals L.
  auto p = hot_params();
  p.temperature = 300.0;  // cold: Hertz contacts, no necks
  p.youngs_modulus = 1e9;
  p.friction = p.wall_friction = 0.0;
  const double e_star = p.youngs_modulus / (2.0 * (1.0 - p.poisson_ratio * p.poisson_ratio));
  State s;
  for (int k = 0; k < 3; ++k) test::add_sphere(s, Vec3(0, 0, kR + 2.0 * kR * k - 1e-3 * kR * k), kR, kRho);
  s.walls.push_back(test::plane_wall("bottom", Vec3(0, 0, 1e-4 * kR), Vec3::UnitZ()));
  Wall top = test::plane_wall("top", Vec3(0, 0, 6.0 * kR - 3e-3 * kR), -Vec3::UnitZ());
  s.walls.push_back(top);
  const double area = 1e-12, pressure = 1e6, load = pressure * area;
  StageConfig cfg = qs_stage(1.0, 20);
  WallMotion m;
  m.kind = WallMotion::Kind::Pressure;
  m.pressure_time = {0.0};
  m.pressure_value = {pressure};
  m.area = area;
  cfg.motions["top"] = m;
  cfg.quasi.max_approach_increment = 1.0;  // the first step loads the column from touching: one elastic jump
  const ContactModelT<Sintering> law(p);
  Simulation sim(s, law);
  test::NullObserver obs;
  sim.run_stage(cfg, obs);
  const double dp = std::pow(load / (4.0 / 3.0 * e_star * std::sqrt(0.5 * kR)), 2.0 / 3.0);
  const double dw = std::pow(load / (4.0 / 3.0 * e_star * std::sqrt(kR)), 2.0 / 3.0);
  const auto& x = s.particles.position;
  INFO("pair overlaps " << 2.0 * kR - (x[1] - x[0]).norm() << ", " << 2.0 * kR - (x[2] - x[1]).norm() << " m, closed form " << dp
                        << " m; wall forces " << s.walls[0].normal_force << ", " << s.walls[1].normal_force << " N, load " << load << " N");
  for (int k = 0; k < 2; ++k) CHECK(2.0 * kR - (x[k + 1] - x[k]).norm() == Approx(dp).epsilon(1e-6));
  CHECK(kR - (x[0].z() - 1e-4 * kR) == Approx(dw).epsilon(1e-6));
  CHECK(s.walls[1].normal_force == Approx(load).epsilon(1e-6));
  CHECK(s.walls[0].normal_force == Approx(load).epsilon(1e-6));
}

namespace {
/// One particle between a frictional floor (Coulomb cap mu N, stiff stick viscosity) and a ceiling
/// that drags it sideways with F_t = F - c_t v_x, both pressing with N; arms zero (no spin). The
/// particle slides at v_x = (F - mu N) / c_t when F > mu N and sticks (v_x = F / (c_t + k_stick))
/// otherwise. Returns the solution at the given slip_relaxation.
QuasiStaticSolution dragged_particle(double drag, double eps) {
  QuasiStaticProblem prob;
  prob.particles = 1;
  prob.dt = 1.0;
  prob.wall_rate = {0.0, 0.0};
  prob.wall_load = {0.0, 0.0};
  LinearRow floor, ceiling;
  floor.j = -1;
  floor.n = Vec3::UnitZ();
  floor.r_min = 1.0;
  floor.lc.f0 = 1.0;   // N [N]
  floor.lc.c = 10.0;   // [N s/m]
  floor.lc.mu = 0.5;
  floor.lc.ct = 1e4;   // stick viscosity [N s/m]
  floor.lc.unilateral = true;
  ceiling = floor;
  ceiling.j = -2;
  ceiling.n = -Vec3::UnitZ();
  ceiling.lc.mu = std::numeric_limits<double>::infinity();
  ceiling.lc.ct = 1.0;  // c_t [N s/m]
  ceiling.lc.ft0 = Vec3(drag, 0.0, 0.0);
  prob.rows = {floor, ceiling};
  QuasiStaticConfig cfg;
  cfg.friction_iterations = 500;
  cfg.friction_tolerance = 1e-8;
  cfg.slip_relaxation = eps;
  return solve_quasi_static(prob, cfg);
}
}  // namespace

TEST_CASE("Quasi-static friction: a dragged particle slides at (F - mu N) / c_t for every slip_relaxation, sooner with a small one", "[quasi_static]") {
  // Near sticking (mu N / F = 0.9) the secant rounds (eps = 1) contract by 0.9 per round and the
  // relaxed Newton form (eps = 0.1) by eps mu N / (F - mu N + eps mu N) = 0.47: the same answer in
  // fewer rounds.
  const double drag = 0.5 / 0.9, exact = drag - 0.5;
  const QuasiStaticSolution secant = dragged_particle(drag, 1.0), relaxed = dragged_particle(drag, 0.1);
  INFO("v_x " << secant.v[0].x() << " (" << secant.rounds << " rounds), " << relaxed.v[0].x() << " (" << relaxed.rounds
              << " rounds); closed form " << exact << " m/s");
  CHECK(secant.converged);
  CHECK(relaxed.converged);
  CHECK(secant.v[0].x() == Approx(exact).epsilon(1e-6));
  CHECK(relaxed.v[0].x() == Approx(exact).epsilon(1e-6));
  CHECK(std::abs(secant.v[0].z()) < 1e-12);
  CHECK(relaxed.rounds * 3 < secant.rounds);
  // Below the cap it sticks: the stick viscosity alone resists.
  const QuasiStaticSolution stuck = dragged_particle(0.4, 0.1);
  CHECK(stuck.v[0].x() == Approx(0.4 / (1.0 + 1e4)).epsilon(1e-9));
  CHECK(stuck.sliding == 0);
}

TEST_CASE("Quasi-static neck moments: two particles twisted and bent against each other turn at torque / (twist or bend)", "[quasi_static]") {
  // Particles 0 and 1 joined by a neck along x (LinearContact bend B, twist T; no arms, so its
  // tangential line takes no part). Each is driven by two force-free wall rows (normals +z and -z,
  // arm R, F_t = +-F along y and along x), whose net is a torque 2 R F x (twist) and -2 R F y (bend)
  // on particle 0 and the opposite on 1. The relative spin W = w_0 - w_1 is then (2RF / T, -2RF / B, 0)
  // and the common spin is zero (its right-hand side is).
  const double R = 1e-6, F = 1e-6, B = 3e-15, T = 7e-15;
  QuasiStaticProblem prob;
  prob.particles = 2;
  prob.dt = 1.0;
  prob.wall_rate = {0.0, 0.0};
  prob.wall_load = {0.0, 0.0};
  LinearRow neck;
  neck.i = 0;
  neck.j = 1;
  neck.n = Vec3::UnitX();
  neck.r_min = R;
  neck.lc.c = 1.0;
  neck.lc.ct = 1.0;
  neck.lc.bend = B;
  neck.lc.twist = T;
  prob.rows.push_back(neck);
  for (int p = 0; p < 2; ++p)
    for (int side = 0; side < 2; ++side) {
      const double sgn = side == 0 ? 1.0 : -1.0, dir = p == 0 ? 1.0 : -1.0;
      LinearRow d;
      d.i = static_cast<Index>(p);
      d.j = -1 - side;
      d.n = sgn * Vec3::UnitZ();
      d.arm_i = R;
      d.r_min = R;
      d.lc.ft0 = dir * sgn * F * Vec3(1.0, 1.0, 0.0);  // y: torque R F x (twist); x: torque -R F y (bend)
      prob.rows.push_back(d);
    }
  QuasiStaticConfig cfg;
  const QuasiStaticSolution sol = solve_quasi_static(prob, cfg);
  const Vec3 W = sol.w[0] - sol.w[1], common = sol.w[0] + sol.w[1];
  INFO("W = " << W.transpose() << " rad/s; closed form " << 2 * R * F / T << ", " << -2 * R * F / B);
  CHECK(W.x() == Approx(2.0 * R * F / T).epsilon(1e-9));
  CHECK(W.y() == Approx(-2.0 * R * F / B).epsilon(1e-9));
  CHECK(std::abs(W.z()) < 1e-9 * W.norm());
  // The common spin is a free mode held by the 1e-12 drag alone: round-off (1e-16) amplified 1e12 times.
  CHECK(common.norm() < 1e-3 * W.norm());
  CHECK(sol.v[0].norm() + sol.v[1].norm() < 1e-12);
}

TEST_CASE("Quasi-static stage: what it cannot take is refused before step 0", "[quasi_static]") {
  State s;
  test::add_sphere(s, Vec3(0, 0, 0), kR, kRho);
  test::add_sphere(s, Vec3(1.9 * kR, 0, 0), kR, kRho);
  test::NullObserver obs;
  SECTION("a law without an inertia-free form") {
    const ContactModelT<physics::HertzMindlin> law(physics::HertzMindlin::Params{});
    Simulation sim(s, law);
    CHECK_THROWS_WITH(sim.run_stage(qs_stage(1e-4, 1), obs), Catch::Contains("no inertia-free form"));
  }
  SECTION("scaled inertia") {
    const ContactModelT<Sintering> law(hot_params());
    Simulation sim(s, law);
    StageConfig c = qs_stage(1e-4, 1);
    c.mass_scaling = 10.0;
    CHECK_THROWS_WITH(sim.run_stage(c, obs), Catch::Contains("mass_scaling"));
  }
  SECTION("no dt") {
    const ContactModelT<Sintering> law(hot_params());
    Simulation sim(s, law);
    StageConfig c = qs_stage(0.0, 1);
    c.dt_fraction = 0.5;
    CHECK_THROWS_WITH(sim.run_stage(c, obs), Catch::Contains("set dt"));
  }
}

TEST_CASE("Quasi-static stage: `sparkdem check` plans it without a stable-step limit", "[quasi_static]") {
  // The dry run prepares each stage as the run does: a quasi-static stage's dt (1 s here) is not
  // compared with the explicit stable step, and its plan is the one quasi_static_step item.
  Registry reg;
  physics::register_all(reg);
  io::Scenario sc = io::load_scenario(test::load_data("quasi_static_press_small.json"), reg,
                                      std::filesystem::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data");
  const nlohmann::json d = io::dry_run(sc);
  const auto& press = d["stages"][1]["derived"];
  CHECK_FALSE(press.contains("dt_note"));
  CHECK(press["step_plan"] == nlohmann::json::array({"quasi_static_step", "temperature_history"}));
}

}  // namespace test_quasi_static
