#include <cstdio>
#include "engine/simulation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#include "engine/core/error.hpp"
#include "engine/core/interrupt.hpp"
#include "engine/core/memory.hpp"
#include "engine/integrate/velocity_verlet.hpp"
#include "engine/state/pair_transfer.hpp"
#include "engine/core/parallel.hpp"

namespace {
/// A number with 6 significant digits (std::to_string prints 1e-9 s as 0.000000).
std::string fmt_g(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}
}  // namespace

namespace sparkdem {

namespace {

/// Per-particle mass factor of a stage with mass scaling (see StageConfig::mass_floor_radius).
const std::string kMassFactorField = "mass_factor";

/// Divides masses and inertias by the per-particle factors of a mass-scaled stage and drops them
/// (no-op without the field).
void undo_mass_factors(ParticleStore& p) {
  if (!p.fields.has(kMassFactorField)) return;
  const auto& f = p.fields.data(kMassFactorField);
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.mass[i] /= f[i];
    p.inertia[i] /= f[i];
  }
  p.fields.remove(kMassFactorField);
}

const std::vector<std::string> kCoreFields = {"position", "velocity", "orientation", "omega",  "force",
                                              "torque",   "radius",   "mass",        "inertia"};

/// Area a pressure-controlled plane acts on when none is given: the cross-section of the first
/// cylinder wall (the die), or 0.
double die_area(const std::vector<Wall>& walls) {
  for (const auto& w : walls)
    if (!w.is_plane()) return kPi * w.cylinder_radius() * w.cylinder_radius();
  return 0.0;
}

}  // namespace

std::vector<std::string> prescribed_set_columns(const std::string& name) {
  std::vector<std::string> c;
  for (const char* x : {"_count", "_fx", "_fy", "_fz", "_tx", "_ty", "_tz", "_angle"}) c.push_back("set_" + name + x);
  return c;
}

std::vector<std::string> builtin_columns(const State& s) {
  std::vector<std::string> c = {"step",      "time",           "physical_time",           "stage",
                                "particles", "kinetic_energy", "kinetic_energy_per_mass", "max_speed",
                                "contacts",  "coordination",   "max_overlap_ratio"};
  if (s.bonds_active) c.insert(c.end(), {"bonds", "bonds_broken", "bonds_elastic_energy", "bonds_max_failure_stress"});
  for (const auto& w : s.walls) {
    c.push_back("wall_" + w.name + "_offset");
    c.push_back("wall_" + w.name + "_normal_force");
    c.push_back("wall_" + w.name + "_fx");
    c.push_back("wall_" + w.name + "_fy");
    c.push_back("wall_" + w.name + "_fz");
    c.push_back("wall_" + w.name + "_work");
  }
  return c;
}

std::vector<double> builtin_values(const State& s, const BondModel* bonds) {
  const auto& p = s.particles;
  double ke = 0.0, m = 0.0, vmax2 = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    ke += 0.5 * p.mass[i] * p.velocity[i].squaredNorm() + 0.5 * p.inertia[i] * p.omega[i].squaredNorm();
    m += p.mass[i];
    vmax2 = std::max(vmax2, p.velocity[i].squaredNorm());
  }
  std::size_t touching = 0;
  double ovr = 0.0;
  const auto& ov = s.contacts.overlap();
  for (std::size_t r = 0; r < s.contacts.size(); ++r) {
    if (ov[r] <= 0.0) continue;
    ++touching;
    ovr = std::max(ovr, ov[r] / std::min(p.radius[s.contacts.i(r)], p.radius[s.contacts.j(r)]));
  }
  for (const auto& w : s.walls)
    for (std::size_t i = 0; i < p.size(); ++i) {
      Vec3 n;
      double d;
      w.distance(p.position[i], n, d);
      if (d < p.radius[i]) ovr = std::max(ovr, (p.radius[i] - d) / p.radius[i]);
    }
  std::vector<double> v = {static_cast<double>(s.step),
                           s.time,
                           s.physical_time,
                           static_cast<double>(s.stage_index),
                           static_cast<double>(p.size()),
                           ke,
                           m > 0.0 ? ke / m : 0.0,
                           std::sqrt(vmax2),
                           static_cast<double>(touching),
                           p.size() ? 2.0 * static_cast<double>(touching) / static_cast<double>(p.size()) : 0.0,
                           ovr};
  if (s.bonds_active) {
    v.push_back(static_cast<double>(s.bonds.intact_count()));
    v.push_back(static_cast<double>(s.bonds.broken_count()));
    v.push_back(bonds ? bonds->elastic_energy(p, s.bonds) : std::numeric_limits<double>::quiet_NaN());
    v.push_back(bonds ? bonds->max_failure_stress(p, s.bonds) : std::numeric_limits<double>::quiet_NaN());
  }
  for (const auto& w : s.walls) {
    v.push_back(w.u);
    v.push_back(w.normal_force);
    v.push_back(w.force[0]);
    v.push_back(w.force[1]);
    v.push_back(w.force[2]);
    v.push_back(w.work);
  }
  return v;
}

void Simulation::sample(std::vector<std::string>& cols, std::vector<double>& vals) const {
  cols = builtin_columns(s_);
  vals = builtin_values(s_, bond_law_);
  if (adaptive_) {  // the step in use (fixed-step stages keep their columns as they were)
    cols.push_back("dt");
    vals.push_back(s_.stage_dt);
  }
  const double t_stage = s_.time - s_.stage_t0;
  for (const auto& [name, m] : prescribed_) {
    const auto& f = s_.particles.fields.data("set/" + name);
    const auto& p = s_.particles;
    const Vec3 c = m.center + t_stage * m.velocity;
    Vec3 F = Vec3::Zero(), T = Vec3::Zero();
    double n = 0.0;
    for (std::size_t i = 0; i < f.size(); ++i)
      if (f[i] > 0.5) {
        F += p.force[i];
        T += (p.position[i] - c).cross(p.force[i]) + p.torque[i];
        n += 1.0;
      }
    const auto names = prescribed_set_columns(name);
    cols.insert(cols.end(), names.begin(), names.end());
    vals.insert(vals.end(), {n, F[0], F[1], F[2], T[0], T[1], T[2], m.angular_velocity.norm() * t_stage});
  }
  for (const Monitor* m : monitors_) {
    auto c = m->columns(s_);
    auto v = m->values(s_);
    cols.insert(cols.end(), c.begin(), c.end());
    vals.insert(vals.end(), v.begin(), v.end());
  }
  for (const Module* m : modules_) {
    auto c = m->columns();
    auto v = m->column_values(s_);
    if (c.size() != v.size())
      throw SetupError("module '" + m->name() + "' reports " + std::to_string(v.size()) + " values for " + std::to_string(c.size()) +
                       " columns");
    cols.insert(cols.end(), c.begin(), c.end());
    vals.insert(vals.end(), v.begin(), v.end());
  }
}

