// Cohesive Euler–Bernoulli beam (issue 7; physics/bonds/cohesive_beam.hpp).
//
// Closed forms (to 1e-10 relative): a single beam under pure tension (F = E S dL / L0), pure
// torsion (M = G I0 phi / L0), one end turned (M_near = 4 E I a / L0, M_far = 2 E I a / L0,
// V = 6 E I a / L0^2), pure bending (uniform moment E I kappa); invariants: zero load under a rigid
// motion, zero total force and moment for any deformation (action = reaction), the forces are
// minus the gradient of the elastic energy; failure at the criterion's threshold with its mode.
// System test: a slender cantilever made of a line of bonded elements, clamped at one end, with a
// tip load, settles at the Euler–Bernoulli tip deflection P L^3 / (3 E I) (beams, quaternions and
// integrator together; the beam element is exact for an end load, so the band is the small-load
// geometric non-linearity and the residual motion: 1e-3).
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <random>

#include "engine/contact/bond_model.hpp"
#include "engine/simulation.hpp"
#include "engine/state/pair_transfer.hpp"
#include "engine/state/particle_set.hpp"
#include "physics/body/gravity.hpp"
#include "physics/bonds/cohesive_beam.hpp"
#include "physics/bonds/virial_failure.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "physics/mechanics/torsion_test.hpp"
#include "tests/support/scene.hpp"
#include "tests/support/tolerance.hpp"

