// Extreme mechanical cases (issue 9; docs/extreme_cases.md). Each case states what sparkdem must
// do with it and checks a physical result against a closed form, an invariant or a bisection.
//
//  M1 size ratios 15 and 50 in one packing: no contact missed over a dynamic run; search cost.
//  M2 E = 1e12 Pa: stable-step estimate against the limit measured by bisection; 0.9 x the
//     estimate conserves energy; above the limit refused, and with the override caught as a
//     blow-up with the step and the particle ids.
//  M3 mass scaling 1e6 in a quasi-static compression: the static answer (closed-form Hertz
//     column) is unchanged, the step is 1000 x larger, kinetic/elastic energy reported.
//  M4 pressure-driven punch with no particle under it (refused) and with one particle (runs,
//     settles at the Hertz closed form).
//  M5 overlapping initial particles: reported always; refused, relaxed or allowed as configured.
#include <catch2/catch.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "engine/simulation.hpp"
#include "engine/start_checks.hpp"
#include "engine/state/particle_set.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "tests/extreme/extreme_figures.hpp"
#include "tests/support/scene.hpp"
#include "tests/support/scratch.hpp"
#include "tests/support/tolerance.hpp"

namespace test_extreme_mechanics {

using namespace sparkdem;
using physics::HertzMindlin;
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// K + U: kinetic (translation + rotation) and Hertz elastic energy 8/15 E* sqrt(R*) delta^5/2
/// of every overlapping pair and particle-wall contact (R* = r at a wall).
struct Energy {
  double kinetic = 0.0, elastic = 0.0;
  double total() const { return kinetic + elastic; }
};
Energy hertz_energy(const State& s, double es) {
  const auto& p = s.particles;
  Energy e;
  for (std::size_t i = 0; i < p.size(); ++i) {
    e.kinetic += 0.5 * p.mass[i] * p.velocity[i].squaredNorm() + 0.5 * p.inertia[i] * p.omega[i].squaredNorm();
    for (std::size_t j = i + 1; j < p.size(); ++j) {
      const double d = p.radius[i] + p.radius[j] - (p.position[i] - p.position[j]).norm();
      if (d > 0.0) e.elastic += 8.0 / 15.0 * es * std::sqrt(p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j])) * std::pow(d, 2.5);
    }
    for (const Wall& w : s.walls) {
      Vec3 n;
      double dist;
      w.distance(p.position[i], n, dist);
      const double d = p.radius[i] - dist;
      if (d > 0.0) e.elastic += 8.0 / 15.0 * es * std::sqrt(p.radius[i]) * std::pow(d, 2.5);
    }
  }
  return e;
}

std::set<std::pair<Id, Id>> touching_ids(const State& s) {
  const auto& p = s.particles;
  std::set<std::pair<Id, Id>> out;
  for (const auto& pr : find_pairs_brute_force(p.position, p.radius, 0.0))
    out.emplace(std::min(p.id[pr[0]], p.id[pr[1]]), std::max(p.id[pr[0]], p.id[pr[1]]));
  return out;
}