namespace {

/// Wall history for a law of w state columns (WallHistory): a stage with another law (other
/// columns) starts with fresh history, like the contact table. A state written before the history
/// had rows of its own holds it in the per-particle fields "wall_state/<wall>": their nonzero rows
/// are taken over (by particle id) and the fields dropped. Rows follow the candidate lists when
/// these are valid, else at the next rebuild.
void prepare_wall_history(State& s, int w) {
  WallHistory& h = s.wall_history;
  if (h.width != w) h.reset(w, s.walls.size());
  h.ids.resize(s.walls.size());
  h.rows.resize(s.walls.size());
  auto& fields = s.particles.fields;
  for (std::size_t k = 0; k < s.walls.size(); ++k) {
    const std::string f = "wall_state/" + s.walls[k].name;
    if (!fields.has(f)) continue;
    if (w > 0 && fields.info(f).components == w) {
      const std::vector<double>& v = fields.data(f);
      h.ids[k].clear();
      h.rows[k].clear();
      for (std::size_t i = 0; i < s.particles.size(); ++i) {
        const auto row = v.begin() + static_cast<std::ptrdiff_t>(i * w);
        if (std::all_of(row, row + w, [](double x) { return x == 0.0; })) continue;
        h.ids[k].push_back(s.particles.id[i]);
        h.rows[k].insert(h.rows[k].end(), row, row + w);
      }
    }
    fields.remove(f);
  }
  if (s.wall_candidates.size() == s.walls.size()) h.follow(s.wall_candidates, s.particles.id);
}

}  // namespace

StepPlan Simulation::prepare(const StageConfig& cfg) {
  // Contact law state columns (history is kept if the law's columns are unchanged).
  if (s_.contacts.state_columns() != law_.state_columns()) s_.contacts.set_state_columns(law_.state_columns());
  alive_rule_ = law_.alive_rule();
  prepare_wall_history(s_, static_cast<int>(law_.state_columns().size()));
  if (bond_law_ && s_.bonds.state_columns() != bond_law_->state_columns()) {
    if (s_.bonds.size() > 0 && !s_.bonds.state_columns().empty())
      throw SetupError("the bonds carry state columns of another bond law than '" + bond_law_->name() + "'");
    s_.bonds.set_state_columns(bond_law_->state_columns());
  }
  s_.bonds_active = bond_law_ != nullptr;
  if (!bond_law_ && s_.bonds.intact_count() > 0)
    throw SetupError("the state has " + std::to_string(s_.bonds.intact_count()) +
                     " intact bonds but the scenario names no bond law (\"bonds\": {\"law\": ...})");
  for (Module* m : modules_) {
    Declarations d;
    m->declare(d);
    for (const auto& f : d.particle_fields) s_.particles.fields.declare(f, s_.particles.size());
  }
  if (cfg.quasi_static)  // the inertia-free solve's guesses (engine/simulation_quasi_static.cpp)
    for (const auto& wall : s_.walls) s_.particles.fields.declare({quasi_static_slip_field(wall.name), 1, "N s/m", 0.0, false}, s_.particles.size());
  for (Module* m : modules_) m->bind(s_);
  plan_ = build_step_plan(modules_, kCoreFields, bond_law_ != nullptr, cfg.mechanics, cfg.quasi_static);
  // Event clocks keep their references in fields (permuted and checkpointed with the particles).
  for (const PlanItem& it : plan_.items) {
    if (it.kind != PlanItem::Kind::Module || it.clock.kind != Clock::Kind::OnEvent) continue;
    const Trigger& t = it.clock.trigger;
    const std::string base = "trigger/" + it.name + "/";
    if (std::isfinite(t.moved_beyond)) s_.particles.fields.declare({base + "x0", 3, "m", 0.0, false}, s_.particles.size());
    if (!t.field.empty()) {
      const int comps = s_.particles.fields.info(t.field).components;
      s_.particles.fields.declare({base + "field0", comps, s_.particles.fields.info(t.field).unit, 0.0, false}, s_.particles.size());
    }
  }
  return plan_;
}

double Simulation::mechanical_stable_dt() const {
  if (!bond_law_ || s_.bonds.size() == 0) return law_.stable_dt(s_.particles, s_.contacts, s_.walls);
  std::vector<double> rows(s_.particles.size(), 0.0);
  bond_law_->add_stiffness_rows(s_.particles, s_.bonds, rows);
  return law_.stable_dt(s_.particles, s_.contacts, s_.walls, &rows);
}

std::map<std::string, double> Simulation::module_stable_dts() const {
  std::map<std::string, double> out;
  for (const Module* m : modules_) out[m->name()] = m->stable_dt(s_);
  return out;
}

double Simulation::resolve_dt(const StageConfig& cfg) const {
  if (cfg.dt > 0.0) return cfg.dt;
  if (cfg.quasi_static && cfg.mechanics)
    throw SetupError("stage '" + cfg.name + "': a quasi-static stage has no stable step to take a fraction of; set dt (its substeps follow quasi_static.max_strain_increment)");
  if (!cfg.mechanics) {  // frozen: the smallest stable step of the modules, in mechanical time
    double stable = std::numeric_limits<double>::infinity();
    for (const Module* m : modules_) {
      const double scale = m->time_domain() == TimeDomain::Physical ? time_scale_ : 1.0;
      stable = std::min(stable, m->stable_dt(s_) / scale);
    }
    if (!std::isfinite(stable))
      throw SetupError("stage '" + cfg.name + "': a frozen stage with dt_fraction needs a module with a finite stable step; set dt");
    return cfg.dt_fraction * stable;
  }
  const double stable = mechanical_stable_dt();
  if (!std::isfinite(stable))
    throw SetupError("stage '" + cfg.name + "': dt_fraction needs a finite stable step, but the contact law gives none; set dt");
  return cfg.dt_fraction * stable;
}

double Simulation::contact_stable_dt(const StageConfig& cfg) const {
  return cfg.mechanics && !inertia_free_ ? mechanical_stable_dt() : std::numeric_limits<double>::infinity();
}

double Simulation::adaptive_step(const StageConfig& cfg, double previous, double contact_stable) const {
  const AdaptiveDt& a = cfg.adaptive;
  double stable = contact_stable;
  std::string limit = "the contact law";
  for (const PlanItem& it : plan_.items) {  // a fixed-clock module's stable step, as a mechanical step
    if (it.kind != PlanItem::Kind::Module || it.clock.kind == Clock::Kind::AdaptiveSubsteps || it.clock.kind == Clock::Kind::OnEvent)
      continue;
    const double scale = it.module->time_domain() == TimeDomain::Physical ? time_scale_ : 1.0;
    const double m = it.module->stable_dt(s_) / (it.clock.dt(1.0) * scale);
    if (m < stable) {
      stable = m;
      limit = "module '" + it.name + "'";
    }
  }
  if (!std::isfinite(stable) && !std::isfinite(a.max))
    throw SetupError("stage '" + cfg.name + "': an adaptive step needs a finite stable step or dt.max, and the state gives none");
  if (a.fraction * stable < a.min)
    throw PhysicsError(s_.step, {}, "time step",
                       "the adaptive step " + fmt_g(a.fraction) + " x " + fmt_g(stable) + " s (the stable step of " + limit +
                           ") fell below dt.min = " + fmt_g(a.min) + " s; lower dt.min");
  const double dt = std::min({a.fraction * stable, a.max, previous * a.growth});
  if (!(dt > 0.0) || !std::isfinite(dt))
    throw PhysicsError(s_.step, {}, "time step", "the adaptive step is " + fmt_g(dt) + " s (the stable step of " + limit + " is " + fmt_g(stable) + " s)");
  return dt;
}

