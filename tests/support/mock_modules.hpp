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

#include "engine/graph/interaction_graph.hpp"
#include "engine/graph/laplacian.hpp"
#include "engine/core/error.hpp"
#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"
#include "engine/model/registry.hpp"
#include "engine/state/state.hpp"

namespace sparkdem::test {

template <int Variant>
class MockModule final : public Module {
 public:
  struct Params {
    double rate = 1.0;             ///< field growth per unit time and speed^2
    bool physical_time = false;    ///< run in the physical clock
    double stable_dt_scale = 0.0;  ///< > 0: stable step = scale / (1 + max speed) [s]
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
    for (const auto& [k, v] : warm_) {
      ids.push_back(k);
      vals.push_back(v);
    }
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

/// A fake network module: on its clock it builds the interaction graph (contacts and bonds),
/// gives every edge a conductance proportional to its contact radius (plus a floor), holds the
/// particles of set `high_set` at 1 and of `low_set` at 0, solves through the shared
/// LaplacianSolver (CG with warm start, so the warm start is state a restart must keep) and
/// writes the potential to a particle field and the electrode current to a held output.
class MockNetwork final : public Module {
 public:
  struct Params {
    std::string high_set = "top";
    std::string low_set = "bottom";
  };
  static ParamSpec<Params> spec() {
    ParamSpec<Params> s("mock_network", "module", "test network module on the interaction graph");
    s.add("high_set", &Params::high_set).doc("particle set held at potential 1");
    s.add("low_set", &Params::low_set).doc("particle set held at potential 0");
    return s;
  }
  explicit MockNetwork(const Params& p) : p_(p), solver_(LaplacianOptions{LaplacianMethod::CgDiagonal, 1e-8, 0, true}) {}
  std::string name() const override { return "mock_network"; }
  Phase phase() const override { return Phase::Coupling; }
  void declare(Declarations& d) const override {
    d.particle_fields.push_back({"mock_potential", 1, "V", 0.0, true});
    d.reads = {"position"};
    d.writes = {"mock_potential"};
  }
  void advance(State& s, const StepInfo& info) override {
    const InteractionGraph g = build_interaction_graph(s, GraphOptions{});
    std::vector<double> cond(g.size());
    for (std::size_t e = 0; e < g.size(); ++e) cond[e] = 1e-3 + g.radius[e];
    LaplacianProblem prob = LaplacianProblem::on(g, cond);
    prob.step = info.step;
    const auto& hi = s.particles.fields.data("set/" + p_.high_set);
    const auto& lo = s.particles.fields.data("set/" + p_.low_set);
    DirichletGroup high{{}, 1.0}, low{{}, 0.0};
    for (std::size_t i = 0; i < s.particles.size(); ++i) {
      if (hi[i] > 0.5)
        high.nodes.push_back(static_cast<Index>(i));
      else if (lo[i] > 0.5)
        low.nodes.push_back(static_cast<Index>(i));
    }
    if (high.nodes.empty() || low.nodes.empty()) throw SetupError("mock_network: an electrode set is empty");
    prob.dirichlet = {high, low};
    const LaplacianResult r = solver_.solve(prob);
    auto& u = s.particles.fields.data("mock_potential");
    for (std::size_t i = 0; i < u.size(); ++i) u[i] = std::isnan(r.value[i]) ? -1.0 : r.value[i];
    current = r.dirichlet_flux[0];
    ++calls_;
  }
  void visit(Archive& ar, const std::string& prefix) override {
    ar.visit(prefix + "/calls", calls_);
    ar.visit(prefix + "/current", current);
    solver_.visit(ar, prefix + "/solver");
  }
  double current = 0.0;  ///< held output: net current leaving the high electrode [A]

 private:
  Params p_;
  LaplacianSolver solver_;
  std::int64_t calls_ = 0;
};

/// Every law, module and generator of physics::register_all plus the mocks.
Registry registry_with_mocks();

}  // namespace sparkdem::test
