#include "physics/mechanics/torsion_test.hpp"

#include <cmath>
#include <limits>
#include <map>
#include <string>

#include "engine/core/error.hpp"
#include "engine/core/format.hpp"
#include "engine/state/state.hpp"
#include "engine/core/numbers.hpp"
#include "physics/mechanics/resistance_trend.hpp"

namespace sparkdem::physics {

namespace {
const std::string kKey = "torsion/";

const std::vector<double>& set_field(const State& s, const std::string& name) {
  if (!s.particles.fields.has("set/" + name))
    throw SetupError("torsion_test: particle set '" + name + "' is not defined (list it in the stage's \"sets\")");
  return s.particles.fields.data("set/" + name);
}

double mark(const State& s, const std::string& k) {
  const auto it = s.marks.find(kKey + k);
  return it == s.marks.end() ? kNaN : it->second;
}

/// Local index of the member of `set` with the smallest global id (-1 if empty).
Index reference_member(const State& s, const std::vector<double>& set) {
  Index best = -1;
  for (std::size_t i = 0; i < set.size(); ++i)
    if (set[i] > 0.5 && (best < 0 || s.particles.id[i] < s.particles.id[static_cast<std::size_t>(best)])) best = static_cast<Index>(i);
  return best;
}

/// Axial coordinate of the centroid of a set.
double axial_centroid(const State& s, const std::vector<double>& set, const Vec3& c, const Vec3& a) {
  double z = 0.0, n = 0.0;
  for (std::size_t i = 0; i < set.size(); ++i)
    if (set[i] > 0.5) {
      z += (s.particles.position[i] - c).dot(a);
      n += 1.0;
    }
  return n > 0.0 ? z / n : kNaN;
}

/// A crossing through the persistence filter: a candidate span starts where `cond` first holds,
/// is confirmed (mark kKey + k = the span's first twist) once the twist has advanced by
/// `persistence` with the condition held throughout, and is rejected (counted in k + "/rejected")
/// when it falls back before.
void held(std::map<std::string, double>& m, const std::string& k, bool cond, double theta, double persistence) {
  if (m.count(kKey + k)) return;
  const std::string c = kKey + k + "/candidate";
  if (!cond) {
    if (m.erase(c) > 0) m[kKey + k + "/rejected"] += 1.0;
    return;
  }
  if (!m.count(c)) m[c] = theta;
  if (std::abs(theta - m[c]) >= persistence) m[kKey + k] = m[c];
}

const std::string kTrend = kKey + "trend/";

trend::Sums load_sums(const std::map<std::string, double>& m) {
  trend::Sums t;
  auto get = [&](const std::string& k) {
    const auto it = m.find(kTrend + k);
    return it == m.end() ? 0.0 : it->second;
  };
  for (std::size_t p = 0; p < t.xp.size(); ++p) t.xp[p] = get("xp" + std::to_string(p));
  for (std::size_t p = 0; p < t.xu.size(); ++p) t.xu[p] = get("xu" + std::to_string(p));
  t.uu = get("uu");
  return t;
}

void store_sums(std::map<std::string, double>& m, const trend::Sums& t) {
  for (std::size_t p = 0; p < t.xp.size(); ++p) m[kTrend + "xp" + std::to_string(p)] = t.xp[p];
  for (std::size_t p = 0; p < t.xu.size(); ++p) m[kTrend + "xu" + std::to_string(p)] = t.xu[p];
  m[kTrend + "uu"] = t.uu;
}
}  // namespace

ParamSpec<TorsionTest::Params> TorsionTest::spec() {
  ParamSpec<Params> s("torsion_test", "module",
                      "pin torsion measurements (seed 001 Fig. 16): twist, reaction torque, surface shear stress, elastic "
                      "reference G J theta / L, R / R0 of the electrical network, onset twists (first broken bond, "
                      "resistance rise, separation)");
  s.add("clamped", &Params::clamped).doc("particle set of the clamped end");
  s.add("twisted", &Params::twisted).doc("particle set of the turned end (prescribed angular_velocity)");
  s.add_vec3("axis_point", &Params::axis_point).unit("m").doc("a point of the pin axis (torque reference)");
  s.add_vec3("axis", &Params::axis).unit("1").doc("pin axis direction");
  s.add("radius", &Params::radius).unit("m").positive().required().doc("pin radius r");
  s.add("length", &Params::length).unit("m").nonnegative().doc("L of the elastic reference (0: axial distance of the end-set centroids)");
  s.add("shear_modulus", &Params::shear_modulus).unit("Pa").positive().required().doc("G of the elastic reference G J theta / L");
  s.add("yield_shear_stress", &Params::yield_shear_stress).unit("Pa").positive().required().doc("tau_y");
  s.add("resistance_signal", &Params::resistance_signal).doc("signal holding the resistance (\"\": none)");
  s.add("resistance_threshold", &Params::resistance_threshold)
      .unit("1")
      .positive()
      .doc("the resistance onset is the first twist where R / R0 - 1 exceeds this");
  s.add("resistance_jump_ratio", &Params::resistance_jump_ratio)
      .unit("1")
      .positive()
      .doc("the jump onset is the first twist where R / R0 reaches this (2: R doubled)");
  s.add("resistance_persistence", &Params::resistance_persistence)
      .unit("rad")
      .nonnegative()
      .doc("a resistance crossing counts only if it holds over this twist span (0: unfiltered)");
  s.add("resistance_trend_fit_twist", &Params::resistance_trend_fit_twist)
      .unit("rad")
      .nonnegative()
      .doc("the elastic trend of R / R0 (a quadratic in the twist) is fitted over the twists up to this; past it, the "
           "trend onset is the first twist where R / R0 departs from the trend (either sign) by more than the threshold, "
           "held over resistance_persistence (0: no trend onset)");
  s.add("resistance_trend_sigmas", &Params::resistance_trend_sigmas)
      .unit("1")
      .positive()
      .doc("trend onset threshold: this many residual standard deviations of the trend fit, plus resistance_trend_floor");
  s.add("resistance_trend_floor", &Params::resistance_trend_floor)
      .unit("1")
      .nonnegative()
      .doc("added to the trend onset threshold: a relative change of R the network solver cannot resolve");
  s.add("report_twists", &Params::report_twists)
      .unit("rad")
      .doc("twists at which R / R0 is recorded (columns torsion_resistance_ratio_at_<twist>)");
  return s;
}

TorsionTest::TorsionTest(const Params& p) : p_(p) {
  if (!(p.axis.norm() > 0.0)) throw ConfigError("/axis", "expected a non-zero axis direction, found [0, 0, 0]");
  a_ = p.axis.normalized();
}

std::string TorsionTest::report_column(double theta) { return "torsion_resistance_ratio_at_" + format_number(theta); }

void TorsionTest::declare(Declarations& d) const {
  if (!p_.resistance_signal.empty()) d.reads.push_back("signal/" + p_.resistance_signal);
}

void TorsionTest::bind(State& s) {
  const auto& twisted = set_field(s, p_.twisted);
  const auto& clamped = set_field(s, p_.clamped);
  auto& m = s.marks;
  if (!m.count(kKey + "ref_id")) {  // first call ever: the references
    const Index r = reference_member(s, twisted);
    if (r < 0) throw SetupError("torsion_test: the twisted set '" + p_.twisted + "' is empty");
    const Quat& q = s.particles.orientation[static_cast<std::size_t>(r)];
    m[kKey + "ref_id"] = static_cast<double>(s.particles.id[static_cast<std::size_t>(r)]);
    m[kKey + "q0_w"] = q.w();
    m[kKey + "q0_x"] = q.x();
    m[kKey + "q0_y"] = q.y();
    m[kKey + "q0_z"] = q.z();
    m[kKey + "broken0"] = static_cast<double>(s.bonds.broken_count());
    const double L = p_.length > 0.0
                         ? p_.length
                         : std::abs(axial_centroid(s, twisted, p_.axis_point, a_) - axial_centroid(s, clamped, p_.axis_point, a_));
    if (!(L > 0.0)) throw SetupError("torsion_test: the end sets have no axial distance; set `length`");
    m[kKey + "length"] = L;
  }
}

void TorsionTest::advance(State& s, const StepInfo&) {
  auto& m = s.marks;
  const std::vector<double> v = column_values(s);
  const double theta = v[0], ratio = v[7];
  if (!p_.resistance_signal.empty() && !m.count(kKey + "R0")) {
    const auto it = m.find("signal/" + p_.resistance_signal);
    if (it != m.end() && it->second > 0.0) m[kKey + "R0"] = it->second;
  }
  auto first = [&](const std::string& k, bool cond) {
    if (cond && !m.count(kKey + k)) m[kKey + k] = theta;
  };
  const bool intact = !(static_cast<double>(s.bonds.broken_count()) > m[kKey + "broken0"]);
  if (intact && std::isfinite(theta) && std::isfinite(v[1])) {  // least-squares T = k theta before the first break
    m[kKey + "fit_tt"] += theta * theta;
    m[kKey + "fit_tT"] += theta * v[1];
  }
  first("onset_break", !intact);
  // Resistance crossings through the persistence filter (held above).
  const double span = p_.resistance_persistence;
  held(m, "onset_resistance", ratio - 1.0 > p_.resistance_threshold, theta, span);
  held(m, "jump", ratio >= p_.resistance_jump_ratio, theta, span);
  held(m, "separation", std::isinf(ratio), theta, span);
  advance_trend(s, theta, ratio);
  for (double t : p_.report_twists) {
    const std::string k = "report/" + format_number(t);
    if (std::abs(theta) >= t && !m.count(kKey + k)) m[kKey + k] = ratio;
  }
}

void TorsionTest::advance_trend(State& s, double theta, double ratio) {
  const double fit_twist = p_.resistance_trend_fit_twist;
  if (!(fit_twist > 0.0) || std::isnan(theta) || std::isnan(ratio)) return;
  auto& m = s.marks;
  // A sample is each new value of R (R is held between re-solves) at the twist of its re-solve:
  // a held value compared with the trend at a later twist would ripple with the re-solve interval.
  const auto last = m.find(kTrend + "last");
  const bool fresh = last == m.end() || last->second != ratio;
  if (fresh) {
    m[kTrend + "last"] = ratio;
    m[kTrend + "last_twist"] = theta;
  }
  if (std::abs(theta) <= fit_twist) {
    if (fresh && std::isfinite(ratio)) {
      trend::Sums t = load_sums(m);
      t.add(theta / fit_twist, ratio - 1.0);
      store_sums(m, t);
    }
    return;
  }
  held(m, "onset_trend", std::abs(trend_departure(s)) > 1.0, theta, p_.resistance_persistence);
}

double TorsionTest::trend_departure(const State& s) const {
  const double last = mark(s, "trend/last"), twist = mark(s, "trend/last_twist");
  if (!(p_.resistance_trend_fit_twist > 0.0) || std::isnan(last) || !(std::abs(twist) > p_.resistance_trend_fit_twist))
    return kNaN;
  return trend::departure(trend::fit(load_sums(s.marks)), twist / p_.resistance_trend_fit_twist, last - 1.0,
                          p_.resistance_trend_sigmas, p_.resistance_trend_floor);
}

std::vector<std::string> TorsionTest::columns() const {
  std::vector<std::string> c = {"torsion_twist",
                                "torsion_torque",
                                "torsion_torque_twisted_end",
                                "torsion_shear_stress",
                                "torsion_shear_ratio",
                                "torsion_elastic_torque",
                                "torsion_torque_ratio",
                                "torsion_resistance_ratio",
                                "torsion_break_onset_twist",
                                "torsion_resistance_onset_twist",
                                "torsion_separation_twist",
                                "torsion_stiffness_ratio",
                                "torsion_resistance_jump_twist",
                                "torsion_resistance_rejected_rises",
                                "torsion_resistance_rejected_jumps"};
  if (p_.resistance_trend_fit_twist > 0.0)
    for (const char* k : {"torsion_resistance_trend_onset_twist", "torsion_resistance_trend_departure",
                          "torsion_resistance_trend_samples"})
      c.push_back(k);
  for (double t : p_.report_twists) c.push_back(report_column(t));
  return c;
}

std::vector<double> TorsionTest::column_values(const State& s) const {
  std::vector<double> v(columns().size(), kNaN);
  const auto it = s.marks.find(kKey + "ref_id");
  if (it == s.marks.end()) return v;  // before the first call
  const auto& p = s.particles;
  // Twist of the reference member.
  double theta = kNaN;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (static_cast<double>(p.id[i]) == it->second) {
      const Quat q0(mark(s, "q0_w"), mark(s, "q0_x"), mark(s, "q0_y"), mark(s, "q0_z"));
      const Quat rel = p.orientation[i] * q0.conjugate();
      theta = 2.0 * std::atan2(rel.vec().dot(a_), rel.w());
      if (theta > kPi) theta -= 2.0 * kPi;
      if (theta < -kPi) theta += 2.0 * kPi;
    }
  // Torques about the axis on the two end sets.
  const auto& clamped = set_field(s, p_.clamped);
  const auto& twisted = set_field(s, p_.twisted);
  double tc = 0.0, tt = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double t = ((p.position[i] - p_.axis_point).cross(p.force[i]) + p.torque[i]).dot(a_);
    if (clamped[i] > 0.5) tc += t;
    if (twisted[i] > 0.5) tt -= t;
  }
  const double r = p_.radius, J = kPi * r * r * r * r / 2.0, L = mark(s, "length");
  const double tau = 2.0 * tc / (kPi * r * r * r), Tel = p_.shear_modulus * J * theta / L;
  double ratio = kNaN;
  if (!p_.resistance_signal.empty()) {
    const auto R = s.marks.find("signal/" + p_.resistance_signal);
    const double R0 = mark(s, "R0");
    if (R != s.marks.end()) ratio = R->second < 0.0 ? std::numeric_limits<double>::infinity() : R->second / R0;
  }
  v[0] = theta;
  v[1] = tc;
  v[2] = tt;
  v[3] = tau;
  v[4] = tau / p_.yield_shear_stress;
  v[5] = Tel;
  v[6] = Tel != 0.0 ? tc / Tel : kNaN;
  v[7] = ratio;
  v[8] = mark(s, "onset_break");
  v[9] = mark(s, "onset_resistance");
  v[10] = mark(s, "separation");
  const double fit_tt = mark(s, "fit_tt"), fit_tT = mark(s, "fit_tT");
  v[11] = fit_tt > 0.0 ? fit_tT / fit_tt / (p_.shear_modulus * J / L) : kNaN;
  v[12] = mark(s, "jump");
  const double rejected_rises = mark(s, "onset_resistance/rejected"), rejected_jumps = mark(s, "jump/rejected");
  v[13] = std::isnan(rejected_rises) ? 0.0 : rejected_rises;
  v[14] = std::isnan(rejected_jumps) ? 0.0 : rejected_jumps;
  std::size_t next = 15;
  if (p_.resistance_trend_fit_twist > 0.0) {
    v[next++] = mark(s, "onset_trend");
    v[next++] = trend_departure(s);
    v[next++] = load_sums(s.marks).n();
  }
  for (std::size_t k = 0; k < p_.report_twists.size(); ++k) v[next + k] = mark(s, "report/" + format_number(p_.report_twists[k]));
  return v;
}

}  // namespace sparkdem::physics
