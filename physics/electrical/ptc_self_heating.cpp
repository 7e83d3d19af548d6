#include "physics/electrical/ptc_self_heating.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "engine/core/error.hpp"
#include "engine/state/particle_set.hpp"
#include "engine/state/state.hpp"
#include "physics/electrical/ptc_gaps.hpp"
#include "engine/core/numbers.hpp"

namespace sparkdem::physics {

ParamSpec<PtcSelfHeating::Params> PtcSelfHeating::spec() {
  using P = Params;
  ParamSpec<P> s("ptc_self_heating", "module",
                 "local thermal eigenstrain eps0(T) of the CPC matrix from the temperature field: filler displacements "
                 "(field ptc_displacement) by back-substitution with the factorised bonded-network matrix (self-heating PTC)");
  s.add("high", &P::high).doc("electrode set for the switching columns (\"\": not reported)");
  s.add("low", &P::low).doc("opposite electrode set for the switching columns");
  ptc::add_relative_gaps(s);
  s.add("regularisation", &P::regularisation).nonnegative().doc("ground spring on every filler, x mean spring stiffness");
  s.add("expansion_coefficient", &P::expansion_coefficient)
      .unit("1/K")
      .positive()
      .doc("alpha_s: linear expansion coefficient of the matrix relative to the fillers (below the melting step)");
  s.add("expansion_coefficient_melt", &P::expansion_coefficient_melt)
      .unit("1/K")
      .nonnegative()
      .doc("alpha_l above the melting step (0: alpha_s)");
  s.add("reference_temperature", &P::reference_temperature).unit("K").positive().doc("T_ref: eps0(T_ref) = 0");
  s.add("melting_temperature", &P::melting_temperature).unit("K").nonnegative().doc("T_m (0: no melting step)");
  s.add("melting_strain", &P::melting_strain).unit("1").nonnegative().doc("linear strain jump on melting");
  s.add("melting_width", &P::melting_width).unit("K").nonnegative().doc("width of the smoothed melting step (0: sharp)");
  return s;
}

PtcSelfHeating::PtcSelfHeating(const Params& p) : p_(p) {
  law_ = ptc::ThermalStrainLaw{
      p_.expansion_coefficient, p_.expansion_coefficient_melt > 0.0 ? p_.expansion_coefficient_melt : p_.expansion_coefficient,
      p_.reference_temperature, p_.melting_temperature,
      p_.melting_strain,        p_.melting_width};
  ptc::validate(law_);
  if (p_.high.empty() != p_.low.empty()) throw SetupError("ptc_self_heating: give both electrodes high and low, or neither");
  mp_.min_gap_rel = p_.min_gap_rel;
  mp_.cutoff_gap_rel = p_.cutoff_gap_rel;
  mp_.touch_gap_rel = p_.touch_gap_rel;
  mp_.regularisation = p_.regularisation;
  held_.assign(columns().size(), kNaN);
}

void PtcSelfHeating::declare(Declarations& d) const {
  d.particle_fields.push_back({"ptc_displacement", 3, "m", 0.0, true});
  d.reads_previous = {"position", "radius", "temperature"};
  d.writes = {"ptc_displacement"};
}

void PtcSelfHeating::build(const State& s) {
  const auto& P = s.particles;
  x_ref_ = P.position;
  net_ = ptc::build_network(P.position, P.radius, mp_);
  solver_.factorize(P.size(), net_, mp_);
  contact_.clear();
  for (std::size_t e = 0; e < net_.size(); ++e)
    if (net_.gap[e] <= p_.touch_gap_rel * net_.distance[e]) contact_.push_back(e);
  switching_strain_ = kNaN;
  if (!p_.high.empty()) {
    std::vector<Vec3> u;
    std::vector<double> open;
    solver_.solve(std::vector<double>(net_.size(), 1.0), u, open);
    ptc::Contacts c;
    for (std::size_t e : contact_) {
      c.a.push_back(net_.a[e]);
      c.b.push_back(net_.b[e]);
      c.gap.push_back(net_.gap[e]);
      c.opening.push_back(open[e]);
      c.distance.push_back(net_.distance[e]);
      c.touching.push_back(1);
    }
    const ptc::Intervals iv = ptc::conduction_intervals(c, p_.touch_gap_rel, p_.break_gap_rel);
    switching_strain_ = ptc::switching_strain(P.size(), c, iv, set_members(s, p_.high, "ptc_self_heating"),
                                              set_members(s, p_.low, "ptc_self_heating"));
  }
}

void PtcSelfHeating::advance(State& s, const StepInfo& info) {
  const auto& P = s.particles;
  if (!solver_.ready() || x_ref_ != P.position) build(s);
  const auto& T = P.fields.data("temperature");
  std::vector<double> eps(net_.size(), 0.0);
  double sum = 0.0, mx = -std::numeric_limits<double>::infinity();
  std::size_t cnt = 0;
  for (std::size_t e = 0; e < net_.size(); ++e) {
    const double Te = 0.5 * (T[net_.a[e]] + T[net_.b[e]]);
    if (!std::isfinite(Te))
      throw PhysicsError(info.step, {P.id[net_.a[e]], P.id[net_.b[e]]}, "temperature", "ptc_self_heating: non-finite filler temperature");
    eps[e] = ptc::thermal_strain(law_, Te);
    if (net_.eigen_gap[e] > 0.0) {
      sum += eps[e];
      mx = std::max(mx, eps[e]);
      ++cnt;
    }
  }
  std::vector<Vec3> u;
  std::vector<double> open;
  solver_.solve(eps, u, open);
  auto& f = s.particles.fields.data("ptc_displacement");
  for (std::size_t i = 0; i < P.size(); ++i)
    for (int c = 0; c < 3; ++c) f[3 * i + c] = u[i][c];
  std::size_t conducting = 0;
  for (std::size_t e : contact_)
    if (net_.gap[e] + open[e] <= std::max(p_.break_gap_rel * net_.distance[e], net_.gap[e])) ++conducting;
  const double n = static_cast<double>(P.size());
  held_ = {static_cast<double>(contact_.size()),
           static_cast<double>(conducting),
           n > 0 ? 2.0 * static_cast<double>(conducting) / n : kNaN,
           cnt ? sum / static_cast<double>(cnt) : kNaN,
           cnt ? mx : kNaN,
           switching_strain_,
           std::isnan(switching_strain_) ? kNaN : ptc::temperature_at_strain(law_, switching_strain_)};
}

std::vector<std::string> PtcSelfHeating::columns() const {
  return {"ptc_self_heating_contacts",
          "ptc_self_heating_conducting",
          "ptc_self_heating_coordination",
          "ptc_self_heating_eps0_mean",
          "ptc_self_heating_eps0_max",
          "ptc_self_heating_switching_strain",
          "ptc_self_heating_switching_temperature"};
}

std::vector<double> PtcSelfHeating::column_values(const State&) const { return held_; }

void PtcSelfHeating::visit(Archive& ar, const std::string& prefix) {
  // The factorised network is rebuilt from the (frozen) positions on the first call after a
  // restart (deterministic); the displacements are a particle field. Only the held columns here.
  std::vector<double> held = held_;
  ar.visit(prefix + "/held", held);
  if (ar.reading()) {
    if (held.size() != held_.size())
      throw SetupError("checkpoint ptc_self_heating state has " + std::to_string(held.size()) + " values, expected " +
                       std::to_string(held_.size()));
    held_ = held;
  }
}

}  // namespace sparkdem::physics
