#include "engine/watchdog.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/core/parallel.hpp"

namespace sparkdem {

namespace {

const std::string kMarkPrefix = "watchdog/";
const std::string kChecksMark = "watchdog/energy_checks";

std::string num(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", x);
  return buf;
}

/// What to change about the step, from the stage's step and its stable step.
std::string step_advice(const WatchdogContext& ctx) {
  if (!(ctx.dt > 0.0)) return "lower dt";
  if (!std::isfinite(ctx.stable_dt) || !(ctx.stable_dt > 0.0)) return "lower dt (now " + num(ctx.dt) + " s)";
  const double f = ctx.dt / ctx.stable_dt;
  if (f > 1.0)
    return "reduce dt below the stable step " + num(ctx.stable_dt) + " s (dt = " + num(ctx.dt) + " s is " + num(f) + " times it" +
           (ctx.allow_unstable_dt ? ", run with allow_unstable_dt" : "") + ")";
  return "lower dt or dt_fraction (dt = " + num(ctx.dt) + " s is " + num(f) + " of the stable step " + num(ctx.stable_dt) +
         " s at the stage start; stiffer contacts since then lower the stable step)";
}

[[noreturn]] void fail(const State& s, std::vector<Id> ids, const std::string& quantity, const std::string& what, double value,
                       double bound, std::string hint) {
  PhysicsErrorDetail d;
  d.time = s.time;
  d.value = value;
  d.bound = bound;
  d.hint = std::move(hint);
  throw PhysicsError(s.step, std::move(ids), quantity, "watchdog: " + what, std::move(d));
}

bool finite3(const Vec3& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

bool field_ok(double x, FieldCheck c) { return c == FieldCheck::Finite ? std::isfinite(x) : !std::isinf(x); }

/// Check 1: NaN/Inf. Parallel screen first; the detailed serial pass runs only on a failure.
void check_finite(const State& s, const WatchdogContext& ctx) {
  const auto& p = s.particles;
  const std::int64_t n = static_cast<std::int64_t>(p.size());
  bool bad = par::any_of(n, par::kLight, [&](std::int64_t i) {
    return !(finite3(p.position[i]) && finite3(p.velocity[i]) && finite3(p.omega[i]) && finite3(p.force[i]) && finite3(p.torque[i]));
  });
  std::vector<std::string> fields;
  for (const auto& name : p.fields.names()) {
    const FieldCheck c = p.fields.info(name).check;
    if (c == FieldCheck::None) continue;
    fields.push_back(name);
    const auto& f = p.fields.data(name);
    const std::int64_t m = static_cast<std::int64_t>(f.size());
    bad = bad || par::any_of(m, par::kLight, [&](std::int64_t k) { return !field_ok(f[k], c); });
  }
  if (!bad) return;
  // Detail: every quantity with its particles, in the reporting order.
  std::vector<std::pair<std::string, std::vector<Id>>> found;
  for (const auto& name : fields) {
    const auto& f = p.fields.data(name);
    const FieldCheck c = p.fields.info(name).check;
    const std::size_t comps = static_cast<std::size_t>(p.fields.info(name).components);
    std::vector<Id> ids;
    for (std::size_t i = 0; i < p.size(); ++i)
      for (std::size_t q = 0; q < comps; ++q)
        if (!field_ok(f[i * comps + q], c)) {
          ids.push_back(p.id[i]);
          break;
        }
    if (!ids.empty()) found.emplace_back(name, std::move(ids));
  }
  const std::pair<const char*, const std::vector<Vec3>*> core[] = {
      {"force", &p.force}, {"torque", &p.torque}, {"velocity", &p.velocity}, {"omega", &p.omega}, {"position", &p.position}};
  for (const auto& [name, v] : core) {
    std::vector<Id> ids;
    for (std::size_t i = 0; i < p.size(); ++i)
      if (!finite3((*v)[i])) ids.push_back(p.id[i]);
    if (!ids.empty()) found.emplace_back(name, std::move(ids));
  }
  if (found.empty()) return;  // (cannot happen: the screen saw something)
  std::string list;
  for (const auto& [name, ids] : found) list += (list.empty() ? "" : ", ") + name + " of " + std::to_string(ids.size()) + " particle(s)";
  const std::string& q = found.front().first;
  fail(s, found.front().second, q, "non-finite (NaN or infinite) values in " + list, std::numeric_limits<double>::quiet_NaN(),
       std::numeric_limits<double>::quiet_NaN(), step_advice(ctx) + "; or check the parameters of the module or law that writes " + q);
}

/// Check 2: speed above max_speed (or r_i / dt).
void check_speed(const State& s, const WatchdogConfig& c, const WatchdogContext& ctx) {
  const auto& p = s.particles;
  if (!(ctx.dt > 0.0) && !(c.max_speed > 0.0)) return;
  const std::int64_t n = static_cast<std::int64_t>(p.size());
  const bool bad = par::any_of(n, par::kLight, [&](std::int64_t i) {
    const double vmax = c.max_speed > 0.0 ? c.max_speed : p.radius[i] / ctx.dt;
    return p.velocity[i].squaredNorm() > vmax * vmax;
  });
  if (!bad) return;
  struct Hit {
    double ratio, speed, bound;
    Id id;
  };
  std::vector<Hit> hits;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double vmax = c.max_speed > 0.0 ? c.max_speed : p.radius[i] / ctx.dt;
    const double v = p.velocity[i].norm();
    if (v > vmax) hits.push_back({v / vmax, v, vmax, p.id[i]});
  }
  std::stable_sort(hits.begin(), hits.end(), [](const Hit& a, const Hit& b) { return a.ratio > b.ratio; });
  std::vector<Id> ids;
  for (const Hit& h : hits) ids.push_back(h.id);
  const Hit& w = hits.front();
  const std::string rule = c.max_speed > 0.0 ? "watchdog.max_speed" : "its radius per step, r/dt";
  fail(s, ids, "velocity",
       "speed " + num(w.speed) + " m/s of particle " + std::to_string(w.id) + " exceeds the blow-up bound " + num(w.bound) + " m/s (" +
           rule + "); " + std::to_string(hits.size()) + " particle(s) above their bound",
       w.speed, w.bound, step_advice(ctx) + "; if such speeds are physical, raise watchdog.max_speed [m/s]");
}

/// Check 3: overlap / smaller radius of particle pairs. (Walls are not checked: generators such as
/// cpc_fillers place particles across a face, their centres beyond it, on purpose.)
void check_overlap(const State& s, const WatchdogConfig& c, const WatchdogContext& ctx) {
  const double bound = c.max_overlap_ratio > 0.0 ? c.max_overlap_ratio : ctx.law_overlap_bound;
  if (!std::isfinite(bound)) return;
  const auto& p = s.particles;
  const auto& t = s.contacts;
  const auto& ov = t.overlap();
  const std::int64_t rows = static_cast<std::int64_t>(t.size());
  const bool bad = par::any_of(rows, par::kLight, [&](std::int64_t r) { return ov[r] > bound * std::min(p.radius[t.i(r)], p.radius[t.j(r)]); });
  if (!bad) return;
  struct Hit {
    double ratio;
    Id a, b;
  };
  std::vector<Hit> hits;
  for (std::size_t r = 0; r < t.size(); ++r) {
    const double ratio = ov[r] / std::min(p.radius[t.i(r)], p.radius[t.j(r)]);
    if (ratio > bound) hits.push_back({ratio, t.id_i()[r], t.id_j()[r]});
  }
  std::stable_sort(hits.begin(), hits.end(), [](const Hit& a, const Hit& b) { return a.ratio > b.ratio; });
  std::vector<Id> ids;
  for (const Hit& h : hits) {
    ids.push_back(h.a);
    ids.push_back(h.b);
  }
  const Hit& w = hits.front();
  const std::string who = "particles " + std::to_string(w.a) + " and " + std::to_string(w.b);
  const std::string rule = c.max_overlap_ratio > 0.0 ? "watchdog.max_overlap_ratio" : "the contact law's bound";
  fail(s, ids, "overlap",
       "overlap of " + who + " is " + num(w.ratio) + " of the smaller radius, above " + num(bound) + " (" + rule + "); " +
           std::to_string(hits.size()) + " contact(s) above it",
       w.ratio, bound,
       "the particles were pushed together harder or faster than the contact law holds them: lower the loading "
       "(wall speed or pressure, prescribed motion, body force) or raise the contact stiffness, or " +
           step_advice(ctx) + "; if overlaps of this size are intended, raise watchdog.max_overlap_ratio (now " + num(bound) + ")");
}

/// Check 4: kinetic-energy growth over the last energy_window checks.
void check_energy(State& s, const WatchdogConfig& c, const WatchdogContext& ctx) {
  const auto& p = s.particles;
  const std::int64_t n = static_cast<std::int64_t>(p.size());
  double ke = 0.0, m = 0.0;
  // (A fixed-order serial sum: the sample goes into the checkpointed marks and must not depend on
  // the thread count.)
  for (std::int64_t i = 0; i < n; ++i) {
    ke += 0.5 * p.mass[i] * p.velocity[i].squaredNorm() + 0.5 * p.inertia[i] * p.omega[i].squaredNorm();
    m += p.mass[i];
  }
  const double e = m > 0.0 ? ke / m : 0.0;
  const Step W = std::max<Step>(c.energy_window, 1);
  const auto it = s.marks.find(kChecksMark);
  const Step k = it == s.marks.end() ? 0 : static_cast<Step>(it->second);
  s.marks[kChecksMark] = static_cast<double>(k + 1);
  s.marks[kMarkPrefix + "energy/" + std::to_string(k % (W + 1))] = e;
  if (k < W) return;
  // The window's samples, oldest first: growth only counts when it is sustained (no sample
  // below the one before) from a positive start.
  std::vector<double> window;
  for (Step q = k - W; q <= k; ++q) window.push_back(s.marks[kMarkPrefix + "energy/" + std::to_string(q % (W + 1))]);
  const double e_old = window.front();
  if (!(e_old > 0.0) || !(e > c.energy_growth_factor * e_old)) return;
  for (std::size_t q = 1; q < window.size(); ++q)
    if (window[q] < window[q - 1]) return;
  double v_blow = c.max_speed;
  if (!(v_blow > 0.0) && ctx.dt > 0.0 && n > 0) v_blow = *std::min_element(p.radius.begin(), p.radius.end()) / ctx.dt;
  if (!(v_blow > 0.0)) return;
  const double floor = 0.5 * (c.energy_floor_fraction * v_blow) * (c.energy_floor_fraction * v_blow);
  if (!(e > floor)) return;
  std::vector<Index> order(p.size());
  std::iota(order.begin(), order.end(), Index{0});
  auto kin = [&](Index i) { return p.mass[i] * p.velocity[i].squaredNorm() + p.inertia[i] * p.omega[i].squaredNorm(); };
  const std::size_t top = std::min<std::size_t>(10, order.size());
  std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(top), order.end(),
                    [&](Index a, Index b) { return kin(a) > kin(b); });
  std::vector<Id> ids;
  for (std::size_t q = 0; q < top; ++q) ids.push_back(p.id[order[q]]);
  const double growth = e_old > 0.0 ? e / e_old : std::numeric_limits<double>::infinity();
  fail(s, ids, "kinetic energy",
       "kinetic energy per unit mass grew from " + num(e_old) + " to " + num(e) + " J/kg (x" + num(growth) + ") over the last " +
           std::to_string(W * c.check_every) + " steps, above the growth bound x" + num(c.energy_growth_factor) +
           " (watchdog.energy_growth_factor), growing at every check, with an rms speed above " + num(c.energy_floor_fraction) +
           " of the blow-up speed " + num(v_blow) + " m/s: a numerical instability",
       growth, c.energy_growth_factor, step_advice(ctx) + "; watchdog.energy_growth_factor = 0 turns this check off");
}

}  // namespace

void watchdog_reset(State& s) {
  std::erase_if(s.marks, [](const auto& kv) { return kv.first.rfind(kMarkPrefix, 0) == 0; });
}

void watchdog_check(State& s, const WatchdogConfig& c, const WatchdogContext& ctx, bool energy) {
  check_finite(s, ctx);
  check_speed(s, c, ctx);
  check_overlap(s, c, ctx);
  if (energy && c.energy_growth_factor > 0.0) check_energy(s, c, ctx);
}

}  // namespace sparkdem