double Simulation::next_landing(const StageConfig& cfg, double elapsed) const {
  // A target within a millionth of a step of `elapsed` counts as reached (round-off of the sums).
  const double eps = 1e-6 * s_.stage_dt;
  double next = cfg.duration;
  if (cfg.frame_every_s > 0.0) {
    double n = std::floor((elapsed + eps) / cfg.frame_every_s) + 1.0;
    while (n * cfg.frame_every_s <= elapsed + eps) n += 1.0;  // (the division may round down)
    next = std::min(next, n * cfg.frame_every_s);
  }
  for (const Wall& w : s_.walls) {
    const double s = w.motion.physical_time ? time_scale_ : 1.0;  // table times in physical seconds
    for (const auto* times : {&w.motion.table_time, &w.motion.pressure_time})
      for (const double t : *times)
        if (t / s > elapsed + eps) {
          next = std::min(next, t / s);
          break;
        }
  }
  return next;
}

void Simulation::adapt_step(const StageConfig& cfg, Observer& obs) {
  const double old = s_.stage_dt;
  const double stable_now = contact_stable_dt(cfg);
  if (old > stable_now) {
    s_.marks["adaptive/overshoots"] += 1.0;
    obs.event("stage '" + cfg.name + "' step " + std::to_string(s_.step) + ": the step in use " + fmt_g(old) +
             " s exceeded the stable step " + fmt_g(stable_now) + " s of the state (it stiffened between two checks)");
  }
  const double dt = adaptive_step(cfg, old, stable_now);
  if (dt == old) return;
  s_.marks["adaptive/changes"] += 1.0;
  s_.marks["adaptive/min"] = std::min(s_.marks["adaptive/min"], dt);
  s_.marks["adaptive/max"] = std::max(s_.marks["adaptive/max"], dt);
  // The history (for the median) records a move of 1 % from its last value: bounded however
  // long the stage, at a cost of 1 % in the median.
  if (std::abs(dt - s_.dt_history.back()) >= 0.01 * s_.dt_history.back()) {
    s_.dt_history.push_back(static_cast<double>(s_.step - s_.stage_step0));
    s_.dt_history.push_back(dt);
  }
  s_.stage_dt = dt;
  // Logged when it has moved by 10 % since the last line (a step creeping at every check would
  // fill the log), and when it reaches dt.max.
  if (!(logged_dt_ > 0.0) || std::abs(dt - logged_dt_) >= 0.1 * logged_dt_ || (dt == cfg.adaptive.max && old != dt)) {
    obs.event("stage '" + cfg.name + "' step " + std::to_string(s_.step) + ": dt " + fmt_g(logged_dt_) + " -> " + fmt_g(dt) + " s since the last line (" +
              (dt < old ? "the state stiffened" : "the state softened") + "; stable step of the contact law now " + fmt_g(stable_now) + " s)");
    logged_dt_ = dt;
  }
}

void Simulation::adaptive_stats(StageResult& res) const {
  const auto& h = s_.dt_history;
  const double steps = static_cast<double>(s_.step - s_.stage_step0);
  std::vector<std::pair<double, double>> spans;  // (dt, steps taken at it)
  for (std::size_t k = 0; k + 1 < h.size(); k += 2) {
    const double end = k + 2 < h.size() ? h[k + 2] : steps;
    spans.emplace_back(h[k + 1], end - h[k]);
  }
  StageResult::AdaptiveStats a = *res.adaptive;  // the statistics from the state (State::marks): a resumed stage reports its whole run
  const auto mark = [&](const char* k, double fallback) {
    const auto it = s_.marks.find(k);
    return it == s_.marks.end() ? fallback : it->second;
  };
  a.min = mark("adaptive/min", s_.stage_dt);
  a.max = mark("adaptive/max", s_.stage_dt);
  a.changes = static_cast<Step>(mark("adaptive/changes", 0.0));
  a.overshoots = static_cast<Step>(mark("adaptive/overshoots", 0.0));
  std::sort(spans.begin(), spans.end());
  double seen = 0.0;
  a.median = spans.empty() ? s_.stage_dt : spans.back().first;
  for (const auto& [dt, n] : spans) {
    seen += n;
    if (seen >= 0.5 * steps) {
      a.median = dt;
      break;
    }
  }
  res.adaptive = a;
}

void Simulation::update_neighbors(double skin, Step sort_every) {
  auto& p = s_.particles;
  std::vector<double> wall_u;
  for (const auto& w : s_.walls) wall_u.push_back(w.u);
  const bool stale = s_.marks.count("neighbors_stale") > 0 || s_.contacts.has_pending_hand_over();
  if (!stale && s_.wall_candidates.size() == s_.walls.size() && !s_.verlet.needs_rebuild(p.position, p.radius, skin, wall_u)) return;
  s_.marks.erase("neighbors_stale");
  ++s_.rebuilds;
  if (sort_every > 0 && s_.rebuilds % sort_every == 0 && p.size() > 1) {
    // Spatial sort (cells of one mean diameter, z-y-x order) for cache locality.
    double rsum = 0.0;
    Vec3 lo = p.position[0];
    for (std::size_t i = 0; i < p.size(); ++i) {
      rsum += p.radius[i];
      lo = lo.cwiseMin(p.position[i]);
    }
    const double h = 2.0 * rsum / static_cast<double>(p.size());
    std::vector<std::array<std::int64_t, 3>> key(p.size());
    for (std::size_t i = 0; i < p.size(); ++i)
      for (int d = 0; d < 3; ++d) key[i][d] = static_cast<std::int64_t>(std::floor((p.position[i][d] - lo[d]) / h));
    std::vector<Index> perm(p.size());
    std::iota(perm.begin(), perm.end(), 0);
    std::stable_sort(perm.begin(), perm.end(), [&](Index a, Index b) {
      return std::tie(key[a][2], key[a][1], key[a][0]) < std::tie(key[b][2], key[b][1], key[b][0]);
    });
    p.permute(perm);
    s_.contacts.remap_after_permutation(p.id);
    s_.bonds.remap_after_permutation(p.id);
  }
  ContactRebuildRules rules;
  rules.alive = alive_rule_;
  if (s_.bonds.contact_rule == BondTable::ContactRule::Exclude && s_.bonds.intact_count() > 0) rules.excluded = &s_.bonds.intact_keys();
  s_.contacts.rebuild(find_pairs(p.position, p.radius, skin), p.id, p.size(), rules);
  s_.wall_candidates = wall_candidates(s_.walls, p.position, p.radius, skin);
  s_.wall_history.follow(s_.wall_candidates, p.id);
  s_.verlet.mark_built(p.position, p.radius, wall_u);
  // The rebuild freed the old columns, the candidate pairs and its look-up: their pages go back
  // to the system now (the heap is never trimmed otherwise, engine/core/memory.hpp), so a run's
  // resident set follows the rows it holds rather than the most fragmented heap it has seen.
  release_free_memory_every(0.25);
}

