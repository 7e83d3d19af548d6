// The mechanical stable-step estimate against the limit measured by bisection (issue 23 item 4;
// docs/extreme_cases.md M2 holds the frictionless lattice with its linear analysis).
//
//  S1 random packing (64 spheres, radii +-10 %, relaxed in a box; Hooke springs), mu = 0: the estimate
//     lies below the bisected limit and below the exact limit 2 / sqrt(lambda_max) of the
//     assembled mass-weighted normal stiffness matrix (Eigen), and reaches 0.5 of it;
//  S2 the same packing with mu = 0.5 (tangential springs and rotations);
//  S3 a hot sintered cluster (persistent viscous necks, numerical dashpots);
//  S4 a cohesive-beam block (bond rows).
// Each bisection runs the scene for 3000 steps at a trial step: stable when the kinetic energy
// stays below 100 x its largest value at half the estimate (above the limit the top mode grows
// like (1 + 2 sqrt(eps))^n, e^60 after 3000 steps at eps = 1e-4: the threshold is sharp).
#include <catch2/catch.hpp>

#include <Eigen/Dense>

#include <cmath>
#include <functional>
#include <limits>
#include <random>

#include "engine/contact/bond_model.hpp"
#include "engine/contact/contact_model.hpp"
#include "engine/simulation.hpp"
#include "engine/state/pair_transfer.hpp"
#include "physics/bonds/cohesive_beam.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "physics/contact/hooke.hpp"
#include "physics/contact/sintering.hpp"
#include "tests/extreme/extreme_figures.hpp"
#include "tests/support/scene.hpp"

