// Scheduler and module contract: clocks (every N steps, k substeps per step) as executed by
// Simulation, the step plan's ordering and set-up errors, and the field registry.
#include <catch2/catch.hpp>

#include <algorithm>
#include <string>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/schedule/scheduler.hpp"
#include "engine/simulation.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "tests/support/scene.hpp"

using namespace sparkdem;
using namespace sparkdem::physics;

namespace {

/// A module that records every call it gets.
class Mock final : public Module {
 public:
  Mock(std::string name, Phase phase, Clock clock, std::vector<std::string> reads = {},
       std::vector<std::string> writes = {}, std::vector<FieldInfo> fields = {})
      : name_(std::move(name)), phase_(phase), clock_(clock), reads_(std::move(reads)), writes_(std::move(writes)),
        fields_(std::move(fields)) {}
  std::string name() const override { return name_; }
  Phase phase() const override { return phase_; }
  Clock clock() const override { return clock_; }
  void declare(Declarations& d) const override {
    d.reads = reads_;
    d.writes = writes_;
    d.particle_fields = fields_;
  }
  void advance(State&, const StepInfo& info) override { calls.push_back(info); }
  std::vector<StepInfo> calls;

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
    CHECK(m.calls[k].dt == Approx(3.0 * dt).epsilon(1e-15));     // Clock::dt, exact up to rounding
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
    CHECK(plan.items.size() == 7 + 3);  // the 7 mechanical items + 3 modules
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
