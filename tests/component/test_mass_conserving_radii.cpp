// mass_conserving_radii (physics/contact/mass_conserving_radii.hpp), on a sintering cluster run
// through the inertia-free path:
//  - the union of the grown spheres holds exactly the particles' volume (the closed-form lens of
//    two spheres, written out here, not the module's caps), at every step;
//  - the closed surface share equals sum h / (2R) of the radical-plane caps;
//  - growth is flow: it leaves every neck's elastic approach h - u_s as it was;
//  - dense particles (closed share at dense_closed_surface) stop their pairs' flow under the law's
//    stop_flow_at_dense, which refuses to run without the module that writes the flags.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <vector>

#include "engine/contact/contact_model.hpp"
#include "engine/core/error.hpp"
#include "engine/simulation.hpp"
#include "physics/contact/mass_conserving_radii.hpp"
#include "physics/contact/sintering.hpp"
#include "physics/thermal/expansion.hpp"
#include "support/free_pair.hpp"
#include "support/scene.hpp"

namespace test_mass_conserving_radii {

using namespace sparkdem;
using physics::MassConservingRadii;
using physics::Sintering;

namespace {

using test::free_pair::kR;
using test::free_pair::kRho;
constexpr double kPi = std::numbers::pi;

/// Volume of the lens two spheres (radii a, b, centres d apart, |a - b| < d < a + b) share:
/// V = pi (a + b - d)^2 (d^2 + 2 d (a + b) - 3 (a - b)^2) / (12 d)   (e.g. Weisstein, "Sphere-Sphere Intersection").
double lens(double a, double b, double d) {
  const double h = a + b - d;
  return kPi * h * h * (d * d + 2.0 * d * (a + b) - 3.0 * (a - b) * (a - b)) / (12.0 * d);
}

/// A 3 x 3 x 3 cube of spheres of radii 1-1.2 um, 1.85 um apart, each moved by up to 0.03 um per
/// axis: the 54 lattice edges overlap (d <= 1.96 um), no diagonal does (d >= 2.51 um, r_i + r_j
/// <= 2.4 um, 4 % of growth to spare), so no three spheres share a point.
State cluster() {
  State s;
  test::free_pair::add_cluster27(s, 1.85, 1.1, 0.1);
  return s;
}

Sintering::Params law_params(bool stop_at_dense = false) {
  Sintering::Params p = test::free_pair::law_params();
  p.neck = "intersection";
  p.stop_flow_at_dense = stop_at_dense;
  return p;
}

StageConfig qs_stage(Step steps) {
  StageConfig c = test::stage(1e-4, steps, 0.2 * kR);
  c.quasi_static = true;
  return c;
}

/// Overlapping pairs of the current radii (all pairs: a small scene).
struct Overlaps {
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  std::vector<double> d;
};
Overlaps overlaps(const ParticleStore& p) {
  Overlaps o;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = i + 1; j < p.size(); ++j)
      if (const double d = (p.position[i] - p.position[j]).norm(); d < p.radius[i] + p.radius[j]) {
        o.pairs.emplace_back(i, j);
        o.d.push_back(d);
      }
  return o;
}

/// |union of the spheres - sum of the free volumes| / sum of the free volumes.
double union_error(const ParticleStore& p) {
  const auto& g = p.fields.data(physics::thermal::kRadiusFactorField);
  double free = 0.0, un = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double r = p.radius[i] / g[i];
    free += 4.0 / 3.0 * kPi * r * r * r;
    un += 4.0 / 3.0 * kPi * p.radius[i] * p.radius[i] * p.radius[i];
  }
  const Overlaps o = overlaps(p);
  for (std::size_t k = 0; k < o.pairs.size(); ++k) un -= lens(p.radius[o.pairs[k].first], p.radius[o.pairs[k].second], o.d[k]);
  return std::abs(un - free) / free;
}

}  // namespace

TEST_CASE("Mass-conserving radii: the grown spheres of a sintering cluster hold exactly the particles' volume", "[sintering][quasi_static]") {
  // 10 steps of 1e-4 s of free sintering at 1500 K: the union (closed-form lens) equals the free
  // volume to the sweeps' tolerance at every step.
  State s = cluster();
  const ContactModelT<Sintering> law(law_params());
  MassConservingRadii growth({});
  Simulation sim(s, law);
  sim.add_module(&growth);
  double worst = 0.0, closed_err = 0.0, sweeps = 0.0;
  std::size_t pairs = 0;
  test::StepObserver obs([&](const State& st, Step) {
    const auto& p = st.particles;
    worst = std::max(worst, union_error(p));
    sweeps = std::max(sweeps, growth.column_values(st)[3]);
    const Overlaps o = overlaps(p);
    pairs = o.pairs.size();
    std::vector<double> closed(p.size(), 0.0);  // sum h / (2R), h = R - x on the radical plane
    for (std::size_t k = 0; k < o.pairs.size(); ++k) {
      const auto [i, j] = o.pairs[k];
      const double d = o.d[k], ri = p.radius[i], rj = p.radius[j];
      closed[i] += (ri - (d * d + ri * ri - rj * rj) / (2.0 * d)) / (2.0 * ri);
      closed[j] += (rj - (d * d + rj * rj - ri * ri) / (2.0 * d)) / (2.0 * rj);
    }
    const auto& field = p.fields.data(physics::thermal::kClosedSurfaceField);
    for (std::size_t i = 0; i < p.size(); ++i) closed_err = std::max(closed_err, std::abs(field[i] - closed[i]));
  });
  sim.run_stage(qs_stage(10), obs);
  double gmax = 0.0;
  for (double x : s.particles.fields.data(physics::thermal::kRadiusFactorField)) gmax = std::max(gmax, x);
  WARN("union / free volume - 1 at worst " << worst << ", largest growth " << gmax - 1.0 << ", closed-share error " << closed_err
                                           << ", at most " << sweeps << " sweeps");
  CHECK(pairs == 54);        // the precondition: no three spheres share a point
  CHECK(gmax - 1.0 > 1e-2);  // the particles grew
  CHECK(worst < 1e-10);
  CHECK(closed_err < 1e-12);
}