double median_seconds(const std::function<void()>& f, int reps) {
  std::vector<double> t;
  for (int k = 0; k < reps; ++k) {
    const auto a = std::chrono::steady_clock::now();
    f();
    t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// M1
// ---------------------------------------------------------------------------------------------
TEST_CASE("extreme M1: size ratios 15 and 50 in one packing - no contact missed over a dynamic run, search cost", "[extreme][neighbor]") {
  // Expectation: runs; at every 20th step every pair touching by the O(N^2) reference is in the
  // contact table (exact set inclusion: 0 missed, over more than 1,000 ratio-50 and 2,000
  // ratio-15 contacts), and the cell search on this packing costs at most 5 x that of a
  // monodisperse packing of the same count (multi-level grid).
  // Packing: 2 spheres of 50 r0 touching each other, 12 of 15 r0 on them, 2400 of r0 on the
  // surfaces of the large and medium ones (overlap 1e-4 r0) and 600 free ones between them;
  // a converging velocity field, Hertz E = 1e8 Pa, restitution 0.1, friction 0.5.
  const double r0 = 1e-4, rho = 2500.0;
  State s;
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  auto dir = [&]() { return Vec3(g(rng), g(rng), g(rng)).normalized(); };
  std::vector<Vec3> x;
  std::vector<double> r;
  std::vector<std::size_t> host_of;  // per particle: its host's index (itself for the large and free ones)
  auto free_of = [&](const Vec3& c, double rc, std::size_t skip_host) {
    for (std::size_t k = 0; k < x.size(); ++k)
      if (k != skip_host && (x[k] - c).norm() < r[k] + rc) return false;
    return true;
  };
  x.push_back(Vec3(0, 0, 0));
  r.push_back(50 * r0);
  x.push_back(Vec3(100 * r0 - 0.01 * r0, 0, 0));
  r.push_back(50 * r0);
  host_of = {0, 1};
  for (int k = 0; k < 12;) {  // medium spheres on the large ones
    const std::size_t host = k % 2;
    const Vec3 c = x[host] + (65 * r0 - 1e-4 * r0) * dir();
    if (free_of(c, 15 * r0, host)) {
      x.push_back(c);
      r.push_back(15 * r0);
      host_of.push_back(host);
      ++k;
    }
  }
  const double a_large = 2 * 4 * kPi * 2500.0, a_medium = 12 * 4 * kPi * 225.0;  // host surface weights
  for (int k = 0, tries = 0; k < 2400 && tries < 200000; ++tries) {
    std::size_t host = u(rng) * (a_large + a_medium) < a_large ? static_cast<std::size_t>(u(rng) * 2)
                                                               : 2 + static_cast<std::size_t>(u(rng) * 12);
    host = std::min<std::size_t>(host, 13);
    const Vec3 c = x[host] + (r[host] + r0 - 1e-4 * r0) * dir();
    if (free_of(c, r0, host)) {
      x.push_back(c);
      r.push_back(r0);
      host_of.push_back(host);
      ++k;
    }
  }
  for (int k = 0, tries = 0; k < 600 && tries < 200000; ++tries) {
    const Vec3 c(-60 * r0 + 220 * r0 * u(rng), -60 * r0 + 120 * r0 * u(rng), -60 * r0 + 120 * r0 * u(rng));
    if (free_of(c, r0, static_cast<std::size_t>(-1))) {
      x.push_back(c);
      r.push_back(r0);
      host_of.push_back(x.size() - 1);
      ++k;
    }
  }
  REQUIRE(x.size() > 2900);
  // Every satellite moves towards its host at 0.02 m/s plus 0.005 m/s at random (restitution
  // 0.1: it rattles on the host's surface), the free ones towards the middle of the large pair:
  // contacts open and close all the time across the three sizes.
  const Vec3 mid(50 * r0, 0, 0);
  for (std::size_t k = 0; k < x.size(); ++k) {
    const Vec3 target = host_of[k] == k ? mid : x[host_of[k]];
    const Vec3 in = (target - x[k]).norm() > 0.0 ? Vec3((target - x[k]).normalized()) : Vec3::Zero();
    test::add_sphere(s, x[k], r[k], rho, 0.02 * in + 0.005 * dir());
  }
  s.particles.velocity[0] = s.particles.velocity[1] = Vec3::Zero();

  // Cost of the search on this packing against a monodisperse one of the same count and box.
  std::vector<Vec3> xm;
  std::vector<double> rm(x.size(), 2.0 * r0);
  while (xm.size() < x.size()) xm.push_back(Vec3(-60 * r0 + 220 * r0 * u(rng), -60 * r0 + 120 * r0 * u(rng), -60 * r0 + 120 * r0 * u(rng)));
  NeighborStats st;
  const auto cand = find_pairs(x, r, 0.3 * r0, &st);
  const double t_poly = median_seconds([&] { (void)find_pairs(x, r, 0.3 * r0); }, 7);
  const double t_mono = median_seconds([&] { (void)find_pairs(xm, rm, 0.3 * r0); }, 7);
  const double t_brute = median_seconds([&] { (void)find_pairs_brute_force(x, r, 0.3 * r0); }, 1);

  HertzMindlin::Params hp;
  hp.youngs_modulus = 1e8;
  hp.restitution = 0.1;
  const ContactModelT<HertzMindlin> law(hp);
  Simulation sim(s, law);
  std::size_t missed = 0, checks = 0, touching_max = 0, big_small = 0, medium_small = 0;
  test::StepObserver obs([&](const State& sx, Step) {
    std::set<std::pair<Id, Id>> table;
    for (std::size_t k = 0; k < sx.contacts.size(); ++k)
      table.emplace(std::min(sx.contacts.id_i()[k], sx.contacts.id_j()[k]), std::max(sx.contacts.id_i()[k], sx.contacts.id_j()[k]));
    const auto touching = touching_ids(sx);
    touching_max = std::max(touching_max, touching.size());
    for (const auto& pr : touching) {
      missed += table.count(pr) == 0;
      // ids follow the order of creation: 0-1 large, 2-13 medium, then small.
      if (pr.first < 2 && pr.second >= 14) ++big_small;
      if (pr.first >= 2 && pr.first < 14 && pr.second >= 14) ++medium_small;
    }
    ++checks;
  });
  const double dt = 0.5 * sim.mechanical_stable_dt();
  StageConfig cfg = test::stage(dt, 2000);
  cfg.log_every = 20;
  const StageResult res = sim.run_stage(cfg, obs);
  CHECK(checks == 100);
  CHECK(touching_max > 300);
  CHECK(big_small > 1000);     // ratio-50 pairs checked (summed over the 100 checks)
  CHECK(medium_small > 2000);  // ratio-15 pairs checked
  CHECK(st.levels >= 3);       // the three sizes sit on different levels
  CHECK(missed == 0);
  CHECK(t_poly <= 5.0 * t_mono);
  EXTREME_FIGURE("M1 size ratio 15 and 50", "contacts missed over 100 checks", static_cast<double>(missed), "");
  EXTREME_FIGURE("M1 size ratio 15 and 50", "ratio-50 contacts checked", static_cast<double>(big_small), "");
  EXTREME_FIGURE("M1 size ratio 15 and 50", "ratio-15 contacts checked", static_cast<double>(medium_small), "");
  EXTREME_FIGURE("M1 size ratio 15 and 50", "most contacts at one check", static_cast<double>(touching_max), "");
  EXTREME_FIGURE("M1 size ratio 15 and 50", "search time poly / mono", t_poly / t_mono, "");
  EXTREME_FIGURE("M1 size ratio 15 and 50", "search time per particle", t_poly / static_cast<double>(x.size()) * 1e6, "us");
  EXTREME_FIGURE("M1 size ratio 15 and 50", "brute force / cell search", t_brute / t_poly, "");
  EXTREME_FIGURE("M1 size ratio 15 and 50", "candidate pairs per particle",
                 static_cast<double>(cand.size()) / static_cast<double>(x.size()), "");
  EXTREME_FIGURE("M1 size ratio 15 and 50", "particle-steps per second", res.particle_steps_per_second, "1/s");
}

// ---------------------------------------------------------------------------------------------
// M2
// ---------------------------------------------------------------------------------------------
namespace {

constexpr double kE12 = 1e12, kR12 = 1e-3, kRho12 = 2500.0, kDelta0 = 1e-6;

/// A 3 x 3 x 3 simple cubic lattice of spheres (r = 1 mm) pre-compressed by 1 um per contact
/// inside a box whose walls press on it with the same force, with random velocities (1e-3 m/s):
/// a conservative (e = 1, mu = 0), permanently connected contact network.
State stiff_lattice(std::uint64_t seed) {
  State s;
  const double a = 2 * kR12 - kDelta0;
  // Walls press by delta_w = 2^(-1/3) delta0, which gives the pair force (R* = r at a wall,
  // r/2 between spheres): the lattice at rest is in equilibrium.
  const double dw = kDelta0 * std::pow(2.0, -1.0 / 3.0);
  const double lo = kR12 - dw, hi = lo + 2 * a + kR12 - dw;
  test::add_box(s, Vec3::Constant(0.0), Vec3::Constant(hi));
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        test::add_sphere(s, Vec3(lo + a * i, lo + a * j, lo + a * k), kR12, kRho12, 1e-3 * Vec3(g(rng), g(rng), g(rng)));
  return s;
}

HertzMindlin::Params stiff_params() {
  HertzMindlin::Params p;
  p.youngs_modulus = kE12;
  p.poisson_ratio = 0.3;
  p.restitution = 1.0;
  p.friction = 0.0;
  return p;
}

/// Largest |E(t) - E0| over `steps` steps at dt, in units of the initial vibration energy
/// E_vib = E0 - E_static (the static precompression's elastic energy); +inf if the run fails.
double energy_excursion(double dt, Step steps, double* drift_rel_total = nullptr) {
  State s = stiff_lattice(4);
  const ContactModelT<HertzMindlin> law(stiff_params());
  const double es = law.law().e_star();
  // Static energy: the same lattice at rest.
  State rest = stiff_lattice(4);
  for (auto& v : rest.particles.velocity) v.setZero();
  const double e_static = hertz_energy(rest, es).total();
  const double e0 = hertz_energy(s, es).total(), e_vib = e0 - e_static;
  Simulation sim(s, law);
  double worst = 0.0;
  test::StepObserver obs([&](const State& st, Step) { worst = std::max(worst, std::abs(hertz_energy(st, es).total() - e0)); });
  StageConfig c = test::stage(dt, steps, 0.1 * kR12);
  c.allow_unstable_dt = true;
  c.blowup_speed = 1e30;
  c.log_every = 10;
  try {
    sim.run_stage(c, obs);
  } catch (const std::exception&) { return std::numeric_limits<double>::infinity(); }
  if (drift_rel_total) *drift_rel_total = std::abs(hertz_energy(s, es).total() - e0) / e0;
  return std::isfinite(worst) ? worst / e_vib : std::numeric_limits<double>::infinity();
}

}  // namespace

TEST_CASE(
    "extreme M2: E = 1e12 Pa - stable-step estimate against the bisected limit, energy at 0.9 of it, refusal and "
    "caught blow-up above the limit",
    "[extreme][stability]") {
  // Expectation: the estimate (Rayleigh and Gershgorin on the contact network) lies below the
  // limit measured by bisection and above 0.35 of it, its network part (no Rayleigh step) above
  // 0.9 of it; the bisected limit agrees with the linear normal-mode analysis of the lattice
  // within 1 %; at 0.9 x the estimate the energy stays within (dt / limit)^2 of the vibration
  // energy over 20,000 steps (velocity Verlet's bounded oscillation, no drift); a step above the measured limit is a SetupError naming
  // allow_unstable_dt; with the override the run stops with a PhysicsError at step > 0 naming
  // particle ids.
  State s = stiff_lattice(4);
  const ContactModelT<HertzMindlin> law(stiff_params());
  Simulation probe(s, law);
  test::NullObserver none;
  probe.run_stage(test::stage(1e-12, 0, 0.1 * kR12), none);  // contact table of the lattice
  const double estimate = probe.mechanical_stable_dt();
  REQUIRE(s.contacts.size() >= 54);
  // Bisection: stable when the energy excursion over 3000 steps stays below 1e4 x E_vib (close
  // below the limit velocity Verlet's bounded energy error grows like 1 / (1 - (w dt / 2)^2),
  // ~500 at 0.1 % below it; above it the top mode grows by (1 + 2 sqrt(eps))^n).
  double lo = 0.5 * estimate, hi = 8.0 * estimate;
  REQUIRE(energy_excursion(lo, 3000) < 1.0);
  REQUIRE(energy_excursion(hi, 3000) > 1e4);
  for (int it = 0; it < 20; ++it) {
    const double mid = 0.5 * (lo + hi);
    (energy_excursion(mid, 3000) < 1e4 ? lo : hi) = mid;
  }
  const double limit = hi;
  // Linear analysis: frictionless contacts only couple motion along the line of centres, so each
  // row of 3 spheres between two walls is a chain with tangent stiffnesses k = 2 E* sqrt(R* delta)
  // (pairs: R* = r/2, delta0; walls: R* = r, delta_w = 2^-1/3 delta0, so k_w = 2^(1/3) k): the
  // limit is 2 / sqrt(lambda_max(K / m)) of the 3 x 3 chain matrix.
  const double es = law.law().e_star(), m = test::sphere_mass(kR12, kRho12);
  const double k = 2 * es * std::sqrt(0.5 * kR12 * kDelta0), kw = std::cbrt(2.0) * k;
  Eigen::Matrix3d K;
  K << k + kw, -k, 0, -k, 2 * k, -k, 0, -k, k + kw;
  const double linear = 2.0 / std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(K / m).eigenvalues().maxCoeff());
  INFO("estimate " << estimate << " s, measured limit " << limit << " s, linear analysis " << linear << " s");
  CHECK(estimate < limit);
  CHECK(std::abs(limit - linear) <= 0.01 * linear);
  // At mu = 0 the tangential springs drop out of the estimate and the normal rows are exact per
  // axis: the network part is 2 / sqrt(4 k / m) = 0.94 of the limit; the Rayleigh step (an
  // a-priori bound for contacts still to come) binds at 0.39 of it.
  const double network = law.network_stable_dt(s.particles, s.contacts, s.walls);
  CHECK(estimate > 0.35 * limit);
  CHECK(network < limit);
  CHECK(network > 0.9 * limit);
  // Velocity Verlet conserves a modified energy; the energy itself oscillates by at most
  // (w dt / 2)^2 = (dt / limit)^2 of it (harmonic modes, top mode w = 2 / limit).
  double drift = 0.0;
  const double exc = energy_excursion(0.9 * estimate, 20000, &drift);
  CHECK(exc < std::pow(0.9 * estimate / limit, 2));
  EXTREME_FIGURE("M2 E = 1e12 Pa", "stable-step estimate", estimate, "s");
  EXTREME_FIGURE("M2 E = 1e12 Pa", "limit by bisection", limit, "s");
  EXTREME_FIGURE("M2 E = 1e12 Pa", "estimate / limit", estimate / limit, "");
  EXTREME_FIGURE("M2 E = 1e12 Pa", "network estimate (no a-priori step)", network, "s");
  EXTREME_FIGURE("M2 E = 1e12 Pa", "network estimate / limit", network / limit, "");
  EXTREME_FIGURE("M2 E = 1e12 Pa", "bisected limit / linear analysis", limit / linear, "");
  EXTREME_FIGURE("M2 E = 1e12 Pa", "max |dE| / E_vib at 0.9 estimate (20000 steps)", exc, "");
  EXTREME_FIGURE("M2 E = 1e12 Pa", "final |dE| / E0 at 0.9 estimate", drift, "");

  // Above the measured limit: refused before step 0.
  const double above = 1.5 * limit;
  {
    State t = stiff_lattice(4);
    Simulation sim(t, law);
    try {
      sim.run_stage(test::stage(above, 100, 0.1 * kR12), none);
      FAIL("a step above the measured stability limit was accepted");
    } catch (const SetupError& e) {
      const std::string what = e.what();
      INFO(what);
      CHECK(what.find("allow_unstable_dt") != std::string::npos);
      CHECK(what.find("stable step") != std::string::npos);
    }
  }
  // With the override: caught as a blow-up (default blow-up rule: a particle moving more than its
  // radius per step) with the step and the particle ids.
  {
    State t = stiff_lattice(4);
    Simulation sim(t, law);
    StageConfig c = test::stage(above, 100000, 0.1 * kR12);
    c.allow_unstable_dt = true;
    try {
      sim.run_stage(c, none);
      FAIL("the unstable run was not stopped");
    } catch (const PhysicsError& e) {
      INFO(e.what());
      CHECK(e.step() > 0);
      CHECK(!e.ids().empty());
      CHECK(e.quantity() == "velocity");
      EXTREME_FIGURE("M2 E = 1e12 Pa", "blow-up caught at step (1.5 x limit)", static_cast<double>(e.step()), "");
      EXTREME_FIGURE("M2 E = 1e12 Pa", "particles named", static_cast<double>(e.ids().size()), "");
    }
  }
}

// ---------------------------------------------------------------------------------------------
// M3
// ---------------------------------------------------------------------------------------------
TEST_CASE(
    "extreme M3: mass scaling 1e6 in a quasi-static compression - the static answer is unchanged, the step is "
    "1000 x larger",
    "[extreme][mass_scaling]") {
  // Expectation: runs; the stable step with masses x 1e6 is exactly 1000 x the unscaled one
  // (1e-12); a 4 x 4 x 4 simple cubic column lattice (r = 1 mm, E = 70 GPa, frictionless,
  // e = 0.5) pressed by a servo punch to p = 1 MPa settles at the closed-form Hertz heights
  // (each column carries p A / 16; compression per contact (3 F / (4 E* sqrt(R*)))^2/3) within
  // 1 % of the total compression, the punch and floor forces equal p A within 1 %, and the
  // final kinetic energy is below 1e-3 of the elastic energy.
  const double r = 1e-3, rho = 2500.0, E = 70e9, nu = 0.3, P = 1e6;
  const int n = 4;
  const double side = 2 * r * n, area = side * side;
  auto build = [&](State& s) {
    test::add_box(s, Vec3(0, 0, 0), Vec3(side, side, 2 * r * n + 10 * r));
    s.find_wall("z_hi")->shape = PlaneShape{Vec3(0, 0, 2 * r * n), -Vec3::UnitZ()};
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < n; ++k) test::add_sphere(s, Vec3(r + 2 * r * i, r + 2 * r * j, r + 2 * r * k), r, rho);
  };
  HertzMindlin::Params hp;
  hp.youngs_modulus = E;
  hp.poisson_ratio = nu;
  hp.restitution = 0.5;
  hp.friction = 0.0;
  const ContactModelT<HertzMindlin> law(hp);
  // At a fixed 0.5 of the stable step, and with an adaptive step of 0.9 (issue 62: the columns
  // stiffen as the punch loads them).
  for (const bool adaptive : {false, true}) {
  const std::string label = adaptive ? "M3 mass scaling 1e6, adaptive 0.9" : "M3 mass scaling 1e6";
  INFO(label);
  State s;
  build(s);
  Simulation sim(s, law);
  const double dt_plain = sim.mechanical_stable_dt();
  StageConfig cfg = test::stage(0.0, 12000, 0.2 * r);
  cfg.dt_fraction = adaptive ? 0.0 : 0.5;
  cfg.adaptive.fraction = adaptive ? 0.9 : 0.0;
  cfg.mass_scaling = 1e6;
  WallMotion m;
  m.kind = WallMotion::Kind::Pressure;
  m.pressure_time = {0.0, 1.0};
  m.pressure_value = {P, P};
  m.area = area;
  m.max_speed = 2e-5;
  cfg.motions["z_hi"] = m;
  cfg.log_every = 12000;
  double ke_over_el = 0.0;
  const double es = law.law().e_star();
  test::StepObserver obs([&](const State& st, Step) {
    const Energy e = hertz_energy(st, es);
    ke_over_el = e.kinetic / e.elastic;  // the masses are the scaled ones inside the stage
  });
  const StageResult res = sim.run_stage(cfg, obs);
  CHECK(test::relative_error(res.stable_dt_at_start, 1000.0 * dt_plain) < 1e-12);
  // Closed form.
  const double F = P * area / (n * n);
  const double d_pp = std::pow(3 * F / (4 * es * std::sqrt(0.5 * r)), 2.0 / 3.0);
  const double d_w = std::pow(3 * F / (4 * es * std::sqrt(r)), 2.0 / 3.0);
  const double compression = (n - 1) * d_pp + 2 * d_w;
  const Wall& top = *s.find_wall("z_hi");
  const Wall& floor = *s.find_wall("z_lo");
  const double height = 2 * r * n - top.u;  // punch plane height
  const double err = std::abs((2 * r * n - height) - compression) / compression;
  INFO("compression " << 2 * r * n - height << " m, closed form " << compression << " m; punch force " << top.normal_force << " N, floor "
                      << floor.normal_force << " N, target " << P * area << " N");
  CHECK(err < 0.01);
  CHECK(test::relative_error(top.normal_force, P * area) < 0.01);
  CHECK(test::relative_error(floor.normal_force, P * area) < 0.01);
  CHECK(ke_over_el < 1e-3);
  EXTREME_FIGURE(label, "dt scaled / unscaled", res.stable_dt_at_start / dt_plain, "");
  EXTREME_FIGURE(label, "compression error vs Hertz column", err, "");
  EXTREME_FIGURE(label, "floor force / p A", floor.normal_force / (P * area), "");
  EXTREME_FIGURE(label, "kinetic / elastic at end", ke_over_el, "");
  EXTREME_FIGURE(label, "steps", static_cast<double>(res.steps), "");
  EXTREME_FIGURE(label, "wall time", res.wall_seconds, "s");
  if (adaptive) {
    REQUIRE(res.adaptive);
    CHECK(res.adaptive->overshoots == 0);
    EXTREME_FIGURE(label, "smallest / first step", res.adaptive->min / res.dt, "");
  }
  }
}

