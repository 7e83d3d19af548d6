#include "physics/control/temperature_controller.hpp"

#include <algorithm>
#include <cmath>

#include "engine/core/error.hpp"
#include "engine/state/particle_set.hpp"
#include "engine/state/state.hpp"
#include "physics/thermal/temperature_history.hpp"

namespace sparkdem::physics {

namespace control {
PiState pi_step(const PiState& s, double error, double dt, double kp, double ki, double feedforward, double lo, double hi) {
  PiState n = s;
  const double trial = s.integral + error * dt;
  const double u = feedforward + kp * error + ki * trial;
  const bool high = u > hi && error > 0.0, low = u < lo && error < 0.0;
  if (!high && !low) n.integral = trial;  // conditional integration (anti-windup)
  n.output = std::clamp(feedforward + kp * error + ki * n.integral, lo, hi);
  return n;
}
}  // namespace control

ParamSpec<TemperatureController::Params> TemperatureController::spec() {
  using P = Params;
  ParamSpec<P> s("temperature_controller", "module",
                 "PI control of the supplied electrical power so that the mean temperature of a particle set follows a programmed "
                 "cycle; the voltage sqrt(P R) goes to electrical_network through a signal (voltage_signal)");
  s.add("set", &P::set).required().doc("control particle set (its mean temperature is the controlled value)");
  s.add("time", &P::time).unit("s").required().doc("set-point table times, physical seconds from the stage start, strictly increasing");
  s.add("temperature", &P::temperature).unit("K").required().doc("set-point temperatures");
  s.add("kp", &P::kp).unit("W/K").nonnegative().doc("proportional gain (2 zeta omega C for a lumped capacity C)");
  s.add("ki", &P::ki).unit("W/(K s)").nonnegative().doc("integral gain (omega^2 C)");
  s.add("feedforward_capacity", &P::feedforward_capacity).unit("J/K").nonnegative().doc("feedforward C dT_set/dt (0: off)");
  s.add("max_power", &P::max_power).unit("W").positive().doc("largest supplied power");
  s.add("initial_voltage", &P::initial_voltage).unit("V").nonnegative().doc("voltage before the first electrical solve");
  s.add("signal", &P::signal).doc("name of the voltage signal electrical_network reads (its voltage_signal)");
  s.add("track_after", &P::track_after).unit("s").nonnegative().doc("controller_max_error_after counts |e| after this time");
  return s;
}

TemperatureController::TemperatureController(const Params& p) : p_(p) {
  std::vector<Diagnostic> d;
  if (p.time.size() != p.temperature.size() || p.time.empty())
    d.push_back({"/temperature", "expected one temperature per time (" + std::to_string(p.time.size()) + "), found " +
                                     std::to_string(p.temperature.size())});
  for (std::size_t k = 1; k < p.time.size(); ++k)
    if (!(p.time[k] > p.time[k - 1])) d.push_back({"/time/" + std::to_string(k), "expected strictly increasing times"});
  if (p.signal.empty()) d.push_back({"/signal", "expected a signal name, found \"\""});
  if (!d.empty()) throw ConfigError(d);
}

void TemperatureController::declare(Declarations& d) const {
  d.reads_previous = {"temperature", "signal/electrical_resistance"};
  d.writes = {"signal/" + p_.signal};
}

double TemperatureController::setpoint(double t) const { return thermal::table_temperature(p_.time, p_.temperature, t); }

double TemperatureController::measured(const State& s) const {
  // Capacity-weighted mean (the temperature of the set's heat content), arithmetic without capacities.
  const auto& f = s.particles.fields.data("set/" + p_.set);
  const auto& T = s.particles.fields.data("temperature");
  const std::vector<double>* C = s.particles.fields.has("heat_capacity") ? &s.particles.fields.data("heat_capacity") : nullptr;
  double sum = 0.0, w = 0.0;
  for (std::size_t i = 0; i < f.size(); ++i)
    if (f[i] > 0.5) {
      const double c = C && (*C)[i] > 0.0 ? (*C)[i] : 1.0;
      sum += c * T[i];
      w += c;
    }
  return w > 0.0 ? sum / w : std::nan("");
}

void TemperatureController::bind(State& s) {
  const auto& f = set_field(s, p_.set, "temperature_controller");
  if (std::none_of(f.begin(), f.end(), [](double x) { return x > 0.5; }))
    throw SetupError("temperature_controller: the control set '" + p_.set + "' holds no particle");
  if (restored_) {
    restored_ = false;
    return;
  }
  pi_ = control::PiState{};
  max_error_after_ = 0.0;
  last_setpoint_ = setpoint(0.0);
  last_voltage_ = p_.initial_voltage;
  s.marks["signal/" + p_.signal] = last_voltage_;
  if (s.particles.fields.has("temperature")) last_temperature_ = measured(s);
}

void TemperatureController::advance(State& s, const StepInfo& info) {
  const double t = info.time - s.stage_phys_t0;  // physical time since the stage start, end of this step
  const double Tc = measured(s);
  if (!std::isfinite(Tc)) throw PhysicsError(info.step, {}, "temperature", "temperature_controller: the control temperature is not finite");
  const double Ts = setpoint(t);
  const double e = Ts - Tc;
  const double slope = info.dt > 0.0 ? (Ts - setpoint(std::max(0.0, t - info.dt))) / info.dt : 0.0;
  pi_ = control::pi_step(pi_, e, info.dt, p_.kp, p_.ki, p_.feedforward_capacity * slope, 0.0, p_.max_power);
  const auto R = s.marks.find("signal/electrical_resistance");
  const double V = (R != s.marks.end() && std::isfinite(R->second) && R->second > 0.0) ? std::sqrt(pi_.output * R->second)
                                                                                       : p_.initial_voltage;
  s.marks["signal/" + p_.signal] = V;
  last_setpoint_ = Ts;
  last_temperature_ = Tc;
  last_voltage_ = V;
  if (t > p_.track_after) max_error_after_ = std::max(max_error_after_, std::abs(e));
}

std::vector<std::string> TemperatureController::columns() const {
  return {"controller_setpoint", "controller_temperature", "controller_error",
          "controller_power",    "controller_voltage",     "controller_max_error_after"};
}
std::vector<double> TemperatureController::column_values(const State&) const {
  return {last_setpoint_, last_temperature_, last_setpoint_ - last_temperature_, pi_.output, last_voltage_, max_error_after_};
}

void TemperatureController::visit(Archive& ar, const std::string& prefix) {
  std::vector<double> v = {pi_.integral, pi_.output, last_setpoint_, last_temperature_, last_voltage_, max_error_after_};
  ar.visit(prefix + "/state", v);
  if (ar.reading()) {
    if (v.size() != 6) throw SetupError("checkpoint temperature_controller state has " + std::to_string(v.size()) + " values, expected 6");
    pi_ = control::PiState{v[0], v[1]};
    last_setpoint_ = v[2];
    last_temperature_ = v[3];
    last_voltage_ = v[4];
    max_error_after_ = v[5];
    restored_ = true;
  }
}

}  // namespace sparkdem::physics
