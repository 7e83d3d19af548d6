/// temperature_history: the prescribed T(t) in physical time and the thermal expansion of the
/// radii r = r_ref (1 + alpha (T - T0)) as a function of T (never compounded), across stages.
#include <catch2/catch.hpp>

#include <cmath>
#include <map>
#include <vector>

#include "engine/core/error.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "physics/thermal/temperature_history.hpp"
#include "support/scene.hpp"
#include "support/tolerance.hpp"

namespace test_temperature_history {

using namespace sparkdem;
using physics::TemperatureHistory;

namespace {

/// Closed form of the table used below: 300 K, +10 K/s to 1300 K at 100 s, -2.5 K/s to 800 K
/// at 300 s, then held.
double table_T(double t) {
  if (t <= 0.0) return 300.0;
  if (t <= 100.0) return 300.0 + 10.0 * t;
  if (t <= 300.0) return 1300.0 - 2.5 * (t - 100.0);
  return 800.0;
}

/// Four separated spheres of different radii (no contacts, no walls).
State separated_spheres() {
  State s;
  const double r[] = {1.0e-3, 0.7e-3, 1.3e-3, 0.9e-3};
  for (int k = 0; k < 4; ++k) test::add_sphere(s, Vec3(0.01 * k, 0.0, 0.0), r[k], 2500.0);
  return s;
}

ContactModelT<physics::HertzMindlin> soft_law() {
  physics::HertzMindlin::Params lp;
  lp.youngs_modulus = 1e7;
  return ContactModelT<physics::HertzMindlin>(lp);
}

}  // namespace

TEST_CASE("temperature_history follows its table in physical time with time_scale 1e5", "[thermal][modules]") {
  // dt = 1e-6 s mechanical, time_scale = 1e5: 0.1 physical seconds per step, so 4000 steps
  // cover the whole table (400 s) and the held end. At every step the field equals the closed
  // form at t_phys = 1e5 * k * 1e-6 s to 1e-12 relative (the time is rounded, not the table).
  State s = separated_spheres();
  TemperatureHistory::Params p;
  p.time = {0.0, 100.0, 300.0};
  p.temperature = {300.0, 1300.0, 800.0};
  TemperatureHistory th(p);
  auto law = soft_law();
  Simulation sim(s, law);
  sim.add_module(&th);
  StageConfig cfg = test::stage(1e-6, 4000, 1e-4);
  cfg.time_scale = 1e5;
  sim.prepare(cfg);
  for (double T : s.particles.fields.data("temperature")) CHECK(T == 300.0);  // T(0) before the first force pass
  double worst = 0.0, worst_column = 0.0;
  Step seen = 0;
  test::StepObserver obs([&](const State& st, Step k) {
    const double t_phys = 1e5 * (static_cast<double>(k) * 1e-6);
    CHECK(test::relative_error(st.physical_time, t_phys) <= 1e-12);
    for (double T : st.particles.fields.data("temperature")) worst = std::max(worst, test::relative_error(T, table_T(t_phys)));
    worst_column = std::max(worst_column, test::relative_error(th.column_values(st).at(0), table_T(t_phys)));
    ++seen;
  });
  sim.run_stage(cfg, obs);
  CHECK(seen == 4000);
  INFO("largest relative deviation from the table: " << worst);
  CHECK(worst <= 1e-12);
  CHECK(worst_column <= 1e-12);
  CHECK(s.particles.fields.data("temperature")[0] == 800.0);  // held beyond the last point
  // Without thermal expansion the radii are not touched and no reference field exists.
  CHECK_FALSE(s.particles.fields.has("radius_ref"));
  CHECK(s.particles.radius[0] == 1.0e-3);
}

TEST_CASE("thermal expansion is a function of T: no drift after 40 heating and cooling cycles", "[thermal][modules]") {
  // T oscillates 300 K <-> 1500 K 40 times (alpha = 1.5e-5 1/K, T0 = 293.15 K: +1.8 % radius at
  // the top). Every step: r_i = r_ref,i (1 + alpha (T - T0)) to 1e-15 relative with r_ref,i the
  // initial radius (compounding per step would drift by ~1e-13 and more), mass bit-identical,
  // I_i = 2/5 m_i r_i^2. The neighbour search follows the growth (Verlet radius criterion).
  State s = separated_spheres();
  std::map<Id, double> r0, m0;
  for (std::size_t i = 0; i < s.particles.size(); ++i) {
    r0[s.particles.id[i]] = s.particles.radius[i];
    m0[s.particles.id[i]] = s.particles.mass[i];
  }
  TemperatureHistory::Params p;
  for (int c = 0; c <= 80; ++c) {
    p.time.push_back(5.0 * c);
    p.temperature.push_back(c % 2 == 0 ? 300.0 : 1500.0);
  }
  p.expansion_coefficient = 1.5e-5;
  TemperatureHistory th(p);
  auto law = soft_law();
  Simulation sim(s, law);
  sim.add_module(&th);
  StageConfig cfg = test::stage(1e-6, 4000, 2e-5);
  cfg.time_scale = 1e5;         // 0.1 s per step: 50 steps per ramp
  cfg.sort_every_rebuilds = 3;  // permutations too
  auto T_of = [&](double t) { return physics::thermal::table_temperature(p.time, p.temperature, t); };
  double worst = 0.0, worst_I = 0.0;
  bool mass_kept = true;
  test::StepObserver obs([&](const State& st, Step k) {
    const double T = T_of(1e5 * (static_cast<double>(k) * 1e-6));
    const auto& pp = st.particles;
    for (std::size_t i = 0; i < pp.size(); ++i) {
      const double expect = r0.at(pp.id[i]) * (1.0 + 1.5e-5 * (T - 293.15));
      worst = std::max(worst, test::relative_error(pp.radius[i], expect));
      worst_I = std::max(worst_I, test::relative_error(pp.inertia[i], 0.4 * pp.mass[i] * pp.radius[i] * pp.radius[i]));
      mass_kept = mass_kept && pp.mass[i] == m0.at(pp.id[i]);
      CHECK(pp.fields.data("radius_ref")[i] == r0.at(pp.id[i]));
    }
  });
  sim.run_stage(cfg, obs);
  INFO("largest relative radius deviation: " << worst);
  CHECK(worst <= 1e-15);
  CHECK(worst_I <= 1e-15);
  CHECK(mass_kept);
  // The growth was seen by the Verlet criterion (2 max growth > skin): the build at the stage
  // start, then two while the largest sphere (1.3 mm) first grows by 2.34e-5 m (crossing
  // skin/2 = 1e-5 m twice); never again, as the radii never exceed those of the last build by
  // more (shrinking needs no rebuild).
  CHECK(s.rebuilds == 3);
}

TEST_CASE("thermal expansion: a later stage keeps the reference radii of the first", "[thermal][modules]") {
  // Stage 1 heats 293.15 K -> 1293.15 K in 1 s (alpha = 1e-5: r = 1.01 r0). Stage 2 (a new
  // module, as a scenario builds one per stage) starts at 1293.15 K and cools to 793.15 K: the
  // radii must be
  // r0 (1 + 1e-5 (T - 293.15)) with the original r0, not 1.01 r0 (1 + ...) (a recapture).
  State s = separated_spheres();
  std::map<Id, double> r0;
  for (std::size_t i = 0; i < s.particles.size(); ++i) r0[s.particles.id[i]] = s.particles.radius[i];
  auto law = soft_law();
  test::NullObserver obs;
  StageConfig heat_stage = test::stage(1e-6, 2000, 1e-4);
  heat_stage.time_scale = 1e3;  // 1 ms physical per step: the 1 s ramps take 1000 steps
  TemperatureHistory::Params p1;
  p1.time = {0.0, 1.0};
  p1.temperature = {293.15, 1293.15};
  p1.expansion_coefficient = 1e-5;
  {
    TemperatureHistory th(p1);
    Simulation sim(s, law);
    sim.add_module(&th);
    sim.run_stage(heat_stage, obs);
  }
  for (std::size_t i = 0; i < s.particles.size(); ++i)
    CHECK(test::relative_error(s.particles.radius[i], r0.at(s.particles.id[i]) * 1.01) <= 1e-15);
  TemperatureHistory::Params p2 = p1;
  p2.temperature = {1293.15, 793.15};
  {
    TemperatureHistory th(p2);
    Simulation sim(s, law);
    sim.add_module(&th);
    sim.prepare(heat_stage);
    for (std::size_t i = 0; i < s.particles.size(); ++i)  // at the start of stage 2, before any step
      CHECK(test::relative_error(s.particles.radius[i], r0.at(s.particles.id[i]) * 1.01) <= 1e-15);
    sim.run_stage(heat_stage, obs);
  }
  for (std::size_t i = 0; i < s.particles.size(); ++i)
    CHECK(test::relative_error(s.particles.radius[i], r0.at(s.particles.id[i]) * 1.005) <= 1e-15);
  // A stage giving another reference temperature for the captured radii is a set-up error.
  TemperatureHistory::Params p3 = p2;
  p3.reference_temperature = 300.0;
  TemperatureHistory th3(p3);
  Simulation sim3(s, law);
  sim3.add_module(&th3);
  CHECK_THROWS_AS(sim3.prepare(heat_stage), SetupError);
}

TEST_CASE("temperature_history reports every table problem at once with its path", "[thermal][modules][config]") {
  TemperatureHistory::Params p;
  p.time = {0.0, 2.0, 1.0};
  p.temperature = {300.0, -5.0};
  try {
    TemperatureHistory th(p);
    FAIL("no ConfigError");
  } catch (const ConfigError& e) {
    INFO(e.what());
    std::map<std::string, std::string> by_path;
    for (const auto& d : e.diagnostics()) by_path[d.path] = d.message;
    CHECK(e.diagnostics().size() == 3);
    CHECK(by_path.count("/temperature"));    // 2 temperatures for 3 times
    CHECK(by_path.count("/time/2"));         // 1 s after 2 s
    CHECK(by_path.count("/temperature/1"));  // -5 K
    CHECK(by_path["/temperature/1"].find("-5") != std::string::npos);
  }
  p.time = {};
  p.temperature = {};
  CHECK_THROWS_AS(TemperatureHistory(p), ConfigError);
  p.time = {0.0};
  p.temperature = {2000.0};
  p.expansion_coefficient = -1e-3;  // 1 + alpha (T - T0) < 0: a negative radius
  CHECK_THROWS_AS(TemperatureHistory(p), ConfigError);
}

TEST_CASE("temperature_history start_from_current cools a state from the temperature it holds", "[thermal][modules]") {
  // The state holds 1500 K (as a snapshot taken hot); the table [0, 100] s -> [ignored, 300] K
  // with start_from_current starts at 1500 K: T(t) = 1500 - 12 t, held at 300 K after 100 s.
  State s = separated_spheres();
  s.particles.fields.declare(FieldInfo{"temperature", 1, "K", 0.0, true}, s.particles.size());
  auto& f0 = s.particles.fields.data("temperature");
  std::fill(f0.begin(), f0.end(), 1500.0);
  TemperatureHistory::Params p;
  p.time = {0.0, 100.0};
  p.temperature = {293.15, 300.0};
  p.start_from_current = true;
  TemperatureHistory th(p);
  auto law = soft_law();
  Simulation sim(s, law);
  sim.add_module(&th);
  StageConfig cfg = test::stage(1e-6, 2000, 1e-4);
  cfg.time_scale = 1e5;
  double worst = 0.0;
  test::StepObserver obs([&](const State& st, Step k) {
    const double t = 1e5 * (static_cast<double>(k) * 1e-6);
    const double expect = t >= 100.0 ? 300.0 : 1500.0 - 12.0 * t;
    for (double T : st.particles.fields.data("temperature")) worst = std::max(worst, test::relative_error(T, expect));
  });
  sim.run_stage(cfg, obs);
  CHECK(worst <= 1e-12);
  // A state without any temperature cannot start from it.
  State cold = separated_spheres();
  TemperatureHistory th2(p);
  Simulation sim2(cold, law);
  sim2.add_module(&th2);
  test::NullObserver none;
  CHECK_THROWS_WITH(sim2.run_stage(cfg, none), Catch::Contains("start_from_current needs the particles' temperature"));
}

}  // namespace test_temperature_history