namespace test_stable_step {

using namespace sparkdem;

namespace {

/// A scene for the bisection: a fresh State, its laws and the neighbour skin [m].
struct StepScene {
  std::function<State()> make;
  const ContactModel* law = nullptr;
  const BondModel* bonds = nullptr;
  double skin = 0.0;
};

double kinetic_energy(const State& s) {
  const auto& p = s.particles;
  double e = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i)
    e += 0.5 * p.mass[i] * p.velocity[i].squaredNorm() + 0.5 * p.inertia[i] * p.omega[i].squaredNorm();
  return e;
}

/// Largest kinetic energy over `steps` steps at dt [J]; +inf when the run stops on a blow-up.
double peak_kinetic_energy(const StepScene& sc, double dt, Step steps) {
  State s = sc.make();
  Simulation sim(s, *sc.law, sc.bonds);
  double peak = kinetic_energy(s);
  test::StepObserver obs([&](const State& st, Step) { peak = std::max(peak, kinetic_energy(st)); });
  StageConfig c = test::stage(dt, steps, sc.skin);
  c.allow_unstable_dt = true;
  c.blowup_speed = 1e30;
  c.log_every = 10;
  try {
    sim.run_stage(c, obs);
  } catch (const std::exception&) { return std::numeric_limits<double>::infinity(); }
  return std::isfinite(peak) ? peak : std::numeric_limits<double>::infinity();
}

/// The estimate (ContactModel::stable_dt and its network part) of the scene's initial state,
/// with its contact rows built by a zero-step stage.
struct Estimate {
  double full = 0.0, network = 0.0;
};
Estimate estimate_of(const StepScene& sc) {
  State s = sc.make();
  Simulation sim(s, *sc.law, sc.bonds);
  test::NullObserver none;
  StageConfig c = test::stage(1e-18, 0, sc.skin);
  c.allow_unstable_dt = true;
  sim.run_stage(c, none);
  std::vector<double> rows(s.particles.size(), 0.0);
  if (sc.bonds) sc.bonds->add_stiffness_rows(s.particles, s.bonds, rows);
  const std::vector<double>* extra = sc.bonds ? &rows : nullptr;
  return {sim.mechanical_stable_dt(), sc.law->network_stable_dt(s.particles, s.contacts, s.walls, extra)};
}

/// The stability limit by bisection in [lo, hi] (lo stable, hi not), to 1e-4 relative.
double bisected_limit(const StepScene& sc, double estimate) {
  constexpr Step kSteps = 3000;
  const double ref = peak_kinetic_energy(sc, 0.5 * estimate, kSteps);
  REQUIRE(std::isfinite(ref));
  auto stable = [&](double dt) { return peak_kinetic_energy(sc, dt, kSteps) < 100.0 * ref; };
  double lo = 0.5 * estimate, hi = 16.0 * estimate;
  REQUIRE(!stable(hi));
  while (hi - lo > 1e-4 * lo) {
    const double mid = 0.5 * (lo + hi);
    (stable(mid) ? lo : hi) = mid;
  }
  return hi;
}

constexpr double kR = 1e-3, kRho = 2500.0;

physics::LinearSpringDashpot::Params hooke(double mu, double restitution = 1.0) {
  physics::LinearSpringDashpot::Params p;
  p.normal_stiffness = 1e6;
  p.restitution = restitution;
  p.friction = mu;
  return p;
}

/// A random packing of 64 spheres (radii uniform in [0.9, 1.1] kR) in a box: centres placed by
/// random sequential addition at radius / 1.25 (packing fraction 0.34, 0.66 at full size), then the spheres at full
/// size relaxed by a frictionless Hooke law with restitution 0.05 for 20,000 steps (contacts in
/// random directions at equilibrium); returned with random velocities of 1e-4 m/s. Built once.
State random_packing() {
  static const State relaxed = [] {
    State s;
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const double side = 7.4 * kR, shrink = 1.25;
    std::vector<Vec3> x;
    std::vector<double> r;
    while (x.size() < 64) {
      const double ri = kR * (0.9 + 0.2 * u(rng));
      const Vec3 c = Vec3(u(rng), u(rng), u(rng)) * (side - 2 * ri / shrink) + Vec3::Constant(ri / shrink);
      bool free = true;
      for (std::size_t k = 0; k < x.size() && free; ++k) free = (c - x[k]).norm() >= (ri + r[k]) / shrink;
      if (!free) continue;
      x.push_back(c);
      r.push_back(ri);
    }
    for (std::size_t k = 0; k < x.size(); ++k) test::add_sphere(s, x[k], r[k], kRho);
    test::add_box(s, Vec3::Zero(), Vec3::Constant(side));
    const ContactModelT<physics::LinearSpringDashpot> damped(hooke(0.0, 0.05));
    Simulation sim(s, damped);
    test::NullObserver none;
    StageConfig c = test::stage(0.2 * sim.mechanical_stable_dt(), 20000, 0.1 * kR);
    c.log_every = 1000;
    sim.run_stage(c, none);
    return s;
  }();
  State s = relaxed;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (auto& v : s.particles.velocity) v = 1e-4 * Vec3(u(rng), u(rng), u(rng));
  for (auto& w : s.particles.omega) w.setZero();
  return s;
}

/// Exact limit 2 / sqrt(lambda_max) of the normal springs of the state's closed contacts and
/// walls: the mass-weighted 3n x 3n matrix sum k_n e e^T, e = (n / sqrt(m_i), -n / sqrt(m_j)).
double linear_limit(State s, double kn) {
  const ContactModelT<physics::LinearSpringDashpot> law(hooke(0.0));
  Simulation sim(s, law);
  test::NullObserver none;
  StageConfig c = test::stage(1e-18, 0, 0.1 * kR);
  c.allow_unstable_dt = true;
  sim.run_stage(c, none);
  const auto& p = s.particles;
  const auto n = static_cast<Eigen::Index>(p.size());
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (std::size_t r = 0; r < s.contacts.size(); ++r) {
    const Index i = s.contacts.i(r), j = s.contacts.j(r);
    const Vec3 d = p.position[i] - p.position[j];
    if (d.norm() >= p.radius[i] + p.radius[j]) continue;
    const Vec3 e = d.normalized();
    const Eigen::Matrix3d b = kn * e * e.transpose();
    const double mi = p.mass[i], mj = p.mass[j];
    K.block<3, 3>(3 * i, 3 * i) += b / mi;
    K.block<3, 3>(3 * j, 3 * j) += b / mj;
    K.block<3, 3>(3 * i, 3 * j) -= b / std::sqrt(mi * mj);
    K.block<3, 3>(3 * j, 3 * i) -= b / std::sqrt(mi * mj);
  }
  for (std::size_t i = 0; i < p.size(); ++i)
    for (const Wall& w : s.walls) {
      Vec3 nrm;
      double dist;
      w.distance(p.position[i], nrm, dist);
      if (p.radius[i] - dist > 0.0) K.block<3, 3>(3 * i, 3 * i) += kn * nrm * nrm.transpose() / p.mass[i];
    }
  return 2.0 / std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(K).eigenvalues().maxCoeff());
}