void Simulation::rotate_prescribed(double dt, double t_stage_new) {
  auto& p = s_.particles;
  for (const auto& [name, m] : prescribed_) {
    if (!m.rotates()) continue;
    const double w = m.angular_velocity.norm();
    const Quat dq(Eigen::AngleAxisd(w * dt, m.angular_velocity / w));
    const Eigen::Matrix3d R = dq.toRotationMatrix();
    const Vec3 c_old = m.center + (t_stage_new - dt) * m.velocity, c_new = m.center + t_stage_new * m.velocity;
    const auto& f = p.fields.data("set/" + name);
    for (std::size_t i = 0; i < p.size(); ++i) {
      if (f[i] <= 0.5) continue;
      p.position[i] = c_new + R * (p.position[i] - c_old);
      p.orientation[i] = (dq * p.orientation[i]).normalized();
      p.velocity[i] = m.velocity + m.angular_velocity.cross(p.position[i] - c_new);
      p.omega[i] = m.angular_velocity;
    }
  }
}

void Simulation::advance_walls(double t_stage, double dt, double t_area) {
  for (auto& w : s_.walls) {
    const double u_old = w.u;
    const double load = advance_wall(w, t_stage, dt, t_area, time_scale_);
    w.work += load * (w.u - u_old);
  }
}

void Simulation::zero_forces() {
  auto& p = s_.particles;
  const std::int64_t n = static_cast<std::int64_t>(p.size());
  par::for_each(n, par::kLight, [&](std::int64_t i) {
    p.force[i].setZero();
    p.torque[i].setZero();
  });
}

void Simulation::pair_forces(double dt) { law_.pair_forces(s_.particles, s_.contacts, dt, time_scale_, inertia_free_); }

void Simulation::bond_forces(double dt, Step step) {
  if (!bond_law_) return;
  s_.bonds.prepare(s_.particles.size());
  const std::vector<BondFailure> broke = bond_law_->pass(s_.particles, s_.bonds, dt);
  s_.bonds.gather(s_.particles.force, s_.particles.torque);
  // The time at the end of the step being computed (the set-up pass computes step s_.step).
  const double t = s_.time + static_cast<double>(step - s_.step) * dt;
  for (const BondFailure& f : broke) break_bond(s_, f.row, step, t, f.mode);
}

void Simulation::wall_forces(double dt) {
  const WallLoads loads = law_.wall_pass(s_.particles, s_.walls, s_.wall_candidates, s_.wall_history, dt, time_scale_, inertia_free_);
  for (std::size_t k = 0; k < s_.walls.size(); ++k) {
    s_.walls[k].force = loads.force[k];
    s_.walls[k].normal_force = loads.normal[k];
  }
}

void Simulation::compute_forces(double dt, double t_stage) {
  zero_forces();
  pair_forces(dt);
  bond_forces(dt, s_.step);
  wall_forces(dt);
  for (const PlanItem& it : plan_.items)
    if (it.kind == PlanItem::Kind::Module && it.module->phase() == Phase::Force)
      it.module->advance(s_, StepInfo{s_.step, s_.stage_t0 + t_stage, dt, 0});
}

bool Simulation::event_due(const PlanItem& it, Step step) const {
  const std::string base = "trigger/" + it.name + "/";
  const auto last = s_.marks.find(base + "last_step");
  if (last == s_.marks.end()) return true;  // first step of the stage
  const Trigger& t = it.clock.trigger;
  if (t.max_interval > 0 && step - static_cast<Step>(last->second) >= t.max_interval) return true;
  if (t.bond_broke) {
    // (Both marks are written together; a checkpoint that lost one runs the module again.)
    const auto broken = s_.marks.find(base + "broken");
    if (broken == s_.marks.end() || static_cast<double>(s_.bonds.broken_count()) > broken->second) return true;
  }
  const auto& p = s_.particles;
  const std::int64_t n = static_cast<std::int64_t>(p.size());
  if (std::isfinite(t.moved_beyond)) {
    const auto& x0 = p.fields.data(base + "x0");
    const double lim2 = t.moved_beyond * t.moved_beyond;
    const bool moved = par::any_of(n, par::kLight, [&](std::int64_t i) {
      return (p.position[i] - Vec3(x0[3 * i], x0[3 * i + 1], x0[3 * i + 2])).squaredNorm() > lim2;
    });
    if (moved) return true;
  }
  if (!t.field.empty()) {
    const auto& f = p.fields.data(t.field);
    const auto& f0 = p.fields.data(base + "field0");
    for (std::size_t k = 0; k < f.size(); ++k)
      if (std::abs(f[k] - f0[k]) > t.field_change) return true;
  }
  return false;
}

void Simulation::mark_event_run(const PlanItem& it, Step step) {
  const std::string base = "trigger/" + it.name + "/";
  const Trigger& t = it.clock.trigger;
  auto& p = s_.particles;
  s_.marks[base + "last_step"] = static_cast<double>(step);
  s_.marks[base + "broken"] = static_cast<double>(s_.bonds.broken_count());
  if (std::isfinite(t.moved_beyond)) {
    auto& x0 = p.fields.data(base + "x0");
    for (std::size_t i = 0; i < p.size(); ++i)
      for (int d = 0; d < 3; ++d) x0[3 * i + d] = p.position[i][d];
  }
  if (!t.field.empty()) p.fields.data(base + "field0") = p.fields.data(t.field);
}

/// Adaptive stages: the domain time of a module's last call (the stage start's before its first;
/// in State::marks, so that a restart continues it).
double Simulation::last_call_time(const PlanItem& it, double t_start) const {
  const auto m = s_.marks.find("clock/" + it.name + "/last_time");
  return m == s_.marks.end() ? t_start : m->second;
}

void Simulation::run_module(const PlanItem& it, Step step, double t_stage, double dt_m) {
  const auto t_call = std::chrono::steady_clock::now();
  const Clock& c = it.clock;
  const bool physical = it.module->time_domain() == TimeDomain::Physical;
  const double scale = physical ? time_scale_ : 1.0;
  const double t0 = physical ? s_.stage_phys_t0 : s_.stage_t0;  // domain time at the stage start
  const double t_end = t0 + scale * t_stage;                    // domain time at the end of this step
  const double dt = scale * dt_m;
  Step calls = 0, substeps = 1;
  switch (c.kind) {
    case Clock::Kind::EveryStep:
      it.module->advance(s_, StepInfo{step, t_end, dt, 0});
      calls = 1;
      break;
    case Clock::Kind::EveryNSteps:
      if (step % c.n == 0) {
        it.module->advance(s_, StepInfo{step, t_end, adaptive_ ? t_end - last_call_time(it, t0) : static_cast<double>(c.n) * dt, 0});
        if (adaptive_) s_.marks["clock/" + it.name + "/last_time"] = t_end;
        calls = 1;
      }
      break;
    case Clock::Kind::SubstepsPerStep:
    case Clock::Kind::AdaptiveSubsteps: {
      substeps = c.n;
      if (c.kind == Clock::Kind::AdaptiveSubsteps) {
        const double sdt = it.module->stable_dt(s_);
        if (!(sdt > 0.0))
          throw PhysicsError(step, {}, "time step", "module '" + it.name + "' reports a stable step of " + std::to_string(sdt) + " s");
        if (std::isfinite(sdt)) substeps = std::max<Step>(c.n, static_cast<Step>(std::ceil(dt / sdt * (1.0 - 1e-12))));
      }
      const double h = dt / static_cast<double>(substeps);
      const double start = t_end - dt;
      for (Step q = 1; q <= substeps; ++q)
        it.module->advance(s_, StepInfo{step, q == substeps ? t_end : start + static_cast<double>(q) * h, h, q - 1});
      calls = substeps;
      break;
    }
    case Clock::Kind::OnEvent: {
      if (!event_due(it, step)) break;
      const std::string key = "trigger/" + it.name + "/last_step";
      const auto last = s_.marks.find(key);
      const Step since = last == s_.marks.end() ? 1 : step - static_cast<Step>(last->second);
      // (adaptive: the time since its last call, or since the stage start, where it ran before step 0)
      it.module->advance(s_, StepInfo{step, t_end, adaptive_ ? t_end - last_call_time(it, t0) : static_cast<double>(since) * dt, 0});
      if (adaptive_) s_.marks["clock/" + it.name + "/last_time"] = t_end;
      mark_event_run(it, step);
      calls = 1;
      break;
    }
  }
  if (stats_) {
    stats_->module_seconds[it.name] += std::chrono::duration<double>(std::chrono::steady_clock::now() - t_call).count();
    stats_->module_calls[it.name] += calls;
    auto& m = stats_->max_substeps[it.name];
    m = std::max(m, substeps);
  }
}