namespace test_cohesive_beam {

using namespace sparkdem;
using physics::CohesiveBeam;

namespace {

constexpr double kR = 1e-3;  // element radius [m]
constexpr double kE = 1e9;   // beam Young's modulus [Pa]
constexpr double kNu = 0.25;
constexpr double kRatio = 0.5;
constexpr double kRho = 7800.0;
const double kPi = std::numbers::pi;

CohesiveBeam::Params beam_params(const std::string& failure = "none", double strength = std::numeric_limits<double>::infinity()) {
  CohesiveBeam::Params p;
  p.young_modulus = kE;
  p.poisson_ratio = kNu;
  p.radius_ratio = kRatio;
  p.failure = failure;
  p.strength = strength;
  return p;
}

/// Two touching elements along x, bonded; returns the state (bond row 0).
State bonded_pair() {
  State s;
  test::add_sphere(s, Vec3(0, 0, 0), kR, kRho);
  test::add_sphere(s, Vec3(2 * kR, 0, 0), kR, kRho);
  s.bonds.add(0, 1, s.particles.id, s.particles.position, s.particles.orientation);
  return s;
}

BondForces evaluate(const State& s, const CohesiveBeam& law) {
  return law(detail::bond_geometry(s.particles, s.bonds, 0), BondMotion{}, 0.0, nullptr);
}

const double L0 = 2 * kR, rmu = kRatio * kR, S = kPi * rmu * rmu, I = kPi * std::pow(rmu, 4) / 4, I0 = 2 * I, G = kE / (2 * (1 + kNu));

Quat about(const Vec3& axis, double angle) { return Quat(Eigen::AngleAxisd(angle, axis.normalized())); }

}  // namespace

TEST_CASE("cohesive beam: pure tension, torsion and bending match the Euler-Bernoulli closed forms to 1e-10", "[beam][bonds]") {
  const CohesiveBeam law(beam_params());
  SECTION("tension: F = E S dL / L0 along the axis, no moments") {
    State s = bonded_pair();
    const double d = 1e-6;
    s.particles.position[1].x() += d;
    const BondForces f = evaluate(s, law);
    CHECK(test::relative_error(f.force.x(), kE * S * d / L0) < 1e-10);  // on i, towards j
    CHECK(std::abs(f.force.y()) + std::abs(f.force.z()) < 1e-12 * kE * S * d / L0);
    CHECK(f.torque_i.norm() == 0.0);
    CHECK(f.torque_j.norm() == 0.0);
  }
  SECTION("torsion: M = G I0 phi / L0 about the axis, opposite on the two ends, no force") {
    State s = bonded_pair();
    const double phi = 1e-3;
    s.particles.orientation[1] = about(Vec3::UnitX(), phi);
    const BondForces f = evaluate(s, law);
    const double m = G * I0 * phi / L0;
    CHECK(test::relative_error(f.torque_j.x(), -m) < 1e-10);
    CHECK(test::relative_error(f.torque_i.x(), m) < 1e-10);
    CHECK(f.torque_j.tail<2>().norm() < 1e-12 * m);
    CHECK(f.force.norm() < 1e-12 * m / L0);
  }
  SECTION("one end turned by a: M_j = -4 E I a / L0, M_i = -2 E I a / L0, shear V = 6 E I a / L0^2") {
    State s = bonded_pair();
    const double a = 1e-3;
    s.particles.orientation[1] = about(Vec3::UnitZ(), a);
    const BondForces f = evaluate(s, law);
    CHECK(test::relative_error(f.torque_j.z(), -4 * kE * I * a / L0) < 1e-10);
    CHECK(test::relative_error(f.torque_i.z(), -2 * kE * I * a / L0) < 1e-10);
    CHECK(test::relative_error(f.force.y(), -6 * kE * I * a / (L0 * L0)) < 1e-10);  // on i; on j +V
    CHECK(std::abs(f.force.x()) < 1e-12 * std::abs(f.force.y()));
  }
  SECTION("pure bending: ends turned by -a and +a carry the uniform moment E I kappa, kappa = 2a / L0, and no force") {
    State s = bonded_pair();
    const double a = 1e-3;
    s.particles.orientation[0] = about(Vec3::UnitZ(), -a);
    s.particles.orientation[1] = about(Vec3::UnitZ(), a);
    const BondForces f = evaluate(s, law);
    const double M = kE * I * 2 * a / L0;
    CHECK(test::relative_error(f.torque_i.z(), M) < 1e-10);
    CHECK(test::relative_error(f.torque_j.z(), -M) < 1e-10);
    CHECK(f.force.norm() < 1e-12 * M / L0);
    // energy of pure bending: M^2 L0 / (2 E I)
    CHECK(test::relative_error(law.energy(detail::bond_geometry(s.particles, s.bonds, 0), nullptr), M * M * L0 / (2 * kE * I)) < 1e-10);
  }
}

TEST_CASE("cohesive beam: rigid motions load nothing, any deformation is balanced, forces are -grad U", "[beam][bonds]") {
  const CohesiveBeam law(beam_params());
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto rvec = [&]() { return Vec3(u(rng), u(rng), u(rng)); };
  for (int trial = 0; trial < 20; ++trial) {
    State s = bonded_pair();
    // Rigid motion: a rotation about a random axis through a random point, plus a translation.
    const Quat R = about(rvec(), 3.0 * u(rng));
    const Vec3 c = rvec() * kR, t = rvec() * kR;
    for (std::size_t k = 0; k < 2; ++k) {
      s.particles.position[k] = c + R * (s.particles.position[k] - c) + t;
      s.particles.orientation[k] = R * s.particles.orientation[k];
    }
    BondForces f = evaluate(s, law);
    const double scale = kE * S * 1e-6 / L0;  // the load of a 1e-6 m stretch
    CHECK(f.force.norm() < 1e-9 * scale);
    CHECK(f.torque_i.norm() + f.torque_j.norm() < 1e-9 * scale * L0);
    // Then a random small deformation: total force zero by construction, total moment about
    // the origin zero (action = reaction for moments).
    s.particles.position[1] += 1e-5 * kR * rvec();
    s.particles.orientation[0] = about(rvec(), 1e-3 * u(rng)) * s.particles.orientation[0];
    s.particles.orientation[1] = about(rvec(), 1e-3 * u(rng)) * s.particles.orientation[1];
    f = evaluate(s, law);
    const Vec3 M = s.particles.position[0].cross(f.force) + s.particles.position[1].cross(-f.force) + f.torque_i + f.torque_j;
    CHECK(M.norm() < 1e-12 * (f.force.norm() * L0 + f.torque_i.norm() + f.torque_j.norm()));
    // Force on j = -dU/dx_j by central differences (the co-rotational forces are the energy
    // gradient to first order in the rotations, here 1e-3 rad).
    const auto U = [&](const State& st) { return law.energy(detail::bond_geometry(st.particles, st.bonds, 0), nullptr); };
    const double h = 1e-9 * kR;
    for (int d = 0; d < 3; ++d) {
      State a = s, b = s;
      a.particles.position[1][d] += h;
      b.particles.position[1][d] -= h;
      const double grad = (U(a) - U(b)) / (2 * h);
      CHECK(std::abs(-grad - (-f.force[d])) < 2e-3 * f.force.norm());
    }
  }
}

TEST_CASE("cohesive beam: each criterion breaks at its threshold with its mode", "[beam][bonds][failure]") {
  const double d = 1e-6, sigma_a = kE * d / L0;  // axial stress of a 1e-6 m stretch
  SECTION("max_normal under tension: breaks at sigma_a, mode axial") {
    State s = bonded_pair();
    s.particles.position[1].x() += d;
    CHECK_FALSE(evaluate(s, CohesiveBeam(beam_params("max_normal", sigma_a * (1 + 1e-9)))).broken);
    const BondForces f = evaluate(s, CohesiveBeam(beam_params("max_normal", sigma_a * (1 - 1e-9))));
    CHECK(f.broken);
    CHECK(f.mode == 1);
  }
  SECTION("max_normal ignores compression and torsion") {
    State s = bonded_pair();
    s.particles.position[1].x() -= d;
    s.particles.orientation[1] = about(Vec3::UnitX(), 0.1);
    CHECK_FALSE(evaluate(s, CohesiveBeam(beam_params("max_normal", 1.0))).broken);
  }
  SECTION("von Mises and Tresca under torsion: sqrt(3) tau and 2 tau, mode torsion") {
    State s = bonded_pair();
    const double phi = 1e-3;
    s.particles.orientation[1] = about(Vec3::UnitX(), phi);
    const double tau = G * rmu * phi / L0;
    const auto check = [&](const std::string& crit, double eq) {
      CHECK_FALSE(evaluate(s, CohesiveBeam(beam_params(crit, eq * (1 + 1e-9)))).broken);
      const BondForces f = evaluate(s, CohesiveBeam(beam_params(crit, eq * (1 - 1e-9))));
      CHECK(f.broken);
      CHECK(f.mode == 3);
    };
    check("von_mises", std::sqrt(3.0) * tau);
    check("tresca", 2.0 * tau);
  }
  SECTION("bending: the end stress 2 E r (2 theta_k + theta_k') / L0, mode bending") {
    State s = bonded_pair();
    const double a = 1e-3;
    s.particles.orientation[1] = about(Vec3::UnitZ(), a);  // theta_j = a: end j carries 2 a
    const double sb = 2 * kE * rmu * 2 * a / L0;
    CHECK_FALSE(evaluate(s, CohesiveBeam(beam_params("max_normal", sb * (1 + 1e-9)))).broken);
    const BondForces f = evaluate(s, CohesiveBeam(beam_params("max_normal", sb * (1 - 1e-9))));
    CHECK(f.broken);
    CHECK(f.mode == 2);
  }
}

TEST_CASE("a cantilever of bonded elements under a tip load settles at P L^3 / (3 E I)", "[beam][bonds][system]") {
  constexpr int kN = 11;  // 10 beams
  State s;
  for (int k = 0; k < kN; ++k) test::add_sphere(s, Vec3(2 * kR * k, 0, 0), kR, kRho);
  const std::size_t made = bond_within_gap(s, 1e-3 * kR);
  REQUIRE(made == kN - 1);
  test::id_set(s, "clamp", {s.particles.id[0]});
  test::id_set(s, "tip", {s.particles.id[kN - 1]});
  const double L = 2 * kR * (kN - 1);
  const double P = 1e-5;  // [N]; deflection ~1e-4 L: linear regime
  const double expected = P * L * L * L / (3 * kE * I);

  physics::HertzMindlin::Params hp;
  hp.youngs_modulus = kE;
  ContactModelT<physics::HertzMindlin> contact(hp);
  BondModelT<CohesiveBeam> bonds(beam_params());
  Simulation sim(s, contact, &bonds);
  physics::AddForce::Params fp;
  fp.set = "tip";
  fp.force = Vec3(0, -P, 0);
  physics::AddForce load(fp);
  physics::LocalDamping damping({0.7});
  sim.add_module(&load);
  sim.add_module(&damping);  // last: acts on the net force
  StageConfig c = test::stage(0.0, 200000);
  c.dt_fraction = 0.5;
  c.prescribed_sets["clamp"] = PrescribedMotion{};
  test::NullObserver obs;
  sim.run_stage(c, obs);
  const Index t = test::local_index(s.particles, s.particles.id.back());
  (void)t;
  double tip_y = 0.0, speed = 0.0;
  for (std::size_t i = 0; i < s.particles.size(); ++i) {
    if (std::abs(s.particles.position[i].x() - L) < 0.5 * kR) tip_y = s.particles.position[i].y();
    speed = std::max(speed, s.particles.velocity[i].norm());
  }
  INFO("tip deflection " << -tip_y << " m, Euler-Bernoulli " << expected << " m, max speed " << speed);
  CHECK(test::relative_error(-tip_y, expected) < 1e-3);
}

TEST_CASE("torsion_test on a twisted chain of beams: twist = w t, torque = G I0 theta / L of the beams in series",
          "[beam][bonds][torsion]") {
  // A line of elements along the z axis: the bottom one clamped, the top one turned about the
  // axis at w. The beams twist in series (no bending: the axis does not move), so at rest the
  // torque is G_mu I0 theta / ((N - 1) L0) exactly; torsion_test's elastic reference with
  // G = G_mu, r = r_mu and L = the end-set distance must give a torque ratio of 1.
  constexpr int kN = 6;
  State s;
  for (int k = 0; k < kN; ++k) test::add_sphere(s, Vec3(0, 0, 2 * kR * k), kR, kRho);
  REQUIRE(bond_within_gap(s, 1e-3 * kR) == kN - 1);
  test::id_set(s, "bottom", {s.particles.id[0]});
  test::id_set(s, "top", {s.particles.id[kN - 1]});

  physics::HertzMindlin::Params hp;
  ContactModelT<physics::HertzMindlin> contact(hp);
  BondModelT<CohesiveBeam> bonds(beam_params());
  Simulation sim(s, contact, &bonds);
  physics::LocalDamping damping({0.7});
  physics::TorsionTest::Params tp;
  tp.clamped = "bottom";
  tp.twisted = "top";
  tp.radius = rmu;
  tp.shear_modulus = G;
  tp.yield_shear_stress = 1e9;
  tp.resistance_signal = "";
  physics::TorsionTest torsion(tp);
  sim.add_module(&damping);
  sim.add_module(&torsion);
  const double w = 10.0;  // [rad/s]
  StageConfig turn = test::stage(0.0, 2000);
  turn.dt_fraction = 0.5;
  turn.prescribed_sets["bottom"] = PrescribedMotion{};
  PrescribedMotion m;
  m.angular_velocity = Vec3(0, 0, w);
  turn.prescribed_sets["top"] = m;
  test::NullObserver obs;
  const StageResult r1 = sim.run_stage(turn, obs);
  // Then hold the twist and let the chain settle.
  StageConfig hold = test::stage(r1.dt, 200000);
  hold.prescribed_sets["bottom"] = PrescribedMotion{};
  hold.prescribed_sets["top"] = PrescribedMotion{};
  sim.run_stage(hold, obs);
  std::vector<std::string> cols;
  std::vector<double> vals;
  sim.sample(cols, vals);
  auto col = [&](const std::string& n) { return vals[static_cast<std::size_t>(std::find(cols.begin(), cols.end(), n) - cols.begin())]; };
  const double theta = w * r1.simulated_time;
  CHECK(test::relative_error(col("torsion_twist"), theta) < 1e-10);
  const double expected = G * I0 * theta / ((kN - 1) * L0);
  INFO("torque " << col("torsion_torque") << " N m, twisted end " << col("torsion_torque_twisted_end") << ", closed form " << expected);
  CHECK(test::relative_error(col("torsion_torque"), expected) < 1e-6);
  CHECK(test::relative_error(col("torsion_torque_twisted_end"), expected) < 1e-6);
  CHECK(std::abs(col("torsion_torque_ratio") - 1.0) < 1e-6);
  // the top element stays on the axis and was turned rigidly: its position did not drift
  CHECK((s.particles.position[kN - 1] - Vec3(0, 0, 2 * kR * (kN - 1))).norm() < 1e-12 * kR);
}

TEST_CASE("cohesive beam stable step: below the stability limit measured by bisection, and not far below", "[beam][bonds][stability]") {
  // Two free elements joined by a beam, every mode excited (random velocities and spins); a
  // step is stable when the energy stays bounded over 20,000 steps. The 12-dof eigenproblem of
  // this pair gives 2 / omega_max = 1.23 x our Gershgorin estimate (numpy, see bond_model.hpp).
  auto energy_growth = [](double dt) {
    State s = bonded_pair();
    std::mt19937_64 rng(3);
    std::normal_distribution<double> n(0.0, 1.0);
    for (std::size_t k = 0; k < 2; ++k) {
      s.particles.velocity[k] = 1e-3 * Vec3(n(rng), n(rng), n(rng));
      s.particles.omega[k] = 1e-3 / kR * Vec3(n(rng), n(rng), n(rng));
    }
    physics::HertzMindlin::Params hp;
    ContactModelT<physics::HertzMindlin> contact(hp);
    BondModelT<CohesiveBeam> bonds(beam_params());
    Simulation sim(s, contact, &bonds);
    auto ke = [&]() {
      double e = 0.0;
      for (std::size_t k = 0; k < 2; ++k)
        e += 0.5 * s.particles.mass[k] * s.particles.velocity[k].squaredNorm() +
             0.5 * s.particles.inertia[k] * s.particles.omega[k].squaredNorm();
      return e;
    };
    const double e0 = ke();
    StageConfig c = test::stage(dt, 20000);
    c.allow_unstable_dt = true;
    c.blowup_speed = 1e30;
    test::NullObserver obs;
    try {
      sim.run_stage(c, obs);
    } catch (const std::exception&) { return std::numeric_limits<double>::infinity(); }
    const double e = ke() + bonds.elastic_energy(s.particles, s.bonds);
    return std::isfinite(e) ? e / e0 : std::numeric_limits<double>::infinity();
  };
  State s = bonded_pair();
  physics::HertzMindlin::Params hp;
  ContactModelT<physics::HertzMindlin> contact(hp);
  BondModelT<CohesiveBeam> bonds(beam_params());
  const double estimate = Simulation(s, contact, &bonds).mechanical_stable_dt();
  double lo = 0.5 * estimate, hi = 3.0 * estimate;  // stable, unstable
  REQUIRE(energy_growth(lo) < 2.0);
  REQUIRE(energy_growth(hi) > 100.0);
  for (int it = 0; it < 30; ++it) {
    const double mid = 0.5 * (lo + hi);
    (energy_growth(mid) < 10.0 ? lo : hi) = mid;
  }
  INFO("estimate " << estimate << " s, measured limit " << lo << " s, ratio " << estimate / lo);
  CHECK(estimate < lo);
  CHECK(estimate > 0.7 * lo);
  CHECK(energy_growth(0.9 * estimate) < 1.5);  // bounded energy at 0.9 of the estimate
}

namespace {
/// A 3 x 3 x 3 simple cubic lattice (spacing 2r) of bonded elements (54 bonds) stretched by e
/// along x, its bond forces filled by one pass of the beam law.
void stretched_lattice(State& s, double e) {
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y)
      for (int z = 0; z < 3; ++z) test::add_sphere(s, Vec3(2 * kR * x, 2 * kR * y, 2 * kR * z), kR, kRho);
  REQUIRE(bond_within_gap(s, 1e-3 * kR) == 54);
  for (auto& x : s.particles.position) x.x() *= 1.0 + e;
  s.bonds_active = true;
  BondModelT<CohesiveBeam> bonds(beam_params());
  s.bonds.prepare(s.particles.size());
  bonds.pass(s.particles, s.bonds, 0.0);
}
}  // namespace

