#include "physics/thermal/temperature_history.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "engine/core/error.hpp"
#include "engine/core/format.hpp"

namespace sparkdem::physics {

namespace thermal {
double table_temperature(const std::vector<double>& t, const std::vector<double>& T, double time) {
  if (time <= t.front()) return T.front();
  if (time >= t.back()) return T.back();
  // first k with t[k] > time (k >= 1 since time > t.front())
  const std::size_t k = static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), time) - t.begin());
  const double s = (time - t[k - 1]) / (t[k] - t[k - 1]);
  return T[k - 1] + s * (T[k] - T[k - 1]);
}
}  // namespace thermal

ParamSpec<TemperatureHistory::Params> TemperatureHistory::spec() {
  ParamSpec<Params> s("temperature_history", "module",
                      "prescribed uniform temperature T(t) (piecewise linear in physical time from the stage start, held "
                      "beyond the ends) written to the particle field `temperature`, and thermal expansion of the radii "
                      "r = r_ref (1 + alpha_T (T - T_0)) with constant mass; column `temperature`");
  s.add("time", &Params::time).unit("s").required().doc("table times, physical seconds from the stage start, strictly increasing");
  s.add("temperature", &Params::temperature).unit("K").required().doc("temperature at each time (> 0)");
  s.add("expansion_coefficient", &Params::expansion_coefficient)
      .unit("1/K")
      .doc("alpha_T, linear thermal expansion coefficient (0: radii unchanged)");
  s.add("start_from_current", &Params::start_from_current)
      .doc(
          "replace the first tabulated temperature by the particles' mean temperature at the stage start (cooling a state taken hot, e.g. "
          "a snapshot)");
  s.add("reference_temperature", &Params::reference_temperature)
      .unit("K")
      .positive()
      .doc(
          "T_0: the radii when the reference radii are first captured are the radii at this temperature (keep it the same in every stage)");
  return s;
}

TemperatureHistory::TemperatureHistory(const Params& p) : p_(p) {
  std::vector<Diagnostic> d;
  if (p.time.empty()) d.push_back({"/time", "expected at least one time [s], found none"});
  if (p.temperature.size() != p.time.size())
    d.push_back({"/temperature", "expected " + std::to_string(p.time.size()) + " temperatures [K] (one per time), found " +
                                     std::to_string(p.temperature.size())});
  for (std::size_t k = 1; k < p.time.size(); ++k)
    if (!(p.time[k] > p.time[k - 1]))
      d.push_back({"/time/" + std::to_string(k),
                   "expected times increasing strictly, found " + format_number(p.time[k]) + " s after " + format_number(p.time[k - 1]) + " s"});
  for (std::size_t k = 0; k < p.temperature.size(); ++k) {
    if (!(p.temperature[k] > 0.0) || !std::isfinite(p.temperature[k]))
      d.push_back({"/temperature/" + std::to_string(k), "expected a finite temperature > 0 K, found " + format_number(p.temperature[k])});
    else if (!(thermal::expanded_radius(1.0, p.expansion_coefficient, p.temperature[k], p.reference_temperature) > 0.0))
      d.push_back({"/expansion_coefficient", "expected 1 + alpha_T (T - T_0) > 0 for every tabulated T, found " +
                                                 format_number(1.0 + p.expansion_coefficient * (p.temperature[k] - p.reference_temperature)) +
                                                 " at T = " + format_number(p.temperature[k]) + " K"});
  }
  if (!d.empty()) throw ConfigError(d);
  current_ = p_.temperature.front();
  table_ = p_.temperature;
}

void TemperatureHistory::declare(Declarations& d) const {
  d.particle_fields.push_back({"temperature", 1, "K", 0.0, true, FieldCheck::Finite});
  d.writes = {"temperature"};
  if (p_.expansion_coefficient != 0.0) thermal::declare_expansion(d);
}

void TemperatureHistory::bind(State& s) {
  if (restored_) {  // resumed mid-stage: temperature, radii and references come from the checkpoint
    restored_ = false;
    return;
  }
  auto& p = s.particles;
  table_ = p_.temperature;
  if (p_.start_from_current && p.size() > 0) {
    // The field exists (declared); a state that never had a temperature module holds 0 there.
    const auto& f = p.fields.data("temperature");
    double sum = 0.0;
    for (double x : f) sum += x;
    const double mean = sum / static_cast<double>(f.size());
    if (!(mean > 0.0))
      throw SetupError(
          "temperature_history: start_from_current needs the particles' temperature, but the state has none "
          "(no earlier stage prescribed one)");
    table_.front() = mean;
  }
  if (p_.expansion_coefficient != 0.0) thermal::capture_reference_radii(s, p_.reference_temperature, "temperature_history");
  apply(s, temperature_at(0.0));  // the stage's first force pass sees T(0)
}

void TemperatureHistory::apply(State& s, double T) {
  auto& p = s.particles;
  current_ = T;
  auto& f = p.fields.data("temperature");
  std::fill(f.begin(), f.end(), T);
  if (p_.expansion_coefficient != 0.0) thermal::apply_expansion(s, p_.expansion_coefficient, p_.reference_temperature, T);
}

void TemperatureHistory::advance(State& s, const StepInfo& step) {
  // step.time = stage_phys_t0 + time_scale * (mechanical stage time): the table time is the
  // physical time since the stage start.
  apply(s, temperature_at(step.time - s.stage_phys_t0));
}

void TemperatureHistory::visit(Archive& ar, const std::string& prefix) {
  ar.visit(prefix + "/temperature", current_);
  if (p_.start_from_current) {
    double t0 = table_.front();
    ar.visit(prefix + "/start_temperature", t0);
    table_.front() = t0;
  }
  if (ar.reading()) restored_ = true;
}

}  // namespace sparkdem::physics