/// Wall motions of the stage and its prescribed-velocity sets (marked fixed, given their velocity
/// at a fresh start).
void Simulation::bind_walls_and_sets(const StageConfig& cfg, bool resume) {
  auto& p = s_.particles;
  // Prescribed motions start from the current offset.
  for (auto& w : s_.walls) {
    auto it = cfg.motions.find(w.name);
    w.motion = it != cfg.motions.end() ? it->second : WallMotion{};
    if (!resume) {
      w.u_start = w.u;
      w.halted = false;
    }
  }
  // Prescribed-velocity sets: not integrated, moved with their velocity (see verlet_first_half).
  prescribed_ = cfg.prescribed_sets;
  std::vector<std::uint8_t> claimed(p.size(), 0);
  for (const auto& [name, m] : cfg.prescribed_sets) {
    if (!s_.particles.fields.has("set/" + name)) throw SetupError("stage '" + cfg.name + "': particle set '" + name + "' is not defined");
    const auto& f = s_.particles.fields.data("set/" + name);
    for (std::size_t i = 0; i < p.size(); ++i)
      if (f[i] > 0.5) {
        if (claimed[i]++)
          throw SetupError("stage '" + cfg.name + "': particle id " + std::to_string(p.id[i]) + " belongs to two prescribed sets (" + name +
                           " and another)");
        p.fixed[i] = m.rotates() ? 2 : 1;
        if (!resume) {
          p.velocity[i] = m.velocity + m.angular_velocity.cross(p.position[i] - m.center);
          p.omega[i] = m.angular_velocity;
        }
      }
  }
}

/// A fresh stage: its clocks start here, event marks are cleared and the stage's mass factors
/// applied (those of a mass-scaled stage a snapshot came from undone first).
void Simulation::begin_stage(const StageConfig& cfg) {
  auto& p = s_.particles;
  s_.stage_step0 = s_.step;
  s_.stage_t0 = s_.time;
  s_.stage_phys_t0 = s_.physical_time;
  s_.stage_time_scale = cfg.time_scale;
  // Event clocks start afresh: each event module runs at the end of the stage's first step.
  for (const PlanItem& it : plan_.items)
    if (it.kind == PlanItem::Kind::Module)
      std::erase_if(s_.marks, [&](const auto& kv) { return kv.first.rfind("trigger/" + it.name + "/", 0) == 0; });
  // A state saved inside a mass-scaled stage (a snapshot) carries its factors: undo them first,
  // so every stage starts from the true masses.
  undo_mass_factors(p);
  if (cfg.mass_scaling != 1.0 || cfg.mass_floor_radius > 0.0) {
    // The factor of each particle is kept in a field (checkpointed), so the end of the stage
    // undoes exactly what its start did, also after a restart and with radii that changed.
    p.fields.declare(FieldInfo{kMassFactorField, 1, "1", 1.0, false}, p.size());
    auto& f = p.fields.data(kMassFactorField);
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double fines = p.radius[i] < cfg.mass_floor_radius ? std::pow(cfg.mass_floor_radius / p.radius[i], 3) : 1.0;
      f[i] = cfg.mass_scaling * fines;
      p.mass[i] *= f[i];
      p.inertia[i] *= f[i];
    }
  }
}

/// The neighbour skin [m]: the checkpoint's on resume, else the stage's (0: 0.3 x smallest radius).
void Simulation::choose_skin(const StageConfig& cfg, bool resume) {
  const auto& p = s_.particles;
  if (resume) {
    skin_ = s_.stage_skin;
  } else {
    skin_ = cfg.skin;
    if (skin_ <= 0.0) {
      const double rmin = p.size() ? *std::min_element(p.radius.begin(), p.radius.end()) : 0.0;
      skin_ = 0.3 * rmin;
    }
    s_.stage_skin = skin_;
  }
}

/// On resume the stage's step comes from the checkpoint, so the continuation is exact. The
/// checkpoint's clocks must then be those run_stage's stepping loop computes (time = stage_t0 +
/// k dt, physical time = phys_t0 + scale k dt, bit for bit): a checkpoint that breaks them was
/// not written by a run (and a wrong dt could make the stage run for ever).
void Simulation::check_resumed_clocks(const StageConfig& cfg) const {
  // (an adaptive stage's time is the sum of its steps, kept in the checkpoint)
  const double t_stage = cfg.adaptive.on() ? s_.stage_elapsed : static_cast<double>(s_.step - s_.stage_step0) * s_.stage_dt;
  if (cfg.adaptive.on() != !s_.dt_history.empty())
    throw SetupError("stage '" + cfg.name + "': the checkpoint was written by a stage with " +
                     (s_.dt_history.empty() ? "a fixed" : "an adaptive") + " step; the scenario gives it " +
                     (cfg.adaptive.on() ? "an adaptive" : "a fixed") + " one");
  if (!(s_.stage_dt > 0.0) || s_.time != s_.stage_t0 + t_stage || s_.physical_time != s_.stage_phys_t0 + time_scale_ * t_stage)
    throw SetupError("stage '" + cfg.name + "': the checkpoint's clocks are inconsistent (step " + std::to_string(s_.step) +
                     ", stage start step " + std::to_string(s_.stage_step0) + ", dt " + fmt_g(s_.stage_dt) + " s, time " + fmt_g(s_.time) +
                     " s, stage start time " + fmt_g(s_.stage_t0) + " s)");
}