TEST_CASE("bond_virial_failure: the Love-Weber hydrostatic stress of a stretched cubic lattice, and breaking at it",
          "[beam][bonds][failure]") {
  // A simple cubic lattice (spacing 2r) of bonded elements stretched by e along x only: every x
  // bond carries F = E S e (axial), the others nothing. An interior element has two x bonds with
  // lever L0 / 2 = r, so sigma_xx = 2 r F / V and sigma_h = sigma_xx / 3 (V = sphere / f_v).
  State s;
  const double e = 1e-4;
  stretched_lattice(s, e);
  const double fv = 0.6, F = kE * S * e, V = 4.0 / 3.0 * kPi * kR * kR * kR / fv;
  const std::vector<double> h = physics::bond_hydrostatic_stress(s.particles, s.bonds, fv);
  const Index centre = 13;  // (1, 1, 1)
  REQUIRE((s.particles.position[centre] - Vec3(2 * kR * (1 + e), 2 * kR, 2 * kR)).norm() < 1e-15);
  const double expected = 2.0 * kR * (1 + e) * F / V / 3.0;
  CHECK(test::relative_error(h[centre], expected) < 1e-10);
  // A threshold just below the centre's stress breaks exactly the bonds whose two ends average
  // above it, and logs them as hydrostatic.
  physics::BondVirialFailure mod({0.5 * (h[centre] + h[4]) * (1 - 1e-9), fv});
  mod.advance(s, StepInfo{1, 1e-6, 1e-6, 0});
  std::size_t expected_breaks = 0;
  for (std::size_t r = 0; r < s.bonds.size(); ++r)
    if (0.5 * (h[s.bonds.i(r)] + h[s.bonds.j(r)]) >= 0.5 * (h[centre] + h[4]) * (1 - 1e-9)) ++expected_breaks;
  CHECK(expected_breaks > 0);
  CHECK(s.bonds.broken_count() == expected_breaks);
  for (std::size_t r = 0; r < s.bonds.size(); ++r)
    if (s.bonds.broken(r)) CHECK(s.bonds.break_record(r).mode == kBreakModeHydrostatic);
}