TEST_CASE("Mass-conserving radii: growth is flow, every neck's elastic approach stays as it was", "[sintering][quasi_static]") {
  // Five steps without the module (the lenses grow unredistributed), then one call grows the
  // particles at once: every neck's h - u_s and the law's approach rate (radius sum) unchanged.
  State s = cluster();
  const ContactModelT<Sintering> law(law_params());
  Simulation sim(s, law);
  test::NullObserver none;
  sim.run_stage(qs_stage(5), none);
  auto& p = s.particles;
  p.fields.declare({physics::thermal::kRadiusFactorField, 1, "1", 1.0, true}, p.size());
  p.fields.declare({physics::thermal::kClosedSurfaceField, 1, "1", 0.0, true}, p.size());
  p.fields.declare({physics::thermal::kDenseField, 1, "1", 0.0, true}, p.size());
  const ContactTable& t = s.contacts;
  const int us = t.column("viscous_approach"), rs = t.column("radius_sum"), neck = t.column("neck_radius");
  auto approach = [&](std::size_t r) {
    const Index i = t.i(r), j = t.j(r);
    return p.radius[i] + p.radius[j] - (p.position[i] - p.position[j]).norm() - t.state(r)[us];
  };
  std::vector<double> before, sum_before;
  for (std::size_t r = 0; r < t.size(); ++r) {
    before.push_back(approach(r));
    sum_before.push_back(t.state(r)[rs] - p.radius[t.i(r)] - p.radius[t.j(r)]);
  }
  const MassConservingRadii::Growth g = MassConservingRadii({}).grow(s);
  CHECK(g.capped == 0);
  CHECK(union_error(p) < 1e-10);
  std::size_t necks = 0;
  double worst = 0.0, grown = 0.0;
  for (std::size_t r = 0; r < t.size(); ++r) {
    if (!(t.state(r)[neck] > 0.0)) continue;
    ++necks;
    worst = std::max(worst, std::abs(approach(r) - before[r]));
    worst = std::max(worst, std::abs(t.state(r)[rs] - p.radius[t.i(r)] - p.radius[t.j(r)] - sum_before[r]));
  }
  for (double g : p.fields.data(physics::thermal::kRadiusFactorField)) grown = std::max(grown, g - 1.0);
  INFO(necks << " necks, largest change of an elastic approach or radius-sum offset " << worst << " m, largest growth " << grown);
  CHECK(necks == 54);
  CHECK(grown > 1e-3);
  CHECK(worst < 1e-15 * kR * 1e6);  // 1e-15 m: rounding of quantities of order 1e-6 m
}

TEST_CASE("Mass-conserving radii: dense particles stop their pairs' flow (stop_flow_at_dense), which needs the module", "[sintering][quasi_static]") {
  // With dense_closed_surface below every particle's closed share at the start, every particle is
  // dense from step 2 on (the module flags them at the end of step 1) and no pair flows. What still
  // moves is the elastic response to the driving force's end (the Hertz springs re-balanced one
  // linearised step at a time): measured from step 4 to 10 it is below 1e-3 of the flow without the stop.
  auto approach_after = [](bool stop, Step steps) {
    State s = cluster();
    const ContactModelT<Sintering> law(law_params(stop));
    MassConservingRadii::Params mp;
    mp.dense_closed_surface = 1e-6;
    MassConservingRadii growth(mp);
    Simulation sim(s, law);
    sim.add_module(&growth);
    std::vector<double> d1;
    double moved = 0.0, dense = 0.0;
    test::StepObserver obs([&](const State& st, Step n) {
      const auto& p = st.particles;
      std::vector<double> d;
      for (std::size_t i = 0; i + 1 < p.size(); ++i) d.push_back((p.position[i] - p.position[i + 1]).norm());
      if (n == 4) d1 = d;
      for (std::size_t k = 0; k < d.size() && !d1.empty(); ++k) moved = std::max(moved, std::abs(d[k] - d1[k]));
      dense = growth.column_values(st)[4];
    });
    sim.run_stage(qs_stage(steps), obs);
    CHECK(dense == 27.0);
    return moved;
  };
  const double stopped = approach_after(true, 10), flowing = approach_after(false, 10);
  INFO("largest change of a neighbour distance after step 4: " << stopped << " m stopped, " << flowing << " m flowing");
  CHECK(flowing > 1e-4 * kR);
  CHECK(stopped < 1e-3 * flowing);
  // The stop without the module that writes the flags: a set-up error naming the field.
  State s = cluster();
  const ContactModelT<Sintering> law(law_params(true));
  Simulation sim(s, law);
  test::NullObserver none;
  CHECK_THROWS_WITH(sim.run_stage(qs_stage(2), none), Catch::Contains("mass_conserving_radii/dense"));
  // Both stops at once: a configuration error naming the parameter.
  Sintering::Params both = law_params(true);
  both.creep_stop_gb_fraction = 0.9;
  CHECK_THROWS_WITH(Sintering(both), Catch::Contains("/stop_flow_at_dense"));
}

}  // namespace test_mass_conserving_radii