/// What each module will do at step dt_used [s] (printed at the stage start by the I/O layer).
std::vector<ModuleStep> Simulation::module_steps(double dt_used) const {
  std::vector<ModuleStep> out;
  for (const auto& it : plan_.items) {
    if (it.kind != PlanItem::Kind::Module) continue;
    const double scale = it.module->time_domain() == TimeDomain::Physical ? time_scale_ : 1.0;
    ModuleStep ms;
    ms.name = it.name;
    ms.stable_dt = it.module->stable_dt(s_);
    const Clock& c = it.clock;
    const double dtm = dt_used * scale;
    switch (c.kind) {
      case Clock::Kind::EveryStep:
        ms.dt = dtm;
        ms.clock = "every step";
        break;
      case Clock::Kind::EveryNSteps:
        ms.dt = static_cast<double>(c.n) * dtm;
        ms.calls_per_step = 1.0 / static_cast<double>(c.n);
        ms.clock = "every " + std::to_string(c.n) + " steps";
        break;
      case Clock::Kind::SubstepsPerStep:
        ms.dt = dtm / static_cast<double>(c.n);
        ms.calls_per_step = static_cast<double>(c.n);
        ms.clock = std::to_string(c.n) + " substeps per step";
        break;
      case Clock::Kind::AdaptiveSubsteps: {
        Step k = c.n;
        if (std::isfinite(ms.stable_dt) && ms.stable_dt > 0.0)
          k = std::max<Step>(c.n, static_cast<Step>(std::ceil(dtm / ms.stable_dt * (1.0 - 1e-12))));
        ms.dt = dtm / static_cast<double>(k);
        ms.calls_per_step = static_cast<double>(k);
        ms.clock = "adaptive substeps (now " + std::to_string(k) + ")";
        break;
      }
      case Clock::Kind::OnEvent:
        ms.dt = 0.0;
        ms.calls_per_step = 0.0;
        ms.clock = "on event (quasi-static)";
        break;
    }
    out.push_back(ms);
  }
  return out;
}

