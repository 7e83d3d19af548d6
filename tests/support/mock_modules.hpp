#pragma once
/// Mock coupling modules for the contract tests. They keep every kind of module state a real
/// module keeps — a call counter, a held (zero-order-hold) output fed back into the next call,
/// a warm-start vector keyed by particle id, a per-particle field — and let the scenario choose
/// their clock, time domain and a state-dependent stable step. Any piece of that state a
/// checkpoint forgets changes the particle field they write, so a restart comparison sees it.
#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"
#include "engine/model/registry.hpp"
#include "engine/state/state.hpp"

namespace sparkdem::test {

template <int Variant>
class MockModule final : public Module {
 public:
  struct Params {
    double rate = 1.0;              ///< field growth per unit time and speed^2
    bool physical_time = false;     ///< run in the physical clock
    double stable_dt_scale = 0.0;   ///< > 0: stable step = scale / (1 + max speed) [s]
  };
  static std::string kind() { return "mock_" + std::string(1, static_cast<char>('a' + Variant)); }
  static ParamSpec<Params> spec() {
    ParamSpec<Params> s(kind(), "module", "test module with counters, a held output and a warm-start vector");
    s.add("rate", &Params::rate).doc("growth rate");
    s.add("physical_time", &Params::physical_time).doc("run in physical time");
    s.add("stable_dt_scale", &Params::stable_dt_scale).nonnegative().unit("s").doc("stable step scale");
    return s;
  }
  explicit MockModule(const Params& p) : p_(p) {}
  std::string name() const override { return kind(); }
  Phase phase() const override { return Phase::Coupling; }
  TimeDomain time_domain() const override { return p_.physical_time ? TimeDomain::Physical : TimeDomain::Mechanical; }
  void declare(Declarations& d) const override {
    d.particle_fields.push_back({field(), 1, "1", 0.0, true});
    d.reads = {"velocity"};
    d.writes = {field()};
  }
  double stable_dt(const State& s) const override {
    if (!(p_.stable_dt_scale > 0.0)) return Module::stable_dt(s);
    double vmax = 0.0;
    for (const auto& v : s.particles.velocity) vmax = std::max(vmax, v.norm());
    return p_.stable_dt_scale / (1.0 + 100.0 * vmax);
  }
  void advance(State& s, const StepInfo& info) override {
    auto& f = s.particles.fields.data(field());
    double sum = 0.0;
    for (std::size_t i = 0; i < f.size(); ++i) {
      double& warm = warm_[s.particles.id[i]];
      warm = 0.5 * warm + s.particles.velocity[i].squaredNorm();
      f[i] += p_.rate * info.dt * warm + 1e-3 * held_;
      sum += f[i];
    }
    held_ = sum / static_cast<double>(std::max<std::size_t>(1, f.size()));
    ++calls_;
    dt_sum_ += info.dt;
    last_time_ = info.time;
  }
  void visit(Archive& ar, const std::string& prefix) override {
    ar.visit(prefix + "/calls", calls_);
    ar.visit(prefix + "/dt_sum", dt_sum_);
    ar.visit(prefix + "/last_time", last_time_);
    ar.visit(prefix + "/held", held_);
    std::vector<std::int64_t> ids;
    std::vector<double> vals;
    for (const auto& [k, v] : warm_) { ids.push_back(k); vals.push_back(v); }
    ar.visit(prefix + "/warm_ids", ids);
    ar.visit(prefix + "/warm_values", vals);
    if (ar.reading()) {
      warm_.clear();
      for (std::size_t k = 0; k < ids.size() && k < vals.size(); ++k) warm_[ids[k]] = vals[k];
    }
  }

 private:
  static std::string field() { return kind() + "_heat"; }
  Params p_;
  std::int64_t calls_ = 0;
  double dt_sum_ = 0.0, last_time_ = 0.0, held_ = 0.0;
  std::map<Id, double> warm_;
};

/// Every law, module and generator of physics::register_all plus the mocks.
Registry registry_with_mocks();

}  // namespace sparkdem::test
