// Scheduler and module contract: clocks (every N steps, k substeps per step) as executed by
// Simulation, the step plan's ordering and set-up errors, and the field registry.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/schedule/scheduler.hpp"
#include "engine/simulation.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "tests/support/scene.hpp"

namespace test_scheduler {

using namespace sparkdem;
using namespace sparkdem::physics;

namespace {

/// A module that records every call it gets.
class Mock final : public Module {
 public:
  Mock(std::string name, Phase phase, Clock clock, std::vector<std::string> reads = {}, std::vector<std::string> writes = {},
       std::vector<FieldInfo> fields = {})
      : name_(std::move(name)),
        phase_(phase),
        clock_(clock),
        reads_(std::move(reads)),
        writes_(std::move(writes)),
        fields_(std::move(fields)) {}
  std::string name() const override { return name_; }
  Phase phase() const override { return phase_; }
  Clock clock() const override { return clock_; }
  TimeDomain time_domain() const override { return domain; }
  double stable_dt(const State& s) const override { return stable ? stable(s) : Module::stable_dt(s); }
  void declare(Declarations& d) const override {
    d.reads = reads_;
    d.writes = writes_;
    d.particle_fields = fields_;
  }
  void advance(State& s, const StepInfo& info) override {
    calls.push_back(info);
    if (on_call) on_call(s);
  }
  std::vector<StepInfo> calls;
  TimeDomain domain = TimeDomain::Mechanical;
  std::function<double(const State&)> stable;  ///< own stable step; empty = unconditionally stable
  std::function<void(State&)> on_call;