void report(const char* scene, const Estimate& e, double limit) {
  INFO(scene << ": estimate " << e.full << " s (network " << e.network << " s), bisected limit " << limit << " s");
  CHECK(e.full <= e.network);
  CHECK(e.full < limit);
  CHECK(e.network < limit);
  EXTREME_FIGURE(scene, "stable-step estimate", e.full, "s");
  EXTREME_FIGURE(scene, "network estimate (no a-priori step)", e.network, "s");
  EXTREME_FIGURE(scene, "limit by bisection", limit, "s");
  EXTREME_FIGURE(scene, "estimate / limit", e.full / limit, "");
}

}  // namespace

TEST_CASE("stable step S1/S2: random Hooke packing, mu = 0 and 0.5 - estimate below the bisected and the exact limit",
          "[extreme][stability]") {
  // mu = 0: the tangential springs drop out (tangential_free) and the normal rows are exact per
  // axis; the estimate is >= 0.5 of the exact limit of the assembled matrix, which the bisection
  // reproduces within 1 %. mu = 0.5: the sticking tangential springs and rotations lower the true
  // limit; the estimate stays below it.
  const double kn = hooke(0.0).normal_stiffness;
  const ContactModelT<physics::LinearSpringDashpot> frictionless(hooke(0.0)), frictional(hooke(0.5));
  StepScene sc{random_packing, &frictionless, nullptr, 0.1 * kR};
  State s0 = random_packing();
  const double exact = linear_limit(s0, kn);
  const Estimate e0 = estimate_of(sc);
  const double lim0 = bisected_limit(sc, e0.full);
  report("S1 random packing mu = 0", e0, lim0);
  INFO("exact limit " << exact << " s");
  CHECK(std::abs(lim0 - exact) <= 0.01 * exact);
  CHECK(e0.full >= 0.5 * exact);
  EXTREME_FIGURE("S1 random packing mu = 0", "bisected / exact (assembled matrix)", lim0 / exact, "");
  sc.law = &frictional;
  const Estimate e1 = estimate_of(sc);
  const double lim1 = bisected_limit(sc, e1.full);
  report("S2 random packing mu = 0.5", e1, lim1);
  CHECK(lim1 <= lim0 * (1.0 + 1e-3));
}

TEST_CASE("stable step S3: hot sintered cluster with viscous necks - estimate below the bisected limit", "[extreme][stability]") {
  // 27 spheres (r = 1 um) overlapping 2 % of r at 1500 K: every pair gets a persistent neck of
  // at least 0.1 r at once; Maxwell dashpots and the numerical damping (ratio 0.3) act.
  const double r = 1e-6;
  physics::Sintering::Params p;
  p.youngs_modulus = 1e11;
  p.temperature = 1500.0;
  p.sintering_start_temperature = 1000.0;
  p.min_neck_fraction = 0.1;
  const ContactModelT<physics::Sintering> law(p);
  auto make = [r] {
    State s;
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k)
          test::add_sphere(s, 1.98 * r * Vec3(i, j, k) + 0.01 * r * Vec3(u(rng), u(rng), u(rng)), r, 5900.0,
                           1e-4 * Vec3(u(rng), u(rng), u(rng)));
    return s;
  };
  const StepScene sc{make, &law, nullptr, 0.2 * r};
  const Estimate e = estimate_of(sc);
  report("S3 hot sintered cluster", e, bisected_limit(sc, e.full));
}

TEST_CASE("stable step S4: cohesive-beam block - estimate below the bisected limit", "[extreme][stability]") {
  // A 3 x 3 x 3 block of touching spheres, every neighbour pair bonded (54 beams), random
  // velocities; the Hertz contacts carry nothing (zero overlap), the bonds set the limit.
  physics::CohesiveBeam::Params bp;
  bp.young_modulus = 1e9;
  bp.poisson_ratio = 0.25;
  bp.radius_ratio = 0.5;
  const BondModelT<physics::CohesiveBeam> bonds(bp);
  physics::HertzMindlin::Params hp;
  hp.youngs_modulus = 1e9;
  const ContactModelT<physics::HertzMindlin> law(hp);
  auto make = [] {
    State s;
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) test::add_sphere(s, 2 * kR * Vec3(i, j, k), kR, 7800.0, 1e-4 * Vec3(u(rng), u(rng), u(rng)));
    REQUIRE(bond_within_gap(s, 1e-3 * kR) == 54);
    return s;
  };
  const StepScene sc{make, &law, &bonds, 0.2 * kR};
  const Estimate e = estimate_of(sc);
  report("S4 cohesive-beam block", e, bisected_limit(sc, e.full));
}

}  // namespace test_stable_step