/// One mechanical step: the plan's items in order; t_new = stage time at the end of the step.
void Simulation::execute_plan(const StageConfig& cfg, double dt_used, double t_new, double t_area) {
  auto& p = s_.particles;
  const bool timed = stats_ && split_timed(s_.step);
  if (timed) ++stats_->core_sampled_steps;
  for (const PlanItem& it : plan_.items) {
    const bool time_item = timed && it.kind != PlanItem::Kind::Module;  // modules time themselves (run_module)
    const auto t0 = time_item ? std::chrono::steady_clock::now() : std::chrono::steady_clock::time_point{};
    switch (it.kind) {
      case PlanItem::Kind::IntegrateFirstHalf:
        verlet_first_half(p, dt_used);
        rotate_prescribed(dt_used, t_new);
        break;
      case PlanItem::Kind::Walls:
        advance_walls(t_new, dt_used, t_area);
        break;
      case PlanItem::Kind::Neighbors:
        update_neighbors(skin_, cfg.sort_every_rebuilds);
        break;
      case PlanItem::Kind::ContactPairs:
        pair_forces(dt_used);
        break;
      case PlanItem::Kind::Bonds:
        bond_forces(dt_used, s_.step + 1);
        break;
      case PlanItem::Kind::ContactWalls:
        wall_forces(dt_used);
        break;
      case PlanItem::Kind::Module:
        run_module(it, s_.step + 1, t_new, dt_used);
        break;
      case PlanItem::Kind::IntegrateSecondHalf:
        verlet_second_half(p, dt_used);
        break;
      case PlanItem::Kind::QuasiStatic:
        quasi_static_step(cfg, dt_used, t_new, t_area);
        break;
    }
    if (time_item) stats_->core_seconds[it.name] += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
}

/// The stage's watchdog settings: its max speed defaults to blowup_speed; a frozen stage or one
/// that takes no step (a one-off evaluation of its modules) moves nothing, so only the non-finite
/// check runs there.
/// A fresh stage's state before step 0: walls at stage time 0, forces, and one run of every
/// event-clock module (a stage of zero steps evaluates them), counted in res.
/// Fixed-clock modules: their step against their own stable step (in their time domain); adaptive
/// clocks choose their substeps from it, event clocks run quasi-static solves. Above it: a
/// SetupError at the stage start, a PhysicsError during the stage (unless allow_unstable_dt).
void Simulation::check_module_steps(const StageConfig& cfg, double dt_used, bool at_start) const {
  for (const auto& it : plan_.items) {
    if (it.kind != PlanItem::Kind::Module) continue;
    const Clock::Kind kind = it.clock.kind;
    if (kind == Clock::Kind::AdaptiveSubsteps || kind == Clock::Kind::OnEvent) continue;
    const double scale = it.module->time_domain() == TimeDomain::Physical ? time_scale_ : 1.0;
    const double mdt = it.clock.dt(dt_used) * scale, sdt = it.module->stable_dt(s_);
    if (!(mdt > sdt) || cfg.allow_unstable_dt) continue;
    const std::string msg = "module '" + it.name + "' runs with dt = " + fmt_g(mdt) + " s above its stable step " + fmt_g(sdt) + " s";
    if (at_start) throw SetupError("stage '" + cfg.name + "': " + msg);
    throw PhysicsError(s_.step, {}, "time step", msg + " of the current state; use an adaptive clock or a smaller step");
  }
}

void Simulation::evaluate_start(double dt_used, double t_area, StageResult& res) {
  if (!inertia_free_) {
    advance_walls(0.0, dt_used, t_area);
    compute_forces(dt_used, 0.0);
  } else {
    // The forces of the start state without advancing any history (a step of zero length); a
    // force-controlled wall stays where it is (the solve moves it).
    for (auto& w : s_.walls)
      if (w.motion.kind != WallMotion::Kind::Pressure || w.halted) advance_wall(w, 0.0, dt_used, t_area, time_scale_);
    compute_forces(0.0, 0.0);
  }
  // Event-clock modules run once on the initial state (a stage of zero steps evaluates them).
  for (const PlanItem& it : plan_.items)
    if (it.kind == PlanItem::Kind::Module && it.clock.kind == Clock::Kind::OnEvent) {
      const bool physical = it.module->time_domain() == TimeDomain::Physical;
      it.module->advance(s_, StepInfo{s_.step, physical ? s_.stage_phys_t0 : s_.stage_t0, 0.0, 0});
      mark_event_run(it, s_.step);
      ++res.module_calls[it.name];
    }
}

WatchdogContext Simulation::watchdog_context(const StageConfig& cfg, double dt, double stable_dt) const {
  WatchdogContext c;
  c.dt = dt;
  c.stable_dt = stable_dt;
  c.allow_unstable_dt = cfg.allow_unstable_dt;
  c.law_overlap_bound = law_.overlap_ratio_bound();
  c.stage = cfg.name;
  return c;
}

void Simulation::release_module_caches() {
  for (const PlanItem& it : plan_.items)
    if (it.kind == PlanItem::Kind::Module) it.module->release_caches();
}

WatchdogConfig Simulation::stage_watchdog(const StageConfig& cfg) const {
  WatchdogConfig wd = cfg.watchdog;
  if (!(wd.max_speed > 0.0)) wd.max_speed = cfg.blowup_speed;
  if (wd.check_every < 1) throw SetupError("stage '" + cfg.name + "': watchdog.check_every must be at least 1");
  if (cfg.quasi_static) {
    wd.energy_growth_factor = 0.0;  // no inertia: the kinetic energy is a rate, not a mode that can grow
    // A step's motion is bounded by the substeps (max_approach_increment), not by r/dt.
    if (!(wd.max_speed > 0.0)) wd.max_speed = std::numeric_limits<double>::infinity();
  }
  if (!cfg.mechanics || cfg.max_steps == 0 || !(cfg.duration > 0.0)) {
    // Its geometry is given (e.g. an overlapping packing built for a network test).
    wd.max_speed = std::numeric_limits<double>::infinity();
    wd.max_overlap_ratio = std::numeric_limits<double>::infinity();
    wd.energy_growth_factor = 0.0;
  }
  return wd;
}

/// The stage's counts and last monitor values into res; the stage's mass factors and prescribed
/// sets released.
void Simulation::end_stage(const std::vector<std::string>& cols, const std::vector<double>& vals, StageResult& res) {
  auto& p = s_.particles;
  res.steps = s_.step - s_.stage_step0;
  res.simulated_time = s_.time - s_.stage_t0;
  res.physical_time = s_.physical_time - s_.stage_phys_t0;
  for (std::size_t q = 0; q < cols.size(); ++q) res.final_values[cols[q]] = vals[q];
  undo_mass_factors(p);
  for (auto& f : p.fixed) f = 0;
  prescribed_.clear();
}

/// Walls with a halt condition stop once their monitored quantity reaches its value (sampled
/// into cols, vals only when a wall has one).
void Simulation::halt_walls(std::vector<std::string>& cols, std::vector<double>& vals) {
  bool sampled = false;
  for (auto& w : s_.walls) {
    if (w.halted || w.motion.halt_quantity.empty()) continue;
    if (!sampled) {
      sample(cols, vals);
      sampled = true;
    }
    auto it = std::find(cols.begin(), cols.end(), w.motion.halt_quantity);
    if (it == cols.end()) throw SetupError("wall '" + w.name + "': halt quantity '" + w.motion.halt_quantity + "' is not monitored");
    if (vals[it - cols.begin()] >= w.motion.halt_value) w.halted = true;
  }
}

/// The stage's mechanics and its step [s]: the inertia-free path's checks (its velocities are the
/// solve's output: a fresh quasi-static stage starts them at zero); the step from the checkpoint on
/// resume, else resolve_dt, against the contact law's stable step (explicit mechanics only) and the
/// modules' steps; into res.
double Simulation::choose_step(const StageConfig& cfg, bool resume, StageResult& res) {
  auto& p = s_.particles;
  if (cfg.quasi_static && cfg.mechanics) {
    check_quasi_static(cfg);
    // Velocities are the solve's output, not state: the explicit stage before left its own.
    if (!resume)
      for (std::size_t i = 0; i < p.size(); ++i) {
        p.velocity[i].setZero();
        p.omega[i].setZero();
      }
  }
  const bool explicit_mechanics = cfg.mechanics && !cfg.quasi_static;
  inertia_free_ = cfg.mechanics && cfg.quasi_static;
  adaptive_ = cfg.adaptive.on();
  if (adaptive_ && inertia_free_) throw SetupError("stage '" + cfg.name + "': an adaptive step needs explicit mechanics (quasi_static sets its own substeps)");
  if (adaptive_) res.adaptive = StageResult::AdaptiveStats{};
  if (!resume)  // the module clocks and step statistics of an earlier adaptive stage
    for (auto m = s_.marks.begin(); m != s_.marks.end();)
      m = m->first.rfind("clock/", 0) == 0 || m->first.rfind("adaptive/", 0) == 0 ? s_.marks.erase(m) : std::next(m);
  if (adaptive_ && !resume) {  // the first step from the stage's start state; the history starts with it
    s_.stage_dt = adaptive_step(cfg, std::numeric_limits<double>::infinity(), contact_stable_dt(cfg));
    s_.stage_elapsed = 0.0;
    s_.dt_history = {0.0, s_.stage_dt};
    s_.marks["adaptive/min"] = s_.marks["adaptive/max"] = s_.stage_dt;
    s_.marks["adaptive/changes"] = s_.marks["adaptive/overshoots"] = 0.0;
  }
  if (!adaptive_) s_.dt_history.clear();
  const double dt_used = resume || adaptive_ ? s_.stage_dt : resolve_dt(cfg);
  s_.stage_dt = dt_used;
  logged_dt_ = dt_used;
  res.dt = dt_used;
  res.stable_dt_at_start = explicit_mechanics ? mechanical_stable_dt() : std::numeric_limits<double>::infinity();
  res.dt_fraction_used = dt_used / res.stable_dt_at_start;
  // (An adaptive stage chose its step from the state; resumed, the state may have stiffened past it
  // since its last check: the loop's next check shrinks it, as in the uninterrupted run.)
  if (dt_used > res.stable_dt_at_start && !cfg.allow_unstable_dt && !adaptive_)
    throw SetupError("stage '" + cfg.name + "': dt = " + fmt_g(dt_used) + " s is " + fmt_g(res.dt_fraction_used) + " of the stable step " +
                     fmt_g(res.stable_dt_at_start) + " s of the contact law; lower dt or set allow_unstable_dt");
  // Fixed-clock modules: their step against their own stable step (in their time domain).
  // Adaptive clocks choose their substeps from it; event clocks run quasi-static solves.
  if (!adaptive_) check_module_steps(cfg, dt_used, true);  // (adaptive: adaptive_step bounds the step by them)
  res.module_steps = module_steps(dt_used);
  return dt_used;
}

Simulation::StepSpan Simulation::step_span(const StageConfig& cfg, Step k, double dt_used) const {
  if (!adaptive_)  // time = steps x dt, never accumulated
    return {static_cast<double>(k) * dt_used, dt_used, static_cast<double>(k + 1) * dt_used};
  // The current step, shortened to land on the next target time.
  const double t_old = s_.stage_elapsed, land = next_landing(cfg, t_old);
  StepSpan span{t_old, s_.stage_dt, t_old + s_.stage_dt};
  if (span.t_new >= land - 1e-6 * span.dt) {
    span.t_new = land;
    span.dt = land - t_old;
  }
  if (!(span.dt > 0.0))
    throw PhysicsError(s_.step, {}, "time step", "an adaptive step of " + fmt_g(span.dt) + " s to land on t = " + fmt_g(land) + " s");
  return span;
}

void Simulation::check_step(const StageConfig& cfg, Step kk, double dt_used, Observer& obs, StageResult& res) {
  if (adaptive_) {
    if (kk % cfg.adaptive.check_every != 0) return;
    const auto t_check = std::chrono::steady_clock::now();
    adapt_step(cfg, obs);
    res.adaptive->check_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t_check).count();
    ++res.adaptive->checks;
    return;
  }
  if (cfg.stability_check_every <= 0 || kk % cfg.stability_check_every != 0 || cfg.allow_unstable_dt) return;
  const double st = contact_stable_dt(cfg);
  if (dt_used > st)
    throw PhysicsError(s_.step, {}, "time step",
                       "dt = " + fmt_g(dt_used) + " s now exceeds the stable step " + fmt_g(st) +
                           " s of the current state (contacts stiffened); lower dt_fraction or dt");
  check_module_steps(cfg, dt_used, false);
}

