// Extreme bond case (issue 9; docs/extreme_cases.md).
//
//  B1 a cohesive-beam domain loaded until every bond breaks: a 3 x 3 x 6 simple cubic block of
//     bonded elements under a kinematically imposed homogeneous expansion (every element its
//     own prescribed set moving at strain_rate x its position): every beam is stretched
//     axially at the same rate, so every one breaks at t_f = strength / (E strain_rate), in
//     axial mode; then the fragments coast with no bond left.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "engine/contact/bond_model.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "engine/simulation.hpp"
#include "engine/state/pair_transfer.hpp"
#include "engine/state/particle_set.hpp"
#include "physics/bonds/cohesive_beam.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "tests/extreme/extreme_figures.hpp"
#include "tests/support/scene.hpp"

namespace test_extreme_bonds {

using namespace sparkdem;
using physics::CohesiveBeam;

TEST_CASE("extreme B1: a cohesive-beam block loaded until every bond breaks", "[extreme][bonds]") {
  // Expectation: runs; all 117 bonds of the block break (closed-form count
  // (nx-1) ny nz + nx (ny-1) nz + nx ny (nz-1)), each in axial mode (1), each in the first step
  // whose end time reaches t_f = sigma / (E eps_dot) (exact kinematics: L = L0 (1 + eps_dot t));
  // the bonds' elastic energy is 0 afterwards; a second stage with no prescription and no bond
  // left runs on the contact law's stable step and the kinetic energy is unchanged (no contact:
  // the fragments separate), relative 1e-14.
  const double r = 1e-3, rho = 7800.0, E = 1e9, sigma = 1e6, eps_dot = 10.0;
  const int nx = 3, ny = 3, nz = 6;
  State s;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) test::add_sphere(s, Vec3(2 * r * i, 2 * r * j, 2 * r * k), r, rho);
  const std::size_t bonds = bond_within_gap(s, 1e-3 * r);
  const std::size_t expected = (nx - 1) * ny * nz + nx * (ny - 1) * nz + nx * ny * (nz - 1);
  REQUIRE(bonds == expected);
  CohesiveBeam::Params bp;
  bp.young_modulus = E;
  bp.poisson_ratio = 0.25;
  bp.radius_ratio = 0.5;
  bp.failure = "max_normal";
  bp.strength = sigma;
  const BondModelT<CohesiveBeam> bl(bp);
  physics::HertzMindlin::Params hp;
  hp.youngs_modulus = 1e9;
  const ContactModelT<physics::HertzMindlin> law(hp);
  Simulation sim(s, law, &bl);
  const Vec3 centre(2 * r, 2 * r, 5 * r);
  StageConfig load = test::stage(0.0, 0, 0.2 * r);
  for (std::size_t i = 0; i < s.particles.size(); ++i) {
    const std::string name = "p" + std::to_string(i);
    SetSelector sel;
    sel.kind = SetSelector::Kind::Ids;
    sel.ids = {s.particles.id[i]};
    assign_set(s, name, sel);
    load.prescribed_sets[name] = PrescribedMotion(eps_dot * (s.particles.position[i] - centre));
  }
  const double dt = 0.5 * sim.mechanical_stable_dt();
  const double t_f = sigma / (E * eps_dot);
  const auto n_f = static_cast<Step>(std::ceil(t_f / dt));
  load.dt = dt;
  load.max_steps = n_f + 20;
  load.log_every = 1;
  test::NullObserver none;
  sim.run_stage(load, none);
  CHECK(s.bonds.broken_count() == expected);
  CHECK(s.bonds.intact_count() == 0);
  std::size_t axial = 0, on_time = 0;
  double worst_dt = 0.0;
  for (std::size_t b = 0; b < s.bonds.size(); ++b) {
    const BondBreakRecord& rec = s.bonds.break_record(b);
    axial += rec.mode == 1;
    // The break happens in step n_f (time n_f dt) or, when t_f / dt is within round-off of an
    // integer, the next one.
    const double off = std::abs(rec.time - static_cast<double>(n_f) * dt);
    worst_dt = std::max(worst_dt, off / dt);
    on_time += off <= 1e-9 * dt || std::abs(rec.time - static_cast<double>(n_f + 1) * dt) <= 1e-9 * dt;
  }
  CHECK(axial == expected);
  CHECK(on_time == expected);
  CHECK(bl.elastic_energy(s.particles, s.bonds) == 0.0);
  // Coast: no bond, no prescription.
  auto ke = [&]() {
    double e = 0.0;
    for (std::size_t i = 0; i < s.particles.size(); ++i)
      e += 0.5 * s.particles.mass[i] * s.particles.velocity[i].squaredNorm() +
           0.5 * s.particles.inertia[i] * s.particles.omega[i].squaredNorm();
    return e;
  };
  const double k0 = ke();
  StageConfig coast = test::stage(0.0, 200, 0.2 * r);
  coast.dt_fraction = 0.5;
  const StageResult res = sim.run_stage(coast, none);
  CHECK(std::isfinite(res.stable_dt_at_start));
  CHECK(find_pairs_brute_force(s.particles.position, s.particles.radius, 0.0).empty());  // no pair touches
  CHECK(std::abs(ke() - k0) <= 1e-14 * k0);
  EXTREME_FIGURE("B1 every bond breaks", "bonds broken", static_cast<double>(s.bonds.broken_count()), "of " + std::to_string(expected));
  EXTREME_FIGURE("B1 every bond breaks", "breaks in axial mode", static_cast<double>(axial), "");
  EXTREME_FIGURE("B1 every bond breaks", "worst break time offset from n_f dt", worst_dt, "steps");
  EXTREME_FIGURE("B1 every bond breaks", "kinetic energy change while coasting", std::abs(ke() - k0) / k0, "");
}

}  // namespace test_extreme_bonds