TEST_CASE("bond_virial_failure, von Mises: the virial tensor of a stretched cubic lattice, closed-form von Mises values",
          "[beam][bonds][failure]") {
  // Closed forms: uniaxial diag(s, 0, 0) -> s; pure shear (tau off-diagonal, symmetric) -> sqrt(3) tau;
  // a hydrostatic tensor -> 0.
  Eigen::Matrix3d u = Eigen::Matrix3d::Zero();
  u(0, 0) = 7.0;
  CHECK(physics::von_mises_stress(u) == Approx(7.0).epsilon(1e-14));
  Eigen::Matrix3d t = Eigen::Matrix3d::Zero();
  t(0, 1) = t(1, 0) = 2.0;
  CHECK(physics::von_mises_stress(t) == Approx(2.0 * std::sqrt(3.0)).epsilon(1e-14));
  CHECK(physics::von_mises_stress(5.0 * Eigen::Matrix3d::Identity()) < 1e-14);
  // The stretched lattice of the hydrostatic test: the centre's tensor is sigma_xx = 2 r F / V only,
  // its trace / 3 is bond_hydrostatic_stress, and its von Mises stress is sigma_xx (uniaxial).
  State s;
  const double e = 1e-4;
  stretched_lattice(s, e);
  const double fv = 0.6, F = kE * S * e, V = 4.0 / 3.0 * kPi * kR * kR * kR / fv;
  const auto sig = physics::bond_virial_stress(s.particles, s.bonds, fv);
  const auto h = physics::bond_hydrostatic_stress(s.particles, s.bonds, fv);
  const Index centre = 13;
  const double sxx = 2.0 * kR * (1 + e) * F / V;
  CHECK(test::relative_error(sig[centre](0, 0), sxx) < 1e-10);
  CHECK(std::abs(sig[centre](1, 1)) + std::abs(sig[centre](2, 2)) + std::abs(sig[centre](0, 1)) < 1e-12 * sxx);
  for (std::size_t i = 0; i < s.particles.size(); ++i) CHECK(std::abs(sig[i].trace() / 3.0 - h[i]) <= 1e-12 * sxx);
  CHECK(test::relative_error(physics::von_mises_stress(sig[centre]), sxx) < 1e-10);
  // The module breaks exactly the bonds whose criterion reaches the threshold, logged as von Mises.
  const auto c = physics::bond_virial_criterion(s.particles, s.bonds, fv, true);
  const double thr = *std::max_element(c.begin(), c.end()) * (1 - 1e-9);
  std::size_t expected = 0;
  for (double x : c) expected += x >= thr;
  physics::BondVirialFailure mod({thr, fv, "von_mises"});
  mod.advance(s, StepInfo{1, 1e-6, 1e-6, 0});
  CHECK(expected > 0);
  CHECK(s.bonds.broken_count() == expected);
  for (std::size_t r = 0; r < s.bonds.size(); ++r)
    if (s.bonds.broken(r)) CHECK(s.bonds.break_record(r).mode == kBreakModeVirialVonMises);
}

}  // namespace test_cohesive_beam