StageResult Simulation::run_stage(const StageConfig& cfg, Observer& obs, bool resume) {
  using clock = std::chrono::steady_clock;
  const auto t_start = clock::now();
  const Step step_begin = s_.step;  // a resumed stage's rate counts the steps this run made
  auto& p = s_.particles;
  prepare(cfg);

  bind_walls_and_sets(cfg, resume);
  if (!resume) begin_stage(cfg);
  choose_skin(cfg, resume);
  // Before step 0: overlaps of the starting packing (reported; refused or relaxed as configured)
  // and pressure walls with nothing to push on (engine/start_checks.hpp).
  InitialOverlapReport overlap0;
  if (!resume) {
    overlap0 = apply_initial_overlap_policy(s_, cfg.name, cfg.initial_overlap, cfg.initial_overlap_limit);
    check_pressure_walls(s_, cfg.name, cfg.motions);
  }
  if (!resume) {
    s_.verlet = VerletTracker{};
    update_neighbors(skin_, 0);
  }

  time_scale_ = resume ? s_.stage_time_scale : cfg.time_scale;
  if (!(time_scale_ > 0.0)) throw SetupError("stage '" + cfg.name + "': time_scale must be positive");
  StageResult res;
  stats_ = &res;
  res.name = cfg.name;
  res.initial_overlap = overlap0;
  res.plan = plan_.names();
  res.particles = p.size();
  const std::int64_t rebuilds0 = s_.rebuilds;
  if (resume) check_resumed_clocks(cfg);
  const double dt_used = choose_step(cfg, resume, res);
  obs.steps_planned(dt_used, res.stable_dt_at_start, res.module_steps);
  const double t_area = die_area(s_.walls);
  if (!resume) evaluate_start(dt_used, t_area, res);
  obs.stage_started(res);

  std::vector<std::string> cols;
  std::vector<double> vals;
  // The step cols and vals were last sampled at by the step's bookkeeping: the `until` check at the
  // top of the next iteration sees the same state and reuses them (the monitors - a compact's
  // porosity runs a neighbour search and the lens volumes - were evaluated twice per check).
  Step sampled_at = -1;
  auto until_holds = [&]() {
    if (cfg.until.empty()) return false;
    if (sampled_at != s_.step) sample(cols, vals);
    for (const auto& c : cfg.until) {
      auto it = std::find(cols.begin(), cols.end(), c.quantity);
      if (it == cols.end()) throw SetupError("stage '" + cfg.name + "': stop quantity '" + c.quantity + "' is not monitored");
      const double v = vals[it - cols.begin()];
      if (c.at_least ? !(v >= c.value) : !(v <= c.value)) return false;
    }
    return true;
  };
  const Step watch_every = obs.watch_every();
  if (!resume) {
    sample(cols, vals);
    obs.timeseries(cols, vals);
    obs.watch(s_, cols, vals);
    if (cfg.frame_every > 0 || cfg.frame_every_s > 0.0) obs.frame(s_);
  }
  // The run watchdog: the state of the stage start must pass it (a scene it refuses stops before
  // step 0), and that state is the first healthy copy.
  const WatchdogConfig wd = stage_watchdog(cfg);
  WatchdogContext wctx = watchdog_context(cfg, dt_used, res.stable_dt_at_start);
  if (!resume) watchdog_reset(s_);
  try {
    // (On resume at a check step the energy samples restart there: they are not in checkpoints.)
    watchdog_check(s_, wd, wctx, !resume || (s_.step - s_.stage_step0) % wd.check_every == 0);
  } catch (const PhysicsError& e) {
    throw PhysicsError(e.step(), e.ids(), e.quantity(),
                       "stage '" + cfg.name + "' refused before its first step: its initial state fails the " + e.reason(), e.detail());
  }
  const auto stage_done = [&](Step k) {
    const double elapsed = adaptive_ ? s_.stage_elapsed : static_cast<double>(k) * dt_used;
    return k >= cfg.max_steps || elapsed >= cfg.duration * (1.0 - 1e-12);
  };
  // A stage with no step ahead (e.g. a sweep item's measurement, stop.steps = 0) keeps no copy:
  // it would hold the state the stage fails in, which restarting from would only redo the stage.
  if (wd.snapshot_every_checks > 0 && !stage_done(s_.step - s_.stage_step0)) obs.healthy(s_);

  bool reached = false;
  const Step log_every = cfg.log_every > 0 ? cfg.log_every : 100;
  for (;;) {
    const Step k = s_.step - s_.stage_step0;  // steps done in this stage
    if (stage_done(k)) break;
    if (k > 0 && k % cfg.check_every == 0) {
      halt_walls(cols, vals);
      if (until_holds()) {
        reached = true;
        break;
      }
    }

    // ---- one step: execute the plan ----
    const auto [t_old, dt_step, t_new] = step_span(cfg, k, dt_used);
    execute_plan(cfg, dt_step, t_new, t_area);
    ++s_.step;
    if (adaptive_) s_.stage_elapsed = t_new;
    s_.time = s_.stage_t0 + t_new;
    s_.physical_time = s_.stage_phys_t0 + time_scale_ * t_new;
    // ---- bookkeeping ----
    const Step kk = k + 1;
    const bool checked = kk % wd.check_every == 0;
    if (checked) watchdog_check(s_, wd, wctx, true);
    check_step(cfg, kk, dt_used, obs, res);
    if (adaptive_) wctx.dt = s_.stage_dt;
    const bool row = cfg.timeseries_every > 0 && kk % cfg.timeseries_every == 0;
    if (row || (watch_every > 0 && kk % watch_every == 0)) {
      sample(cols, vals);
      sampled_at = s_.step;
      if (row) obs.timeseries(cols, vals);
      obs.watch(s_, cols, vals);
    }
    const bool timed_frame = cfg.frame_every_s > 0.0 && std::floor(t_new / cfg.frame_every_s * (1.0 + 1e-12)) >
                                                            std::floor(t_old / cfg.frame_every_s * (1.0 + 1e-12));
    if ((cfg.frame_every > 0 && kk % cfg.frame_every == 0) || timed_frame) obs.frame(s_);
    if ((cfg.checkpoint_every > 0 && s_.step % cfg.checkpoint_every == 0) || (cfg.checkpoint_every_s > 0.0 && obs.checkpoint_due()))
      obs.checkpoint(s_);
    if (checked && wd.snapshot_every_checks > 0 && (kk / wd.check_every) % wd.snapshot_every_checks == 0) obs.healthy(s_);
    if (kk % log_every == 0) obs.progress(s_, kk, t_new, dt_step);
    if (interrupt_flag().load()) {
      obs.checkpoint(s_);
      throw Interrupted("interrupted at step " + std::to_string(s_.step) + "; checkpoint written");
    }
  }
  watchdog_check(s_, wd, wctx, false);
  watchdog_reset(s_);  // the energy samples live only inside the stage (final states carry none)
  sampled_at = -1;
  release_module_caches();
  obs.frame(s_);
  if (!reached && !cfg.until.empty()) reached = until_holds();
  res.until_reached = cfg.until.empty() || reached;
  if (adaptive_) adaptive_stats(res);
  sample(cols, vals);
  obs.timeseries(cols, vals);
  obs.watch(s_, cols, vals);
  end_stage(cols, vals, res);
  res.neighbor_rebuilds = s_.rebuilds - rebuilds0;
  res.wall_seconds = std::chrono::duration<double>(clock::now() - t_start).count();
  res.steps_run = s_.step - step_begin;
  res.particle_steps_per_second =
      res.wall_seconds > 0 ? static_cast<double>(res.steps_run) * static_cast<double>(p.size()) / res.wall_seconds : 0.0;
  stats_ = nullptr;
  return res;
}

}  // namespace sparkdem
