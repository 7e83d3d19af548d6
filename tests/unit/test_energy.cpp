// Energy conservation of the whole pipeline (neighbour list, Hertz law, wall pass, velocity
// Verlet): an elastic, frictionless gas of spheres in a closed box keeps its total energy
// (kinetic + elastic energy stored in the overlaps) to a relative drift below 1e-4.
#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <random>
#include <vector>

#include "engine/simulation.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "tests/support/scene.hpp"
#include "tests/support/tolerance.hpp"

namespace test_energy {

using namespace sparkdem;
using namespace sparkdem::physics;

namespace {

constexpr double kRho = 2500.0;
constexpr double kBox = 10e-3;  // [m]
constexpr double kVmax = 1.0;   // [m/s] largest initial speed

struct Energy {
  double kinetic_translational = 0.0;
  double kinetic_rotational = 0.0;
  double elastic = 0.0;
  double total() const { return kinetic_translational + kinetic_rotational + elastic; }
};

/// K + U with the Hertz elastic energy U = 8/15 E* sqrt(R*) delta^{5/2} of every overlapping
/// pair (all pairs, brute force) and every particle-wall overlap (R* = r).
Energy energy(const State& s, double es) {
  const auto& p = s.particles;
  Energy e;
  for (std::size_t i = 0; i < p.size(); ++i) {
    e.kinetic_translational += 0.5 * p.mass[i] * p.velocity[i].squaredNorm();
    e.kinetic_rotational += 0.5 * p.inertia[i] * p.omega[i].squaredNorm();
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

/// 40 spheres (r in [0.8, 1.2] mm, solid fraction ~0.18) on a 4x4x3 grid of the 10 mm box with
/// random velocities (|v| <= 1 m/s) and no spin.
void gas(State& s, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  test::add_box(s, Vec3::Zero(), Vec3::Constant(kBox));
  for (int k = 0; k < 48 && s.particles.size() < 40; ++k) {
    const Vec3 x((k % 4 + 0.5) * kBox / 4.0, (k / 4 % 4 + 0.5) * kBox / 4.0, (k / 16 + 0.5) * kBox / 3.0);
    Vec3 v(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5);
    v *= kVmax * (0.5 + 0.5 * u(rng)) / v.norm();
    test::add_sphere(s, x, 0.8e-3 + 0.4e-3 * u(rng), kRho, v);
  }
}

/// Stable step of a dense probe: the smallest sphere touched by six of the largest at the largest
/// overlap an impact at 2 kVmax can produce, delta = (15 m* v^2 / (16 E* sqrt(R*)))^{2/5}.
double dense_stable_dt(const ContactModelT<HertzMindlin>& law, double rmin, double rmax) {
  const double es = law.law().e_star();
  const double mi = test::sphere_mass(rmin, kRho), mj = test::sphere_mass(rmax, kRho);
  const double m_eff = mi * mj / (mi + mj), r_eff = rmin * rmax / (rmin + rmax), v = 2.0 * kVmax;
  const double delta = std::pow(15.0 * m_eff * v * v / (16.0 * es * std::sqrt(r_eff)), 0.4);
  ParticleStore p;
  p.add(Vec3::Zero(), rmin, mi);
  for (int d = 0; d < 3; ++d)
    for (double sgn : {-1.0, 1.0}) p.add(sgn * (rmin + rmax - delta) * Vec3::Unit(d), rmax, mj);
  ContactTable t;
  t.rebuild(find_pairs(p.position, p.radius, 0.0), p.id, p.size());
  REQUIRE(t.size() == 6);
  return law.stable_dt(p, t, {});
}

/// Hertz contact duration of the hardest impact of the gas (smallest on largest sphere at 2 kVmax):
/// t_c = 2.87 (m*^2 / (R* E*^2 v))^(1/5) (Johnson 1985) [s].
double hardest_contact_time(double es, double rmin, double rmax) {
  const double mi = test::sphere_mass(rmin, kRho), mj = test::sphere_mass(rmax, kRho);
  const double m_eff = mi * mj / (mi + mj), r_eff = rmin * rmax / (rmin + rmax);
  return 2.87 * std::pow(m_eff * m_eff / (r_eff * es * es * 2.0 * kVmax), 0.2);
}

/// Run `steps` steps at dt = min(0.1 x the initial (Rayleigh) step, t_c / 100: 100 steps per
/// shortest collision), below the dense stable step; return the largest relative deviation of
/// the total energy from its initial value.
double energy_drift(Step steps) {
  State s;
  gas(s, 2024);
  const HertzMindlin::Params params{1e8, 0.3, 1.0, 0.0};  // e = 1, mu = 0: conservative
  const ContactModelT<HertzMindlin> law(params);
  const double es = law.law().e_star();
  Simulation sim(s, law);
  const double dt_rayleigh = sim.mechanical_stable_dt();  // no contacts yet: the Rayleigh step
  const double dt_dense = dense_stable_dt(law, 0.8e-3, 1.2e-3);
  const double dt = std::min(0.1 * dt_rayleigh, hardest_contact_time(es, 0.8e-3, 1.2e-3) / 100.0);
  REQUIRE(dt < dt_dense);
  const double e0 = energy(s, es).total();
  double drift = 0.0, rot = 0.0, emax_elastic = 0.0;
  std::int64_t samples_in_contact = 0;
  test::StepObserver obs([&](const State& st, Step) {
    const Energy e = energy(st, es);
    drift = std::max(drift, std::abs(e.total() - e0) / e0);
    rot = std::max(rot, e.kinetic_rotational);
    emax_elastic = std::max(emax_elastic, e.elastic / e0);
    if (e.elastic > 0.0) ++samples_in_contact;
  });
  StageConfig cfg = test::stage(dt, steps);
  cfg.log_every = 10;
  const auto t0 = std::chrono::steady_clock::now();
  sim.run_stage(cfg, obs);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double final_dev = (energy(s, es).total() - e0) / e0;
  // The test is only meaningful if collisions happened all along: most samples see a contact.
  CHECK(samples_in_contact > steps / 10 / 2);
  // Frictionless contacts exert no torque: the rotational energy stays exactly 0.
  CHECK(rot == 0.0);
  WARN("energy: " << steps << " steps, dt = " << dt << " s (Rayleigh " << dt_rayleigh << " s, dense " << dt_dense << " s; " << secs
                  << " s wall), max |dE|/E0 = " << drift << ", final dE/E0 = " << final_dev << ", max elastic/E0 = " << emax_elastic
                  << ", rebuilds = " << s.rebuilds);
  return drift;
}

}  // namespace

TEST_CASE("Elastic frictionless gas in a box conserves energy (1e5 steps)", "[energy]") {
  // Tolerance (issue): relative drift of K + U below 1e-4 over 1e5 steps (~1.5 s).
  CHECK(energy_drift(100000) < 1e-4);
}

TEST_CASE("Elastic frictionless gas in a box conserves energy (1e6 steps)", "[energy][slow]") {
  // Same bound over ten times as many steps (~600 collisions per particle).
  CHECK(energy_drift(1000000) < 1e-4);
}

}  // namespace test_energy