// ---------------------------------------------------------------------------------------------
// M4
// ---------------------------------------------------------------------------------------------
namespace {
json punch_scene(bool flipped) {
  // A die (cylinder) with a floor and a pressure punch 0.1 mm above a single sphere (r = 1 mm)
  // resting on the floor (a one-point lattice). flipped: the punch's normal points away from the powder (the
  // classic sign mistake): no particle lies on its inward side.
  json sc = json::parse(R"({
    "name": "punch", "seed": 1,
    "materials": [{"name": "steel", "density": 7800}],
    "contact": {"law": "hertz_mindlin", "params": {"youngs_modulus": 1e9, "poisson_ratio": 0.3, "restitution": 0.3, "friction": 0.3}},
    "walls": [
      {"name": "die", "type": "cylinder", "base": [0, 0, 0], "axis": [0, 0, 1], "radius": 0.004},
      {"name": "bottom", "type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]},
      {"name": "top", "type": "plane", "point": [0, 0, 0.0021], "normal": [0, 0, -1]}
    ],
    "stages": [
      {"name": "create", "type": "lattice", "generator": {"lo": [-0.0005, -0.0005, 0.001], "hi": [0.0005, 0.0005, 0.0015], "spacing": 0.001, "diameter": 0.002}},
      {"name": "press", "type": "dynamics", "dt": 2e-6,
       "walls": {"top": {"type": "pressure", "times": [0, 1], "pressures": [1e4, 1e4], "max_speed": 0.01, "area": 1e-5}},
       "stop": {"steps": 40000}, "output": {"timeseries_every": 1000}}
    ]
  })");
  if (flipped) sc["walls"][2]["normal"] = {0, 0, 1};
  return sc;
}
json run_scene(const json& scene, const std::string& tag) {
  test::ScratchDir tmp("sparkdem_extreme_" + tag);
  io::Scenario sc = io::load_scenario(scene, test::registry(), tmp.path);
  io::RunOptions opt;
  opt.outdir = tmp.path / "out";
  opt.quiet = true;
  opt.threads = 1;
  return io::run_scenario(sc, opt);
}
}  // namespace