 private:
  std::string name_;
  Phase phase_;
  Clock clock_;
  std::vector<std::string> reads_, writes_;
  std::vector<FieldInfo> fields_;
};

const std::vector<std::string> kCore = {"position", "velocity", "force", "mass"};

/// One resting sphere (no contacts): the mechanics is trivial, only the schedule matters.
struct Bench {
  State s;
  ContactModelT<HertzMindlin> law{HertzMindlin::Params{}};
  Bench() { test::add_sphere(s, Vec3::Zero(), 1e-3, 2500.0); }
};

std::ptrdiff_t position_of(const StepPlan& plan, const std::string& name) {
  const auto names = plan.names();
  return std::find(names.begin(), names.end(), name) - names.begin();
}

}  // namespace

TEST_CASE("The timed steps of the stage split are one in kSplitEvery on every step period", "[scheduler]") {
  // An item that costs on every P-th step only (a Verlet rebuild) is sampled in proportion: on
  // the steps that are multiples of P the timed share must be 1 / kSplitEvery too, for periods that
  // are powers of two (which a stride would alias with) and others. 64 Ki steps per period, so the
  // binomial spread of the share is below 5 % of it (3 sigma).
  for (const Step period : {1, 2, 7, 16, 32, 33, 64, 100, 128}) {
    const Step n = 65536;
    Step timed = 0;
    for (Step k = 0; k < n; ++k) timed += split_timed(k * period) ? 1 : 0;
    const double share = static_cast<double>(timed) / static_cast<double>(n);
    INFO("period " << period << ": share " << share);
    CHECK(std::abs(share * kSplitEvery - 1.0) < 0.05);
  }
}

TEST_CASE("EveryNSteps(N) runs at global steps N, 2N, ... with dt = N dt", "[scheduler]") {
  Bench b;
  Mock m("every3", Phase::Coupling, {Clock::Kind::EveryNSteps, 3});
  Simulation sim(b.s, b.law);
  sim.add_module(&m);
  const double dt = 1e-6;
  test::NullObserver obs;
  sim.run_stage(test::stage(dt, 10), obs);
  // A second stage of 8 steps continues the global count (steps 11..18).
  sim.run_stage(test::stage(dt, 8), obs);
  REQUIRE(m.calls.size() == 6);  // 3, 6, 9, 12, 15, 18
  for (std::size_t k = 0; k < m.calls.size(); ++k) {
    const Step expect = 3 * static_cast<Step>(k + 1);
    CHECK(m.calls[k].step == expect);
    CHECK(m.calls[k].dt == Approx(3.0 * dt).epsilon(1e-15));       // Clock::dt, exact up to rounding
    CHECK(m.calls[k].time == Approx(expect * dt).epsilon(1e-12));  // end of the call's window
  }
}

TEST_CASE("SubstepsPerStep(k) runs k times per step with dt / k", "[scheduler]") {
  Bench b;
  Mock m("sub4", Phase::Coupling, {Clock::Kind::SubstepsPerStep, 4});
  Simulation sim(b.s, b.law);
  sim.add_module(&m);
  const double dt = 1e-6;
  test::NullObserver obs;
  sim.run_stage(test::stage(dt, 5), obs);
  REQUIRE(m.calls.size() == 20);
  for (std::size_t c = 0; c < m.calls.size(); ++c) {
    CHECK(m.calls[c].step == static_cast<Step>(c / 4 + 1));
    CHECK(m.calls[c].dt == Approx(dt / 4).epsilon(1e-15));
    // Substep q of step n ends at (n - 1) dt + q dt/4: the substeps tile the time axis.
    CHECK(m.calls[c].time == Approx((c + 1) * dt / 4).epsilon(1e-12));
  }
}

TEST_CASE("Force modules run every step after the contact passes", "[scheduler]") {
  Bench b;
  Mock f("force_mod", Phase::Force, {}, {"velocity"}, {"force"});
  Simulation sim(b.s, b.law);
  sim.add_module(&f);
  test::NullObserver obs;
  sim.run_stage(test::stage(1e-6, 7), obs);
  // One call for the set-up force evaluation at the stage start plus one per step.
  REQUIRE(f.calls.size() == 8);
  for (std::size_t k = 0; k < f.calls.size(); ++k) CHECK(f.calls[k].step == static_cast<Step>(k));
  const StepPlan& plan = sim.plan();
  CHECK(position_of(plan, "force_mod") > position_of(plan, "contact_walls"));
  CHECK(position_of(plan, "force_mod") < position_of(plan, "integrate_second_half"));
}

TEST_CASE("build_step_plan: set-up errors and writer-before-reader order", "[scheduler]") {
  const Clock every{};
  SECTION("dangling read") {
    Mock a("a", Phase::Coupling, every, {"temperature"}, {});
    CHECK_THROWS_AS(build_step_plan({&a}, kCore), SetupError);
    // The same read is fine once a module writes the field, or declares it.
    Mock w("w", Phase::Coupling, every, {}, {"temperature"});
    CHECK_NOTHROW(build_step_plan({&a, &w}, kCore));
    Mock d("d", Phase::Force, every, {}, {}, {FieldInfo{"temperature", 1, "K", 300.0, true}});
    CHECK_NOTHROW(build_step_plan({&a, &d}, kCore));
  }
  SECTION("read/write cycle of two coupling modules") {
    Mock a("a", Phase::Coupling, every, {"x"}, {"y"});
    Mock b("b", Phase::Coupling, every, {"y"}, {"x"});
    CHECK_THROWS_AS(build_step_plan({&a, &b}, kCore), SetupError);
  }
  SECTION("clock ratio must be positive") {
    Mock a("a", Phase::Coupling, {Clock::Kind::EveryNSteps, 0});
    CHECK_THROWS_AS(build_step_plan({&a}, kCore), SetupError);
  }
  SECTION("writer before reader, independent of declaration order") {
    Mock reader("reader", Phase::Coupling, every, {"heat"}, {"temperature"});
    Mock writer("writer", Phase::Coupling, every, {"velocity"}, {"heat"});
    Mock last("last", Phase::Coupling, every, {"temperature"}, {});
    const StepPlan plan = build_step_plan({&last, &reader, &writer}, kCore);
    CHECK(position_of(plan, "writer") < position_of(plan, "reader"));
    CHECK(position_of(plan, "reader") < position_of(plan, "last"));
    CHECK(position_of(plan, "writer") > position_of(plan, "integrate_second_half"));  // coupling after mechanics
    CHECK(plan.items.size() == 6 + 3);                                                // the 6 mechanical items + 3 modules
  }
}

TEST_CASE("FieldRegistry: only declared fields exist, and they follow the particles", "[scheduler]") {
  Bench b;
  for (int k = 1; k < 5; ++k) test::add_sphere(b.s, Vec3(3e-3 * k, 0, 0), 1e-3, 2500.0);
  Mock m("heater", Phase::Coupling, {}, {}, {"temperature"}, {FieldInfo{"temperature", 2, "K", 293.0, true}});
  Simulation sim(b.s, b.law);
  sim.add_module(&m);
  auto& f = b.s.particles.fields;
  CHECK_FALSE(f.has("temperature"));  // nothing is allocated before the stage is prepared
  sim.prepare(test::stage(1e-6, 1));
  REQUIRE(f.has("temperature"));
  CHECK(f.data("temperature").size() == 2 * b.s.particles.size());
  CHECK(f.data("temperature")[3] == 293.0);  // initial value, exact
  CHECK(f.info("temperature").unit == "K");
  // A field nobody declared is absent, and asking for it is a set-up error.
  CHECK_FALSE(f.has("heat_flux"));
  CHECK_THROWS_AS(f.data("heat_flux"), SetupError);
  // Declared fields are permuted with the particles (exact values follow the ids).
  for (std::size_t k = 0; k < b.s.particles.size(); ++k) f.data("temperature")[2 * k + 1] = 1000.0 + b.s.particles.id[k];
  b.s.particles.permute({3, 0, 4, 2, 1});
  for (std::size_t k = 0; k < b.s.particles.size(); ++k) CHECK(f.data("temperature")[2 * k + 1] == 1000.0 + b.s.particles.id[k]);
  // New particles get the declared initial value.
  test::add_sphere(b.s, Vec3(0, 5e-3, 0), 1e-3, 2500.0);
  CHECK(f.data("temperature").size() == 2 * b.s.particles.size());
  CHECK(f.data("temperature").back() == 293.0);
}

// ---- event clocks, adaptive substeps, shrinking stable steps, time scaling --------------------

namespace {
Clock on_event(Trigger t) {
  Clock c;
  c.kind = Clock::Kind::OnEvent;
  c.trigger = std::move(t);
  return c;
}
std::vector<Step> steps_of(const Mock& m) {
  std::vector<Step> out;
  for (const auto& c : m.calls) out.push_back(c.step);
  return out;
}
}  // namespace

TEST_CASE("OnEvent: a module runs on the stage's initial state, then when a particle moved beyond a distance", "[scheduler][contracts]") {
  Bench b;
  b.s.particles.velocity[0] = Vec3(1.0, 0, 0);  // 1 m/s, no forces: 1e-6 m per step of 1e-6 s
  Trigger t;
  t.moved_beyond = 3.5e-6;
  Mock m("solver", Phase::Coupling, on_event(t));
  Simulation sim(b.s, b.law);
  sim.add_module(&m);
  test::NullObserver obs;
  const double dt = 1e-6;
  sim.run_stage(test::stage(dt, 14), obs);
  // Runs on the initial state (step 0, dt = 0), then 4 steps (4e-6 m > 3.5e-6 m) after each
  // run: 0, 4, 8, 12.
  CHECK(steps_of(m) == std::vector<Step>{0, 4, 8, 12});
  CHECK(m.calls[0].dt == 0.0);
  for (std::size_t k = 1; k < m.calls.size(); ++k) CHECK(m.calls[k].dt == Approx(4 * dt).epsilon(1e-15));  // time since last run
}

TEST_CASE("OnEvent: a field changed by more than a threshold, and a maximum interval", "[scheduler][contracts]") {
  Bench b;
  Mock writer("heater", Phase::Coupling, {}, {}, {"heat"}, {FieldInfo{"heat", 1, "J", 0.0, false}});
  writer.on_call = [](State& s) { s.particles.fields.data("heat")[0] += 1.0; };
  Trigger t;
  t.field = "heat";
  t.field_change = 2.5;
  Mock reader("watcher", Phase::Coupling, on_event(t), {"heat"});
  Trigger ti;
  ti.max_interval = 5;
  Mock ticker("ticker", Phase::Coupling, on_event(ti));
  Simulation sim(b.s, b.law);
  sim.add_module(&reader);  // declared first: the plan still puts the writer before it
  sim.add_module(&writer);
  sim.add_module(&ticker);
  test::NullObserver obs;
  sim.run_stage(test::stage(1e-6, 12), obs);
  // heat = n after step n; runs at 0 (heat 0), then when heat - heat_at_last_run > 2.5: 3, 6, 9, 12.
  CHECK(steps_of(reader) == std::vector<Step>{0, 3, 6, 9, 12});
  CHECK(steps_of(ticker) == std::vector<Step>{0, 5, 10});
}

TEST_CASE("AdaptiveSubsteps follows a shrinking stable step, and a fixed clock above it stops the run", "[scheduler][contracts]") {
  const double dt = 1e-6;
  SECTION("adaptive") {
    Bench b;
    Mock m("stiff", Phase::Coupling, {Clock::Kind::AdaptiveSubsteps, 1});
    m.stable = [dt](const State& s) { return dt / (1.0 + static_cast<double>(s.step) / 4.0); };
    Simulation sim(b.s, b.law);
    sim.add_module(&m);
    test::NullObserver obs;
    const StageResult r = sim.run_stage(test::stage(dt, 12), obs);
    // Step n (1-based) is computed from the state after n - 1 steps: k_n = ceil(1 + (n - 1)/4).
    std::size_t c = 0;
    Step total = 0;
    for (Step n = 1; n <= 12; ++n) {
      const Step k = static_cast<Step>(std::ceil(1.0 + static_cast<double>(n - 1) / 4.0 - 1e-12));
      total += k;
      double sum = 0.0;
      for (Step q = 0; q < k; ++q, ++c) {
        REQUIRE(c < m.calls.size());
        CHECK(m.calls[c].step == n);
        CHECK(m.calls[c].substep == q);
        CHECK(m.calls[c].dt <= dt / (1.0 + static_cast<double>(n - 1) / 4.0) * (1 + 1e-12));  // never above the stable step
        sum += m.calls[c].dt;
      }
      CHECK(sum == Approx(dt).epsilon(1e-14));  // the substeps tile the step
      CHECK(m.calls[c - 1].time == Approx(static_cast<double>(n) * dt).epsilon(1e-12));
    }
    CHECK(m.calls.size() == static_cast<std::size_t>(total));
    CHECK(r.module_calls.at("stiff") == total);
    CHECK(r.max_substeps.at("stiff") == 4);
  }
  SECTION("fixed clock") {
    Bench b;
    Mock m("fixed", Phase::Coupling, {Clock::Kind::SubstepsPerStep, 1});
    m.stable = [dt](const State& s) { return 2.0 * dt / (1.0 + static_cast<double>(s.step) / 10.0); };
    Simulation sim(b.s, b.law);
    sim.add_module(&m);
    test::NullObserver obs;
    StageConfig cfg = test::stage(dt, 100);
    cfg.stability_check_every = 5;
    // Stable step < dt once step > 10: found at the check after step 15.
    CHECK_THROWS_AS(sim.run_stage(cfg, obs), PhysicsError);
    CHECK(b.s.step == 15);
  }
}

TEST_CASE("time scaling: physical-time modules see time_scale x dt and the physical clock", "[scheduler][contracts]") {
  Bench b;
  Mock phys("sintering_kinetics", Phase::Coupling, {Clock::Kind::EveryNSteps, 2});
  phys.domain = TimeDomain::Physical;
  Mock mech("mechanical_observer", Phase::Coupling, {});
  Simulation sim(b.s, b.law);
  sim.add_module(&phys);
  sim.add_module(&mech);
  test::NullObserver obs;
  const double dt = 1e-6, scale = 1000.0;
  StageConfig cfg = test::stage(dt, 10);
  cfg.time_scale = scale;
  const StageResult r = sim.run_stage(cfg, obs);
  REQUIRE(phys.calls.size() == 5);
  for (std::size_t k = 0; k < phys.calls.size(); ++k) {
    CHECK(phys.calls[k].dt == Approx(2 * dt * scale).epsilon(1e-15));
    CHECK(phys.calls[k].time == Approx(scale * dt * 2.0 * static_cast<double>(k + 1)).epsilon(1e-12));
  }
  CHECK(mech.calls.back().dt == Approx(dt).epsilon(1e-15));
  CHECK(mech.calls.back().time == Approx(10 * dt).epsilon(1e-12));
  CHECK(r.simulated_time == Approx(10 * dt).epsilon(1e-12));
  CHECK(r.physical_time == Approx(10 * dt * scale).epsilon(1e-12));
  CHECK(b.s.physical_time == Approx(10 * dt * scale).epsilon(1e-12));
}

}  // namespace test_scheduler
