// heat_conduction on a stiff network (issue 6, "Stability"): conductivity factors per set,
// the stiff scene of tests/support/thermal_network.hpp (conductance contrast 1e8, a 10 um sphere
// pressed against 1 mm ones), explicit on its adaptive substeps against implicit at 1e3 x the
// explicit stable step, the refusal of an explicit step above the bound and the caught blow-up
// with the override, and first-order convergence of both schemes.
//
// Closed forms: the modal solution of C dT/dt = -L T (exact, forward-Euler and backward-Euler
// recurrences) with L and C computed here from the geometry (Hertz a = sqrt(R* delta), G = 4 a
// lambda_i lambda_j / (lambda_i + lambda_j)), independently of the module.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>

#include "engine/core/error.hpp"
#include "engine/simulation.hpp"
#include "engine/state/particle_set.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "physics/thermal/heat_conduction.hpp"
#include "physics/thermal/thermal_kernels.hpp"
#include "tests/support/scene.hpp"
#include "tests/support/thermal_network.hpp"
#include "tests/support/tolerance.hpp"

namespace test_heat_stiff {

using namespace sparkdem;
using namespace sparkdem::physics;
using test::StiffScene;

namespace {

Eigen::VectorXd temperatures(const State& s) {
  const auto& T = s.particles.fields.data("temperature");
  return Eigen::Map<const Eigen::VectorXd>(T.data(), static_cast<Eigen::Index>(T.size()));
}

/// Runs the stiff scene for `steps` stage steps of `dt`; returns the temperatures and the stage result.
struct Run {
  Eigen::VectorXd T;
  StageResult res;
  double stable = 0.0;
  Id limiting = -1;
};
Run run_stiff(const std::string& scheme, double dt, Step steps, const Clock* clock = nullptr) {
  State s;
  StiffScene::build(s);
  HeatConduction heat(test::StiffScene::heat_params(scheme));
  if (clock) heat.set_clock(*clock);
  ContactModelT<HertzMindlin> law{HertzMindlin::Params{}};
  Simulation sim(s, law);
  sim.add_module(&heat);
  test::NullObserver obs;
  sim.run_stage(test::frozen_stage(dt, 0), obs);  // contact table of the packing
  Run r;
  r.stable = heat.stable_dt(s);
  r.limiting = heat.stable_dt_particle();
  r.res = sim.run_stage(test::frozen_stage(dt, steps), obs);
  r.T = temperatures(s);
  return r;
}

}  // namespace

TEST_CASE("heat_conduction: conductivity factors put the two sides of a branch in series", "[thermal][heat][stiff]") {
  // Two equal spheres (r = 100 um, overlap 1 um); sphere 1 has f lambda. Equal capacities, so the
  // stable step is 0.9 C / G, and the temperature difference relaxes with tau = C / (2 G).
  const double r = 1e-4, overlap = 1e-6, f = 0.01;
  const double C = StiffScene::capacity(r);
  for (const std::string model : {"batchelor_obrien", "transmission_surface"}) {
    DYNAMIC_SECTION(model) {
      State s;
      test::add_sphere(s, Vec3::Zero(), r, StiffScene::rho);
      test::add_sphere(s, Vec3(2 * r - overlap, 0, 0), r, StiffScene::rho);
      s.particles.fields.declare({"temperature", 1, "K", 0.0, true}, 2);
      s.particles.fields.data("temperature") = {400.0, 300.0};
      SetSelector sel;
      sel.kind = SetSelector::Kind::Ids;
      sel.ids = {1};
      assign_set(s, "other", sel);
      HeatConduction::Params hp = test::StiffScene::heat_params("implicit");
      hp.scheme = "explicit";
      hp.model = model;
      hp.alpha_constant = 4.0;  // transmission surface S = 4 r^2
      hp.conductivity_sets = "other";
      hp.conductivity_factors = {f};
      HeatConduction heat(hp);
      ContactModelT<HertzMindlin> law{HertzMindlin::Params{}};
      Simulation sim(s, law);
      sim.add_module(&heat);
      test::NullObserver obs;
      sim.run_stage(test::frozen_stage(1e-6, 0), obs);
      const double lam = StiffScene::lambda, harmonic = 2.0 * lam * f * lam / (lam + f * lam);
      const double G = model == "batchelor_obrien" ? 2.0 * harmonic * std::sqrt(0.5 * r * overlap)
                                                   : harmonic * 4.0 * r * r / (2 * r - overlap);
      CHECK(test::relative_error(heat.stable_dt(s), 0.9 * C / G) <= 1e-12);
    }
  }
  SECTION("one factor per set, positive") {
    HeatConduction::Params hp = test::StiffScene::heat_params("explicit");
    hp.conductivity_factors = {};
    CHECK_THROWS_AS(HeatConduction(hp), ConfigError);
    hp.conductivity_factors = {0.0};
    CHECK_THROWS_AS(HeatConduction(hp), ConfigError);
  }
}

TEST_CASE(
    "heat_conduction: stiff network (contrast 1e8, 10 um sphere on 1 mm ones): explicit on its substeps and implicit at "
    "1e3 x its step agree within the implicit scheme's error bound",
    "[thermal][heat][stiff]") {
  // The scene's numbers (closed forms from the geometry).
  CHECK(test::relative_error(StiffScene::g_ll() / StiffScene::g_ins(), 1e8) <= 1e-9);
  const double s_exp = StiffScene::explicit_stable_dt();
  const double C = StiffScene::capacity(StiffScene::R), Ct = StiffScene::capacity(StiffScene::r);
  CHECK(test::relative_error(s_exp, 0.9 * Ct / StiffScene::g_t()) <= 1e-12);  // the tiny sphere sets it
  // Stage step H = 1000 x the explicit stable step (just below, so that k = 1000 substeps);
  // 20 steps: t = 3.16 s, about half the chain's slowest relaxation time C / G_ll = 5.5 s.
  const double H = 1000.0 * s_exp * (1.0 - 1e-9);
  const Step M = 20;
  const double t = static_cast<double>(M) * H;
  const Run ex = run_stiff("explicit", H, M);
  const Run im = run_stiff("implicit", H, M);
  CHECK(test::relative_error(ex.stable, s_exp) <= 1e-12);
  CHECK(ex.limiting == StiffScene::T);
  CHECK(ex.res.max_substeps.at("heat_conduction") == 1000);
  CHECK(ex.res.module_calls.at("heat_conduction") == 1000 * M);
  CHECK(im.res.module_calls.at("heat_conduction") == M);

  const test::ModalSolution modal(StiffScene::laplacian(), StiffScene::capacities());
  const Eigen::VectorXd T0 = StiffScene::initial();
  const Eigen::VectorXd exact = modal.exact(T0, t);
  const Eigen::VectorXd fe = modal.forward_euler(T0, H / 1000.0, 1000.0 * M);
  const Eigen::VectorXd be = modal.backward_euler(T0, H, static_cast<double>(M));
  INFO("explicit  T = " << ex.T.transpose() << " K (" << 1000 * M << " substeps of " << H / 1000.0 << " s)");
  INFO("implicit  T = " << im.T.transpose() << " K (" << M << " steps of " << H << " s)");
  INFO("exact     T = " << exact.transpose() << " K at t = " << t << " s");
  // 1) Each scheme reproduces its own recurrence (round-off over 2e4 steps: 1e-9 K on 200 K).
  CHECK((ex.T - fe).cwiseAbs().maxCoeff() <= 1e-9);
  CHECK((im.T - be).cwiseAbs().maxCoeff() <= 1e-9);
  // 2) The 1e8-contrast branch carries its heat: L3 warms by (G_ins / C) int_0^t (T2 - T3) dt
  //    = 3.7e-8 K (T3 - 300 K stays below 1e-7 K, 1e-8 of T2 - 300 K: dropped). The integral of
  //    T2 comes from the modal solution (L3's own modal value is not usable at this level: the
  //    eigen-decomposition's absolute error, eps x 5.7e3 1/s, is 1e-3 of the weak coupling
  //    G_ins / C = 1.8e-9 1/s). Explicit: left Riemann sum of a monotone integrand on h, error
  //    <= h (T2(t) - T2(0)) / int = 1.3e-4 (band 1e-3); implicit: right sum on H, error <= 0.13
  //    (H x 16 K / 20 K s) plus the BE error of T2 (band 0.15).
  const double rise_exact = StiffScene::g_ins() / C * (modal.integral(T0, t)[StiffScene::L2] - 300.0 * t);
  INFO("L3 rise: reference " << rise_exact << " K, explicit " << ex.T[StiffScene::L3] - 300.0 << " K, implicit "
                             << im.T[StiffScene::L3] - 300.0 << " K, modal " << exact[StiffScene::L3] - 300.0 << " K");
  CHECK(rise_exact > 3e-8);
  CHECK(rise_exact < 5e-8);
  CHECK(std::abs(ex.T[StiffScene::L3] - 300.0 - rise_exact) <= 1e-3 * rise_exact);
  CHECK(std::abs(im.T[StiffScene::L3] - 300.0 - rise_exact) <= 0.15 * rise_exact);
  // 3) The large spheres: |T_BE - T| <= E_M sum_k |mode k| (the BE bound), the explicit error is
  //    far below it, so explicit and implicit agree within bound + explicit error.
  const double E = test::be_mode_error_bound(static_cast<double>(M));
  const Eigen::VectorXd amp = modal.modal_amplitude(T0);
  for (int i : {StiffScene::L0, StiffScene::L1, StiffScene::L2}) {
    const double bound = E * amp[i];
    INFO("sphere L" << i << ": |implicit - exact| = " << std::abs(im.T[i] - exact[i]) << " K <= bound " << bound
                    << " K; |explicit - exact| = " << std::abs(ex.T[i] - exact[i])
                    << " K; |explicit - implicit| = " << std::abs(ex.T[i] - im.T[i]) << " K");
    CHECK(std::abs(im.T[i] - exact[i]) <= bound);
    CHECK(std::abs(ex.T[i] - exact[i]) <= 0.01 * bound);  // FE error ~ (h / H) x the BE error
    CHECK(std::abs(ex.T[i] - im.T[i]) <= 1.001 * bound);
    CHECK(bound <= 2.0);  // a band of at most 2 K on a 200 K excursion (E_20 = 1.3 %)
  }
  // Energy (sum C_i T_i) is conserved by both to round-off.
  const Eigen::VectorXd Cv = StiffScene::capacities();
  CHECK(test::relative_error(Cv.dot(ex.T), Cv.dot(T0)) <= 1e-13);
  CHECK(test::relative_error(Cv.dot(im.T), Cv.dot(T0)) <= 1e-13);
}

TEST_CASE(
    "heat_conduction: on the stiff network an explicit step above the bound is refused, and the override's blow-up "
    "names the step, the tiny sphere and the temperature",
    "[thermal][heat][stiff]") {
  const double s_exp = StiffScene::explicit_stable_dt();
  Clock one;
  one.kind = Clock::Kind::EveryStep;
  State s;
  StiffScene::build(s);
  HeatConduction heat(test::StiffScene::heat_params("explicit"));
  heat.set_clock(one);  // a fixed clock: the stage step is the module's step
  ContactModelT<HertzMindlin> law{HertzMindlin::Params{}};
  Simulation sim(s, law);
  sim.add_module(&heat);
  test::NullObserver obs;
  sim.run_stage(test::frozen_stage(1e-9, 0), obs);
  const double H = 1000.0 * s_exp;
  try {
    sim.run_stage(test::frozen_stage(H, 5), obs);
    FAIL("the step above the stable one was accepted");
  } catch (const SetupError& e) {
    const std::string what = e.what();
    INFO(what);
    CHECK(what.find("heat_conduction") != std::string::npos);
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", s_exp);  // the stable step 1.58e-4 s, printed with 6 digits
    CHECK(what.find(std::string("above its stable step ") + buf) != std::string::npos);
  }
  // 1.5 x the stable step (1.35 x the Gershgorin bound): refused too.
  CHECK_THROWS_AS(sim.run_stage(test::frozen_stage(1.5 * s_exp, 5), obs), SetupError);
  StageConfig over = test::frozen_stage(2.5 * s_exp, 200);
  over.allow_unstable_dt = true;
  try {
    sim.run_stage(over, obs);
    FAIL("the unstable run was not stopped");
  } catch (const PhysicsError& e) {
    const std::string what = e.what();
    INFO(what);
    CHECK(e.quantity() == "temperature");
    CHECK(e.step() > 0);
    CHECK(e.step() <= 200);
    REQUIRE(!e.ids().empty());
    CHECK(e.ids().front() == StiffScene::T);  // the tiny sphere: amplification 1 - 2.5 x 0.9 = -1.25 per step
    CHECK(what.find("set by particle id 4") != std::string::npos);
  }
}

TEST_CASE("heat_conduction: first-order convergence of both schemes on the stiff network (error ratio 2 when halving the step)",
          "[thermal][heat][stiff]") {
  // Error at t = 20 x 1000 x s_exp against the exact modal solution, max over the large spheres.
  const double s_exp = StiffScene::explicit_stable_dt();
  const test::ModalSolution modal(StiffScene::laplacian(), StiffScene::capacities());
  const Eigen::VectorXd T0 = StiffScene::initial();
  auto err = [&](const Eigen::VectorXd& T, double t) {
    const Eigen::VectorXd e = modal.exact(T0, t);
    return std::max({std::abs(T[0] - e[0]), std::abs(T[1] - e[1]), std::abs(T[2] - e[2])});
  };
  const double t = 20.0 * 1000.0 * s_exp;
  Clock one;
  one.kind = Clock::Kind::EveryStep;
  SECTION("implicit at 1000 and 500 x the explicit stable step") {
    const Run a = run_stiff("implicit", 1000.0 * s_exp, 20), b = run_stiff("implicit", 500.0 * s_exp, 40);
    const double ea = err(a.T, t), eb = err(b.T, t);
    INFO("errors " << ea << " K, " << eb << " K");
    // BE error = c1 dt + O(dt^2): the ratio is 2 (1 + O(lambda dt)); lambda_chain dt = 0.03-0.08 here.
    CHECK(ea / eb >= 1.9);
    CHECK(ea / eb <= 2.1);
  }
  SECTION("explicit at 1 and 0.5 x its stable step") {
    const double h = s_exp * (1.0 - 1e-12);
    const Run a = run_stiff("explicit", h, 20000, &one), b = run_stiff("explicit", 0.5 * h, 40000, &one);
    const double ea = err(a.T, 20000 * h), eb = err(b.T, 20000 * h);
    INFO("errors " << ea << " K, " << eb << " K");
    CHECK(ea / eb >= 1.98);
    CHECK(ea / eb <= 2.02);
  }
}

}  // namespace test_heat_stiff