TEST_CASE("extreme M4: pressure punch with no particle under it is refused, with a single particle it settles at Hertz",
          "[extreme][walls]") {
  SECTION("zero particles under the punch: refused before step 0") {
    // Expectation: (a) the punch's normal pointing away from the powder (the classic sign
    // mistake) is already refused by the loader (ConfigError: the walls do not enclose the
    // generated particles); (b) a stage whose packing has no particle in front of a pressure
    // punch (here: an empty lattice region, 0 particles) and (c) the same in code (a sphere on the
    // floor, the punch facing away) are refused at the stage start by engine/start_checks
    // (SetupError naming the stage, the wall and what to change). Before this case (b) and (c)
    // ran, the punch travelling at max_speed for ever.
    CHECK_THROWS_AS(run_scene(punch_scene(true), "punch_flip"), ConfigError);
    json empty = punch_scene(false);
    empty["stages"][0]["generator"]["lo"] = {0.0001, 0.0001, 0.0011};
    empty["stages"][0]["generator"]["hi"] = {0.0002, 0.0002, 0.0012};
    std::string what;
    try {
      (void)run_scene(empty, "punch0");
      FAIL("the punch with nothing under it was accepted");
    } catch (const SetupError& e) { what = e.what(); } catch (const ConfigError& e) {
      what = std::string("ConfigError: ") + e.what();
    }
    INFO(what);
    CHECK(what.find("wall 'top'") != std::string::npos);
    State s;
    test::add_sphere(s, Vec3(0, 0, 1e-3), 1e-3, 7800.0);
    s.walls.push_back(test::plane_wall("floor", Vec3::Zero(), Vec3::UnitZ()));
    s.walls.push_back(test::plane_wall("punch", Vec3(0, 0, 2.1e-3), Vec3::UnitZ()));  // facing away
    HertzMindlin::Params hp;
    const ContactModelT<HertzMindlin> law(hp);
    Simulation sim(s, law);
    StageConfig cfg = test::stage(1e-6, 100, 1e-4);
    WallMotion m;
    m.kind = WallMotion::Kind::Pressure;
    m.pressure_time = {0.0, 1.0};
    m.pressure_value = {1e4, 1e4};
    m.area = 1e-5;
    m.max_speed = 0.01;
    cfg.motions["punch"] = m;
    cfg.name = "press";
    test::NullObserver none;
    try {
      sim.run_stage(cfg, none);
      FAIL("the punch with nothing under it was accepted");
    } catch (const SetupError& e) {
      const std::string w = e.what();
      INFO(w);
      CHECK(w.find("stage 'press'") != std::string::npos);
      CHECK(w.find("wall 'punch'") != std::string::npos);
      CHECK(w.find("no particle lies on its inward side") != std::string::npos);
    }
    CHECK(s.step == 0);
    EXTREME_FIGURE("M4 punch, 0 particles", "refused before step 0", 1.0, "");
  }
  SECTION("one free particle between floor and punch: runs and settles at the Hertz closed form") {
    // Expectation: the punch force reaches p A = 0.1 N within 0.5 %, the floor carries the same
    // force, and the punch stops where the sphere's two Hertz contacts give that force:
    // height = 2 r - 2 (3 F / (4 E* sqrt(r)))^(2/3), within 1 % of the compression.
    // At the scene's fixed step, and with an adaptive step of 0.9 (issue 62).
    for (const bool adaptive : {false, true}) {
    const std::string label = adaptive ? "M4 punch, 1 particle, adaptive 0.9" : "M4 punch, 1 particle";
    INFO(label);
    json scene = punch_scene(false);
    if (adaptive) scene["stages"][1]["dt"] = {{"adaptive", 0.9}};
    const json sum = run_scene(scene, adaptive ? "punch1_adaptive" : "punch1");
    REQUIRE(sum["status"] == "completed");
    const json& fin = sum["stages"][1]["final"];
    INFO(fin.dump());
    const double F = 1e4 * 1e-5;
    const double es = 1e9 / (2 * (1 - 0.09));
    const double d = std::pow(3 * F / (4 * es * std::sqrt(1e-3)), 2.0 / 3.0);
    const double ftop = fin["wall_top_normal_force"].get<double>(), fbot = fin["wall_bottom_normal_force"].get<double>();
    const double u = fin["wall_top_offset"].get<double>();
    const double comp = 2e-3 - (2.1e-3 - u);  // 2 r - punch height
    CHECK(test::relative_error(ftop, F) < 5e-3);
    CHECK(test::relative_error(fbot, F) < 5e-3);
    CHECK(std::abs(comp - 2 * d) < 0.01 * 2 * d);
    EXTREME_FIGURE(label, "punch force / p A", ftop / F, "");
    EXTREME_FIGURE(label, "compression error vs Hertz", std::abs(comp - 2 * d) / (2 * d), "");
    EXTREME_FIGURE(label, "wall time", sum["stages"][1]["wall_time_s"].get<double>(), "s");
    if (adaptive) CHECK(sum["stages"][1]["dt_adaptive"]["overshoots"] == 0);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// M5
// ---------------------------------------------------------------------------------------------
TEST_CASE("extreme M5: overlapping initial particles are reported, and refused, relaxed or allowed as configured", "[extreme][overlap]") {
  // Two spheres (r = 1 mm) overlapping by 20 % of r, plus a third one sunk 10 % into the floor.
  const double r = 1e-3, rho = 2500.0;
  auto build = [&](State& s) {
    s.walls.push_back(test::plane_wall("floor", Vec3::Zero(), Vec3::UnitZ()));
    test::add_sphere(s, Vec3(0, 0, 5 * r), r, rho);
    test::add_sphere(s, Vec3(1.8 * r, 0, 5 * r), r, rho);
    test::add_sphere(s, Vec3(6 * r, 0, 0.9 * r), r, rho);
  };
  HertzMindlin::Params hp;
  hp.youngs_modulus = 1e8;
  hp.restitution = 1.0;
  hp.friction = 0.0;
  const ContactModelT<HertzMindlin> law(hp);
  const double es = law.law().e_star();
  test::NullObserver none;
  SECTION("allow (default): reported exactly, and the stored elastic energy is released as kinetic energy") {
    // Expectation: max ratio 0.2 (1e-12), worst pair ids 0 and 1; energy conserved (e = 1):
    // the final kinetic energy equals the initial Hertz energy within 1e-3 (velocity Verlet at
    // 0.05 of the stable step through a release from 0.2 r).
    State s;
    build(s);
    const double e0 = hertz_energy(s, es).total();
    Simulation sim(s, law);
    StageConfig c = test::stage(0.0, 20000, 0.1 * r);
    c.dt_fraction = 0.05;
    const StageResult res = sim.run_stage(c, none);
    CHECK(res.initial_overlap.policy == "allow");
    CHECK(std::abs(res.initial_overlap.max_ratio - 0.2) < 1e-12);
    CHECK(res.initial_overlap.worst_i == 0);
    CHECK(res.initial_overlap.worst_j == 1);
    CHECK(res.initial_overlap.pairs_over_limit == 1);
    CHECK(res.initial_overlap.walls_over_limit == 1);
    const Energy e = hertz_energy(s, es);
    CHECK(e.elastic == 0.0);  // they flew apart
    CHECK(test::relative_error(e.kinetic, e0) < 1e-3);
    EXTREME_FIGURE("M5 initial overlap 0.2 r", "allow: max ratio reported", res.initial_overlap.max_ratio, "");
    EXTREME_FIGURE("M5 initial overlap 0.2 r", "allow: kinetic energy released", e.kinetic, "J");
    EXTREME_FIGURE("M5 initial overlap 0.2 r", "allow: release speed", std::sqrt(2 * e.kinetic / (3 * test::sphere_mass(r, rho))), "m/s");
  }
  SECTION("refuse: SetupError before step 0 naming the pair and the settings to change") {
    State s;
    build(s);
    const std::vector<Vec3> x0 = s.particles.position;
    Simulation sim(s, law);
    StageConfig c = test::stage(1e-7, 10, 0.1 * r);
    c.initial_overlap = "refuse";
    try {
      sim.run_stage(c, none);
      FAIL("the overlapping packing was accepted");
    } catch (const SetupError& e) {
      const std::string what = e.what();
      INFO(what);
      CHECK(what.find("particles 0 and 1 overlap by 0.2 of the smaller radius") != std::string::npos);
      CHECK(what.find("initial_overlap") != std::string::npos);
      CHECK(what.find("2 initial overlap(s)") != std::string::npos);
    }
    CHECK(s.step == 0);
    CHECK(s.particles.position == x0);
  }
  SECTION("relax: moved apart to the limit, then the run releases at most the limit's energy") {
    // Expectation: after relaxation every overlap is <= the limit 0.01 (pairs and wall), the
    // three particles were moved, and the energy (kinetic + elastic) created
    // by the run is at most the Hertz energy of the two contacts at the limit (bounded with R* = r).
    State s;
    build(s);
    Simulation sim(s, law);
    StageConfig c = test::stage(0.0, 2000, 0.1 * r);
    c.dt_fraction = 0.2;
    c.initial_overlap = "relax";
    double after = -1.0;
    test::StepObserver first([&](const State& st, Step k) {
      if (k == 1) after = measure_initial_overlap(st, 0.01).max_ratio;
    });
    const StageResult res = sim.run_stage(c, first);
    const auto& o = res.initial_overlap;
    CHECK(std::abs(o.max_ratio - 0.2) < 1e-12);
    CHECK(o.max_ratio_after <= 0.01);
    CHECK(o.moved == 3);
    CHECK(after <= 0.011);
    const double e_limit = 2 * 8.0 / 15.0 * es * std::sqrt(r) * std::pow(0.01 * r, 2.5);
    CHECK(hertz_energy(s, es).total() <= e_limit);
    EXTREME_FIGURE("M5 initial overlap 0.2 r", "relax: sweeps", o.sweeps, "");
    EXTREME_FIGURE("M5 initial overlap 0.2 r", "relax: ratio after", o.max_ratio_after, "");
    EXTREME_FIGURE("M5 initial overlap 0.2 r", "relax: energy after run / bound", hertz_energy(s, es).total() / e_limit, "");
  }
  SECTION("the scenario keys: initial_overlap refuse on an overlapping lattice, reported in summary.json with allow") {
    json sc = json::parse(R"({
      "name": "overlap", "seed": 1,
      "materials": [{"name": "glass", "density": 2500}],
      "contact": {"law": "hertz_mindlin", "params": {"youngs_modulus": 1e8, "poisson_ratio": 0.3, "restitution": 0.5, "friction": 0.3}},
      "walls": [{"name": "bottom", "type": "plane", "point": [0, 0, -0.01], "normal": [0, 0, 1]}],
      "stages": [
        {"name": "create", "type": "lattice", "generator": {"lo": [0, 0, 0], "hi": [0.0036, 0.0036, 0.0036], "spacing": 0.0018, "diameter": 0.002}},
        {"name": "run", "type": "dynamics", "dt_fraction": 0.2, "initial_overlap": "refuse", "initial_overlap_limit": 0.05,
         "stop": {"steps": 100}}
      ]
    })");
    try {
      (void)run_scene(sc, "overlap_refuse");
      FAIL("refuse did not refuse");
    } catch (const SetupError& e) {
      INFO(e.what());
      CHECK(std::string(e.what()).find("stage 'run'") != std::string::npos);
    }
    sc["stages"][1]["initial_overlap"] = "allow";
    const json sum = run_scene(sc, "overlap_allow");
    const json& o = sum["stages"][1]["initial_overlap"];
    INFO(o.dump());
    CHECK(std::abs(o["max_ratio"].get<double>() - 0.2) < 1e-9);  // spacing 1.8 mm, diameter 2 mm
    sc["stages"][1]["initial_overlap"] = "relax";
    sc["stages"][1]["initial_overlap_limit"] = 0.01;
    const json rel = run_scene(sc, "overlap_relax");
    CHECK(rel["stages"][1]["initial_overlap"]["max_ratio_after"].get<double>() <= 0.01);
    EXTREME_FIGURE("M5 initial overlap 0.2 r", "relax sweeps, 27-sphere lattice",
                   rel["stages"][1]["initial_overlap"]["relax_sweeps"].get<double>(), "");
  }
}

}  // namespace test_extreme_mechanics
