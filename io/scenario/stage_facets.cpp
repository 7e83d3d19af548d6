#include "io/scenario/stage_facets.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "engine/core/format.hpp"
#include "io/scenario/json_binder.hpp"
#include "io/restart/state_file.hpp"
#include "io/scenario/scenario_parts.hpp"

namespace sparkdem::io {

std::string unknown_column(const std::string& column, const std::vector<std::string>& cols);

namespace {

// ------------------------------------------------------------------- the stage's own parameters
struct StageParams {
  std::string name = "stage";
  std::string type = "dynamics";
  double dt = 0.0;
  double dt_fraction = 0.0;
  std::string mechanics = "on";
  bool allow_unstable_dt = false;
  double mass_scaling = 1.0;
  double mass_floor_radius = 0.0;
  double time_scale = 1.0;
  double skin = 0.0;
  double blowup_speed = 0.0;
  std::int64_t sort_every_rebuilds = 50;
  std::int64_t stability_check_every = 1000;
  std::string initial_overlap = "allow";
  double initial_overlap_limit = 0.01;
  std::string from_snapshot;
  // stop.*
  struct Stop {
    double time = std::numeric_limits<double>::infinity();
    std::int64_t steps = std::numeric_limits<std::int64_t>::max();
    std::int64_t check_every = 100;
    bool require_until = false;
  } stop;
  struct Output {
    std::int64_t frame_every = 0;
    std::int64_t timeseries_every = 100;
    std::int64_t checkpoint_every = 0;
    double checkpoint_every_s = 600.0;
    std::string network = "auto";
    double frame_every_s = 0.0;
  } output;
  struct Watchdog {
    std::int64_t check_every = 10;
    double max_overlap_ratio = 0.0;
    double max_speed = 0.0;
    double energy_growth_factor = 1e4;
    std::int64_t energy_window = 5;
    double energy_floor_fraction = 0.01;
    std::int64_t snapshot_every_checks = 100;
    std::int64_t snapshot_memory_max_bytes = std::int64_t{1} << 20;
  } watchdog;
};
ParamSpec<StageParams::Watchdog> watchdog_spec() {
  using P = StageParams::Watchdog;
  ParamSpec<P> s("watchdog", "object",
                 "run watchdog (engine/watchdog.hpp): checks that stop a run going wrong (exit code 3) with the step, "
                 "time, particle ids, quantity, value and bound, and write the last state that passed them as "
                 "OUTDIR/checkpoint_before_failure.h5 (loadable with --restart); the defaults never fire on a healthy run");
  s.add("check_every", &P::check_every).min(1).doc("steps between checks (also checked before step 0 and at the stage end)");
  s.add("max_overlap_ratio", &P::max_overlap_ratio)
      .unit("1")
      .nonnegative()
      .doc(
          "largest overlap / smaller radius of a particle pair (walls are not checked); 0: the contact law's bound "
          "(0.5 for elastic laws, max(1, creep_overlap_limit) + 0.5 for sintering)");
  s.add("max_speed", &P::max_speed)
      .unit("m/s")
      .nonnegative()
      .doc("a particle speed above this is a blow-up (0: blowup_speed, or else each particle's radius per step, r/dt)");
  s.add("energy_growth_factor", &P::energy_growth_factor)
      .unit("1")
      .nonnegative()
      .doc(
          "stop when the kinetic energy per unit mass grew by more than this factor over energy_window checks, at "
          "every check, while its rms speed exceeds energy_floor_fraction of the blow-up speed (a numerical "
          "instability; 0: off)");
  s.add("energy_window", &P::energy_window).min(1).doc("checks over which the kinetic-energy growth is measured");
  s.add("energy_floor_fraction", &P::energy_floor_fraction)
      .unit("1")
      .nonnegative()
      .doc("rms speed sqrt(2 KE / M) below this fraction of the blow-up speed (max_speed or min radius / dt) never counts as growth");
  s.add("snapshot_every_checks", &P::snapshot_every_checks)
      .min(0)
      .doc(
          "checks between copies of the last healthy state (one more at the start of a stage with steps to run; 0: none, and no "
          "checkpoint_before_failure.h5)");
  s.add("snapshot_memory_max_bytes", &P::snapshot_memory_max_bytes)
      .unit("B")
      .min(0)
      .doc(
          "a copy of the last healthy state that a checkpoint would store in at most this many bytes is kept in memory; a larger one is "
          "written to the scratch file OUTDIR/.healthy_state.h5 (removed at the stage end), so a large state is not held twice");
  return s;
}
ParamSpec<StageParams::Stop> stop_spec() {
  using P = StageParams::Stop;
  ParamSpec<P> s("stop", "object", "stop condition");
  s.add("time", &P::time).unit("s").positive().doc("simulated time of the stage");
  s.add("steps", &P::steps).min(0).doc("number of steps of the stage");
  s.add("check_every", &P::check_every).min(1).doc("steps between checks of `until`");
  s.add("require_until", &P::require_until).doc("a hard stop before `until` holds is an error (exit 3)");
  return s;
}
ParamSpec<StageParams::Output> output_spec() {
  using P = StageParams::Output;
  ParamSpec<P> s("output", "object", "what the stage saves");
  s.add("frame_every", &P::frame_every).min(0).doc("steps between particle frames (0: final frame only)");
  s.add("timeseries_every", &P::timeseries_every).min(0).doc("steps between time-series rows");
  s.add("checkpoint_every", &P::checkpoint_every).min(0).doc("global steps between checkpoints (0: none)");
  s.add("checkpoint_every_s", &P::checkpoint_every_s)
      .unit("s")
      .nonnegative()
      .doc("wall-clock seconds between checkpoints (0: none): a killed run loses at most this much work");
  s.add("frame_every_s", &P::frame_every_s)
      .unit("s")
      .nonnegative()
      .doc("stage time between frames (0: off; beside frame_every); an adaptive step lands on these times");
  s.add("network", &P::network)
      .choices({"auto", "none", "contacts", "bonds", "both"})
      .doc("which pair sets results.xdmf draws as lines (frames' <group>/nodes): contacts (the contact rows and the modules' "
           "networks, e.g. electrical branches), bonds, both or none; auto: both when a module writes a network or the state "
           "has bonds, else none");
  return s;
}
ParamSpec<AdaptiveDt> adaptive_dt_spec() {
  ParamSpec<AdaptiveDt> s("dt", "object",
                          "an adaptive step: F x the stable step of the current state, re-estimated every check_every steps, "
                          "growing by at most `growth` per check and shrinking at once; steps land on stop.time, "
                          "output.frame_every_s times and wall table breakpoints (docs/scenarios.md, adaptive step)");
  s.add("adaptive", &AdaptiveDt::fraction).unit("1").range(1e-6, 1.0).doc("F, the fraction of the stable step (0 < F <= 1)");
  s.add("min", &AdaptiveDt::min).unit("s").nonnegative().doc("smallest step: a state that needs less stops the run (exit 3)");
  s.add("max", &AdaptiveDt::max).unit("s").positive().doc("largest step (default: none)");
  s.add("check_every", &AdaptiveDt::check_every).min(1).doc("steps between estimates of the stable step");
  s.add("growth", &AdaptiveDt::growth).unit("1").range(1.0, 10.0).doc("largest growth factor of the step per check");
  return s;
}

ParamSpec<StageParams> stage_spec(const Registry& reg) {
  ParamSpec<StageParams> s("stage", "stage",
                           "one stage: a generator (type = a registered generator, parameters in `generator`) or "
                           "`dynamics`; plus modules, wall motions, stop condition and output");
  std::vector<std::string> types = {"dynamics"};
  for (const auto& [k, v] : reg.generators()) types.push_back(k);
  s.add("name", &StageParams::name).doc("stage name");
  s.add("type", &StageParams::type).choices(types).doc("dynamics or a generator name");
  s.add("dt", &StageParams::dt).unit("s").nonnegative().doc("time step (0: dt_fraction of the stable step)");
  s.add("dt_fraction", &StageParams::dt_fraction)
      .unit("1")
      .range(0.0, 10.0)
      .doc("time step as a fraction of the stable step at stage start");
  s.add("mechanics", &StageParams::mechanics)
      .choices({"on", "frozen"})
      .doc(
          "frozen: no mechanical step (positions and contacts of the stage start kept; only coupling modules run); dt_fraction then refers "
          "to the smallest module stable step");
  s.add("allow_unstable_dt", &StageParams::allow_unstable_dt).doc("run above the stable step (explicit override)");
  s.add("mass_scaling", &StageParams::mass_scaling).unit("1").min(1.0).doc("mass scaling factor (reported; 1 = off)");
  s.add("mass_floor_radius", &StageParams::mass_floor_radius)
      .unit("m")
      .nonnegative()
      .doc(
          "particles smaller than this radius take the mass (and inertia) of a sphere of this radius during the stage, on top of "
          "mass_scaling: density scaling of the fines for quasi-static stages (0 = off)");
  s.add("time_scale", &StageParams::time_scale)
      .unit("1")
      .positive()
      .doc(
          "physical seconds per mechanical second: modules in physical time (thermal, sintering kinetics) advance time_scale x dt per "
          "step; both clocks are reported");
  s.add("skin", &StageParams::skin).unit("m").nonnegative().doc("Verlet skin (0: 0.3 x smallest radius)");
  s.add("blowup_speed", &StageParams::blowup_speed)
      .unit("m/s")
      .nonnegative()
      .doc("speed that counts as a blow-up (0: radius per step); watchdog.max_speed, when set, takes precedence");
  s.add("sort_every_rebuilds", &StageParams::sort_every_rebuilds).min(0).doc("spatial sort period in neighbour rebuilds (0: never)");
  s.add("stability_check_every", &StageParams::stability_check_every).min(0).doc("steps between stable-step checks (0: start only)");
  s.add("initial_overlap", &StageParams::initial_overlap)
      .choices({"allow", "refuse", "relax"})
      .doc(
          "overlaps of the starting packing above initial_overlap_limit (always reported in summary.json): run as is (allow), refuse "
          "before step 0 naming the worst pair (refuse), or move the particles apart first (relax)");
  s.add("initial_overlap_limit", &StageParams::initial_overlap_limit)
      .unit("1")
      .positive()
      .doc("largest accepted initial overlap / smaller radius (pairs) or / radius (walls)");
  s.add("from_snapshot", &StageParams::from_snapshot).doc("start from the state stored in this checkpoint file");
  s.add_group("stop", &StageParams::stop, stop_spec());
  s.add_group("output", &StageParams::output, output_spec());
  s.add_group("watchdog", &StageParams::watchdog, watchdog_spec());
  return s;
}

struct SnapshotParams {
  std::string column;
  std::vector<double> at;
  std::int64_t every_steps = 0;
  std::int64_t check_every = 0;
};
ParamSpec<SnapshotParams> snapshot_spec() {
  ParamSpec<SnapshotParams> s("snapshots", "object",
                              "states saved during a stepping stage as OUTDIR/snapshots/<stage>_<k>.h5 (checkpoint "
                              "format), listed in summary.json; a later stage can sweep over them (sweep.snapshots_of)");
  s.add("column", &SnapshotParams::column).doc("time-series column watched by `at` (every_steps: recorded only; default time)");
  s.add("at", &SnapshotParams::at).doc("values of `column`: snapshot k when the column first reaches at[k] (from its first sample's side)");
  s.add("every_steps", &SnapshotParams::every_steps).min(0).doc("instead of `at`: a snapshot every this many stage steps");
  s.add("check_every", &SnapshotParams::check_every)
      .min(0)
      .doc("stage steps between checks of `at` besides the time-series rows (0: rows only)");
  return s;
}

/// Time-series columns of a stage whose walls are named `walls` (a superset of them is fine) in a
/// scenario with (`bonds`) or without a bond law:
/// the built-in ones, the prescribed sets' and the generator monitors' (whose columns are fixed
/// for a stage; they are read from a scratch state with those walls).
std::vector<std::string> stage_columns(const StageDef& st, const std::set<std::string>& walls, bool bonds) {
  State scratch;
  scratch.bonds_active = bonds;  // the bond columns exist when the scenario has a bond law
  for (const auto& n : walls) {
    Wall w;
    w.name = n;
    scratch.walls.push_back(w);
  }
  std::vector<std::string> cols = builtin_columns(scratch);
  for (const auto& [name, v] : st.cfg.prescribed_sets)
    for (const auto& c : prescribed_set_columns(name)) cols.push_back(c);
  if (st.generator)
    for (const auto& m : st.generator->monitors())
      for (const auto& c : m->columns(scratch)) cols.push_back(c);
  for (const auto& m : st.monitors)
    for (const auto& c : m->columns(scratch)) cols.push_back(c);
  for (const auto& m : st.modules)
    for (const auto& c : m->columns()) cols.push_back(c);
  return cols;
}

// ------------------------------------------------------------------------- the stage's own keys

/// The StageDef of a stage's own parameters (no facet yet).
StageDef stage_from_params(const StageParams& p, const std::string& path) {
  StageDef st;
  st.path = path;
  st.type = p.type;
  auto& c = st.cfg;
  c.name = p.name;
  c.dt = p.dt;
  c.dt_fraction = p.dt_fraction;
  c.mechanics = p.mechanics != "frozen";
  c.allow_unstable_dt = p.allow_unstable_dt;
  c.mass_scaling = p.mass_scaling;
  c.mass_floor_radius = p.mass_floor_radius;
  c.time_scale = p.time_scale;
  c.skin = p.skin;
  c.blowup_speed = p.blowup_speed;
  c.watchdog.check_every = p.watchdog.check_every;
  c.watchdog.max_overlap_ratio = p.watchdog.max_overlap_ratio;
  c.watchdog.max_speed = p.watchdog.max_speed;
  c.watchdog.energy_growth_factor = p.watchdog.energy_growth_factor;
  c.watchdog.energy_window = p.watchdog.energy_window;
  c.watchdog.energy_floor_fraction = p.watchdog.energy_floor_fraction;
  c.watchdog.snapshot_every_checks = p.watchdog.snapshot_every_checks;
  c.watchdog.snapshot_memory_max_bytes = p.watchdog.snapshot_memory_max_bytes;
  c.sort_every_rebuilds = p.sort_every_rebuilds;
  c.stability_check_every = p.stability_check_every;
  c.initial_overlap = p.initial_overlap;
  c.initial_overlap_limit = p.initial_overlap_limit;
  c.duration = p.stop.time;
  c.max_steps = p.stop.steps;
  c.check_every = p.stop.check_every;
  c.require_until = p.stop.require_until;
  c.frame_every = p.output.frame_every;
  c.timeseries_every = p.output.timeseries_every;
  c.checkpoint_every = p.output.checkpoint_every;
  c.checkpoint_every_s = p.output.checkpoint_every_s;
  c.network_output = p.output.network;
  c.frame_every_s = p.output.frame_every_s;
  return st;
}

/// `from_snapshot`: the file must be readable; the stage starts with its particles and walls, so
/// the walls' names (and shapes) are checked against the snapshot's.
void bind_from_snapshot(const std::string& file, StageBuild& b) {
  if (file.empty()) return;
  b.st.from_snapshot = (b.ctx.base_dir / file).string();
  b.ctx.has_particles = true;
  // (error_code overloads: a name too long for the file system is "cannot read", not an exception)
  std::error_code ec;
  if (!std::filesystem::exists(b.st.from_snapshot, ec)) {
    b.errors.push_back({b.path + "/from_snapshot", "cannot read the snapshot file '" + b.st.from_snapshot + "'"});
    return;
  }
  try {
    State snap;
    (void)read_checkpoint(b.st.from_snapshot, snap);
    b.ctx.wall_names.clear();
    b.ctx.walls = snap.walls;
    for (const auto& w : snap.walls) b.ctx.wall_names.insert(w.name);
  } catch (const SetupError&) {
    throw;  // a damaged snapshot is a set-up failure (exit 4), as when the stage starts
  } catch (const std::exception& e) {
    b.errors.push_back({b.path + "/from_snapshot", std::string("cannot load the snapshot: ") + e.what()});
  }
}

/// A stage that steps needs a hard stop and a time step.
void check_stop_and_dt(StageBuild& b) {
  const auto& c = b.st.cfg;
  if (b.st.type == "dynamics" && !b.ctx.has_particles)
    b.errors.push_back(
        {b.path + "/type", "this dynamics stage has no particles: no earlier stage generates them and it has no from_snapshot"});
  if (b.st.dynamics && std::isinf(c.duration) && c.max_steps == std::numeric_limits<std::int64_t>::max())
    b.errors.push_back({b.path + "/stop", "a stage needs a hard stop: stop.time [s] or stop.steps"});
  if (b.st.dynamics && c.dt == 0.0 && c.dt_fraction == 0.0 && !c.adaptive.on())
    b.errors.push_back({b.path + "/dt", "set dt [s], dt_fraction (fraction of the stable step) or dt: {\"adaptive\": F}"});
  if (c.dt > 0.0 && c.dt_fraction > 0.0) b.errors.push_back({b.path + "/dt_fraction", "give either dt or dt_fraction, not both"});
  if (c.adaptive.on() && c.dt_fraction > 0.0)
    b.errors.push_back({b.path + "/dt_fraction", "an adaptive dt sets its own fraction (dt.adaptive): remove dt_fraction"});
  if (c.adaptive.on() && c.adaptive.min > c.adaptive.max)
    b.errors.push_back({b.path + "/dt/min", "expected dt.min <= dt.max, found " + std::to_string(c.adaptive.min) + " > " +
                                                std::to_string(c.adaptive.max)});
}

/// After the keys: the generator's settling (its motions, stop conditions and modules, after the
/// stage's own), its checks against the scene, and the stage's time-series columns.
void finish_stage(StageBuild& b, std::size_t errors_at_start) {
  StageDef& st = b.st;
  if (st.generator) {
    st.generator->configure_stage(st.cfg);
    for (auto& m : st.generator->modules()) st.modules.push_back(std::move(m));
    if (b.errors.size() == errors_at_start) {
      State scene;
      scene.materials = b.ctx.materials;
      scene.walls = b.ctx.walls;
      std::vector<Diagnostic> found;
      st.generator->validate(scene, found);
      for (const auto& d : found) b.errors.push_back({b.path + "/generator" + d.path, d.message});
    }
  }
  b.ctx.columns.reset();
  if (st.from_snapshot.empty() && b.modules_built) b.ctx.columns = stage_columns(st, b.ctx.wall_names, b.ctx.has_bond_law);
  const json& snap = b.js.contains("snapshots") ? b.js["snapshots"] : json();
  if (st.snapshots && b.ctx.columns && snap.is_object() && snap.contains("column") && snap["column"].is_string() &&
      !st.snapshots->column.empty()) {
    const std::string bad = unknown_column(st.snapshots->column, *b.ctx.columns);
    if (!bad.empty()) b.errors.push_back({b.path + "/snapshots/column", bad});
  }
}

// ------------------------------------------------------------------------------------ facets

std::vector<std::string> wall_list(const StageContext& ctx) { return {ctx.wall_names.begin(), ctx.wall_names.end()}; }

/// "generator": the parameters of the generator named by `type` (always bound for a generator stage).
void bind_generator(const json& value, const std::string& at, StageBuild& b) {
  StageDef& st = b.st;
  const auto& gens = b.ctx.reg->generators();
  if (st.type == "dynamics") {
    if (!value.is_null())
      b.errors.push_back({at, "a `dynamics` stage takes no generator; set \"type\" to one of " + list_names(names_of(gens))});
    return;
  }
  auto g = gens.find(st.type);
  if (g == gens.end()) return;  // an unknown type is reported by the stage's own spec
  b.ctx.has_particles = true;
  for (const auto& n : g->second.walls) b.ctx.wall_names.insert(n);  // known even when its parameters are wrong
  const std::size_t before = b.errors.size();
  ParamValues v = bind_params(value.is_null() ? json::object() : value, g->second.spec, at, b.errors);
  // Relative CSV paths of size distributions are resolved against the scenario directory.
  auto csv = v.find("size_distribution.csv");
  if (csv != v.end() && !std::get<std::string>(csv->second).empty())
    csv->second = (b.ctx.base_dir / std::get<std::string>(csv->second)).string();
  b.resolved["generator"] = to_json(v, g->second.spec);
  if (b.errors.size() == before) {
    try {
      st.generator = g->second.make(v);
      b.resolved["estimated_particles"] = st.generator->estimated_particles();
    } catch (const ConfigError& e) {  // the generator's own checks (paths relative to it)
      for (const auto& d : e.diagnostics()) b.errors.push_back({at + d.path, d.message});
    }
  }
  b.generator_failed = !st.generator;
  st.dynamics = st.generator && st.generator->steps();
}

/// "modules": {module name: {its parameters, "clock": {...}}}.
void bind_modules(const json& value, const std::string& at, StageBuild& b) {
  b.resolved["modules"] = json::object();
  if (value.is_null()) return;  // no modules (the resolved stage lists none)
  if (!value.is_object()) {
    b.errors.push_back({at, "expected an object {module name: {params}}, found " + describe(value)});
    b.modules_built = false;
    return;
  }
  const auto& mods = b.ctx.reg->modules();
  const std::size_t before = b.errors.size();
  for (auto it = value.begin(); it != value.end(); ++it) {
    const std::string mp = at + "/" + it.key();
    auto m = mods.find(it.key());
    if (m == mods.end()) {
      b.errors.push_back({mp, "unknown module \"" + it.key() + "\"" + suggest(it.key(), names_of(mods)) +
                                  "; registered modules: " + list_names(names_of(mods))});
      continue;
    }
    const std::size_t b2 = b.errors.size();
    const ParamValues v = bind_params(it.value(), m->second.spec, mp, b.errors, {"clock"});
    b.resolved["modules"][it.key()] = to_json(v, m->second.spec);
    std::optional<Clock> clk;
    if (it.value().is_object() && it.value().contains("clock")) {
      json rc;
      clk = make_clock(it.value()["clock"], mp + "/clock", b.errors, rc);
      b.resolved["modules"][it.key()]["clock"] = rc;
    }
    if (b.errors.size() != b2) continue;
    try {
      b.st.modules.push_back(m->second.make(v));
      if (clk) b.st.modules.back()->set_clock(*clk);
    } catch (const ConfigError& e) {  // a module's own consistency checks (paths relative to it)
      for (const auto& d : e.diagnostics()) b.errors.push_back({mp + d.path, d.message});
    }
  }
  // A module that failed to build has no columns: the stage's columns are then unknown and the
  // checks against them (snapshot column, sweep collect) are left out rather than reported for
  // every column of the failed module.
  b.modules_built = b.errors.size() == before;
}

struct CreateBondsParams {
  double gap_tolerance = -1.0;
  double gap_tolerance_relative = -1.0;
};
ParamSpec<CreateBondsParams> create_bonds_spec() {
  ParamSpec<CreateBondsParams> s("create_bonds", "object",
                                 "bond every pair whose gap is at most the tolerance at the stage start (after the "
                                 "generator), with the scenario's bond law; exactly one of the two keys");
  s.add("gap_tolerance", &CreateBondsParams::gap_tolerance)
      .unit("m")
      .nonnegative()
      .no_default()
      .doc("largest gap of a bonded pair (0 = touching pairs)");
  s.add("gap_tolerance_relative", &CreateBondsParams::gap_tolerance_relative)
      .unit("1")
      .nonnegative()
      .no_default()
      .doc("largest gap as a fraction of the mean radius at the stage start (follows the packing's element size)");
  return s;
}
void bind_create_bonds(const json& value, const std::string& at, StageBuild& b) {
  json ignored;
  const std::size_t before = b.errors.size();
  const CreateBondsParams p = build(create_bonds_spec(), value, at, b.errors, ignored);
  const bool abs = p.gap_tolerance >= 0.0, rel = p.gap_tolerance_relative >= 0.0;
  if (b.errors.size() == before && abs == rel)
    b.errors.push_back({at,
                        "expected {\"gap_tolerance\": number >= 0} [m] or {\"gap_tolerance_relative\": number >= 0} "
                        "[1, of the mean radius at the stage start] (bond every pair whose gap is at most this; 0 = "
                        "touching pairs), found " +
                            describe(value)});
  else if (b.errors.size() == before) {
    b.st.create_bonds_gap = rel ? p.gap_tolerance_relative : p.gap_tolerance;
    b.st.create_bonds_gap_relative = rel;
  }
  if (!b.ctx.has_bond_law) b.errors.push_back({at, "creating bonds needs a bond law: add \"bonds\": {\"law\": ...} at the top level"});
  b.resolved["create_bonds"] = value;
}

/// "contact": the stage's own contact law {"law", "params"}.
void bind_contact(const json& value, const std::string& at, StageBuild& b) {
  json rc;
  b.st.law = make_law(value, *b.ctx.reg, at, b.errors, rc);
  b.resolved["contact"] = rc;
}

/// "add_walls": walls added at the stage start (a plane may be placed by `clearance`).
void bind_add_walls(const json& value, const std::string& at, StageBuild& b) {
  if (!value.is_array()) {
    b.errors.push_back({at, "expected an array of walls, found " + describe(value)});
    return;
  }
  b.resolved["add_walls"] = json::array();
  for (std::size_t q = 0; q < value.size(); ++q) {
    const std::string wp = at + "/" + std::to_string(q);
    json rw;
    b.st.add_walls.push_back(make_wall(value[q], wp, b.errors, rw));
    const double clearance = rw.value("clearance", -1.0);
    if (clearance >= 0.0 && !b.st.add_walls.back().is_plane())
      b.errors.push_back({wp + "/clearance", "expected a plane wall for `clearance`, found a cylinder"});
    b.st.add_wall_clearance.push_back(clearance);
    if (!b.ctx.wall_names.insert(b.st.add_walls.back().name).second)
      b.errors.push_back({wp + "/name", "duplicate wall name \"" + b.st.add_walls.back().name + "\""});
    b.resolved["add_walls"].push_back(rw);
  }
}

struct AffineParams {
  std::vector<double> scale;
  std::vector<double> origin = {0.0, 0.0, 0.0};
};
ParamSpec<AffineParams> affine_spec() {
  ParamSpec<AffineParams> s("affine", "object",
                            "a homogeneous affine map of the scene at the stage start (after from_snapshot and the wall edits, "
                            "before the generator): positions and walls x -> origin + diag(scale) (x - origin), radii kept "
                            "(LAMMPS change_box ... remap; engine/state/affine_map.hpp); planes must be normal to a coordinate axis "
                            "and a cylinder's axis along one with equal scales across it");
  s.add("scale", &AffineParams::scale).unit("1").doc("[sx, sy, sz], each > 0");
  s.add("origin", &AffineParams::origin).unit("m").doc("the fixed point [x, y, z]");
  return s;
}

/// "affine": {"scale": [sx, sy, sz], "origin": [x, y, z]}.
void bind_affine(const json& value, const std::string& at, StageBuild& b) {
  json rs;
  const std::size_t before = b.errors.size();
  const AffineParams q = build(affine_spec(), value, at, b.errors, rs);
  b.resolved["affine"] = rs;
  if (b.errors.size() != before) return;
  if (q.scale.size() != 3) b.errors.push_back({at + "/scale", "expected 3 numbers [sx, sy, sz], found " + std::to_string(q.scale.size())});
  if (q.origin.size() != 3) b.errors.push_back({at + "/origin", "expected 3 numbers [x, y, z], found " + std::to_string(q.origin.size())});
  for (std::size_t k = 0; k < q.scale.size(); ++k)
    if (!std::isfinite(q.scale[k]) || !(q.scale[k] > 0.0))
      b.errors.push_back({at + "/scale/" + std::to_string(k), "expected a finite number > 0, found " + format_number(q.scale[k], 12)});
  if (b.js.is_object() && b.js.contains("generator"))
    b.errors.push_back({at, "a stage with a generator makes its particles after the map; give `affine` to the next stage instead"});
  if (b.errors.size() != before) return;
  b.st.affine_scale = Vec3(q.scale[0], q.scale[1], q.scale[2]);
  b.st.affine_origin = Vec3(q.origin[0], q.origin[1], q.origin[2]);
}

/// "remove_walls": names of walls removed at the stage start.
void bind_remove_walls(const json& value, const std::string& at, StageBuild& b) {
  b.resolved["remove_walls"] = value;
  if (!value.is_array()) {
    b.errors.push_back({at, "expected an array of wall names"});
    return;
  }
  for (std::size_t q = 0; q < value.size(); ++q) {
    const auto& x = value[q];
    if (x.is_string() && b.ctx.wall_names.count(x.get<std::string>())) {
      b.st.remove_walls.push_back(x.get<std::string>());
      b.ctx.wall_names.erase(x.get<std::string>());
    } else {
      b.errors.push_back({at + "/" + std::to_string(q), "expected the name of an existing wall, found " + describe(x) +
                                                            (x.is_string() ? suggest(x.get<std::string>(), wall_list(b.ctx)) : "")});
    }
  }
}

/// "walls": {wall name: motion} during the stage.
void bind_walls(const json& value, const std::string& at, StageBuild& b) {
  if (!value.is_object()) {
    b.errors.push_back({at, "expected an object {wall name: motion}, found " + describe(value)});
    return;
  }
  b.resolved["walls"] = json::object();
  for (auto it = value.begin(); it != value.end(); ++it) {
    if (!b.ctx.wall_names.count(it.key())) {
      b.errors.push_back(
          {at + "/" + it.key(), "no wall named \"" + it.key() + "\" exists in this stage" + suggest(it.key(), wall_list(b.ctx))});
      continue;
    }
    json rm;
    b.st.cfg.motions[it.key()] = make_motion(it.value(), at + "/" + it.key(), b.errors, rm);
    b.resolved["walls"][it.key()] = rm;
  }
}

/// Adds the scenario's particle set `name` to the sets evaluated at the stage start (once).
void use_set(const std::string& name, const std::string& at, StageBuild& b) {
  auto it = b.ctx.sets.find(name);
  if (it == b.ctx.sets.end()) {
    b.errors.push_back({at, "no particle set named \"" + name + "\" in /particle_sets" + suggest(name, names_of(b.ctx.sets))});
    return;
  }
  for (const auto& [n, s2] : b.st.sets)
    if (n == name) return;
  b.st.sets.emplace_back(name, it->second);
}

/// "sets": names of particle sets evaluated at the stage start (fields set/<name>).
void bind_sets(const json& value, const std::string& at, StageBuild& b) {
  b.resolved["sets"] = value;
  if (!value.is_array()) {
    b.errors.push_back({at, "expected an array of particle set names"});
    return;
  }
  for (std::size_t q = 0; q < value.size(); ++q) {
    const std::string sp = at + "/" + std::to_string(q);
    if (!value[q].is_string())
      b.errors.push_back({sp, "expected a set name, found " + describe(value[q])});
    else
      use_set(value[q].get<std::string>(), sp, b);
  }
}

/// "delete_sets": particle sets whose members are deleted at the stage start.
void bind_delete_sets(const json& value, const std::string& at, StageBuild& b) {
  b.resolved["delete_sets"] = value;
  const std::vector<std::string> defined = names_of(b.ctx.sets);
  const std::string known = defined.empty() ? std::string("none is defined") : "defined: " + list_names(defined);
  if (!value.is_array()) {
    b.errors.push_back({at, "expected an array of names of particle sets in /particle_sets (" + known + "), found " + describe(value)});
    return;
  }
  for (std::size_t q = 0; q < value.size(); ++q) {
    const json& x = value[q];
    const std::string sp = at + "/" + std::to_string(q);
    if (!x.is_string() || !b.ctx.sets.count(x.get<std::string>())) {
      b.errors.push_back({sp, "expected the name of a particle set in /particle_sets (" + known + "), found " + describe(x) +
                                  (x.is_string() ? suggest(x.get<std::string>(), defined) : "")});
      continue;
    }
    bool dup = false;
    for (const auto& [n, s2] : b.st.delete_sets) dup = dup || n == x.get<std::string>();
    if (dup)
      b.errors.push_back({sp, "expected each set once, found \"" + x.get<std::string>() + "\" twice"});
    else
      b.st.delete_sets.emplace_back(x.get<std::string>(), b.ctx.sets.at(x.get<std::string>()));
  }
}

struct PrescribeParams {
  Vec3 velocity = Vec3::Zero();
  Vec3 angular_velocity = Vec3::Zero();
  Vec3 center = Vec3::Zero();
};
ParamSpec<PrescribeParams> prescribe_spec() {
  ParamSpec<PrescribeParams> s("prescribe", "object",
                               "the rigid motion of one particle set (zero = clamped); the short form [vx, vy, vz] is a "
                               "velocity. Columns set_<name>_count/fx/fy/fz, the torque about the centre tx/ty/tz [N m] "
                               "and the turned angle [rad]");
  s.add_vec3("velocity", &PrescribeParams::velocity).unit("m/s").doc("translation velocity");
  s.add_vec3("angular_velocity", &PrescribeParams::angular_velocity).unit("rad/s").doc("rotation about `center`");
  s.add_vec3("center", &PrescribeParams::center).unit("m").doc("centre of rotation at the stage start (moves with the set)");
  return s;
}
/// "prescribe": {set name: [vx, vy, vz] | {velocity, angular_velocity, center}}.
void bind_prescribe(const json& value, const std::string& at, StageBuild& b) {
  b.resolved["prescribe"] = value;
  if (!value.is_object()) {
    b.errors.push_back({at, "expected an object {set name: [vx, vy, vz] or {velocity, angular_velocity, center}}"});
    return;
  }
  for (auto it = value.begin(); it != value.end(); ++it) {
    const std::string sp = at + "/" + it.key();
    const json& v = it.value();
    PrescribedMotion m;
    if (v.is_object()) {
      json ignored;
      const PrescribeParams p = build(prescribe_spec(), v, sp, b.errors, ignored);
      m.velocity = p.velocity;
      m.angular_velocity = p.angular_velocity;
      m.center = p.center;
    } else if (v.is_array() && v.size() == 3 && v[0].is_number() && v[1].is_number() && v[2].is_number()) {
      m.velocity = Vec3(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
    } else {
      b.errors.push_back({sp, "expected a velocity [vx, vy, vz] in m/s or {velocity, angular_velocity, center}, found " + describe(v)});
    }
    use_set(it.key(), sp, b);
    b.st.cfg.prescribed_sets[it.key()] = m;
  }
}

struct UntilParams {
  double above = std::numeric_limits<double>::quiet_NaN();
  double below = std::numeric_limits<double>::quiet_NaN();
};
ParamSpec<UntilParams> until_spec() {
  ParamSpec<UntilParams> s("until", "object",
                           "a stop condition on a time-series column: the stage ends when the column is at or above "
                           "`above`, or at or below `below` (exactly one), checked every stop.check_every steps");
  s.add("above", &UntilParams::above).no_default().doc("stop when the column >= this (column unit)");
  s.add("below", &UntilParams::below).no_default().doc("stop when the column <= this (column unit)");
  return s;
}
/// "until": {column: {"above"|"below": value}}.
void bind_until(const json& value, const std::string& at, StageBuild& b) {
  b.resolved["until"] = value;
  if (!value.is_object()) {
    b.errors.push_back({at, "expected an object {quantity: {\"above\"|\"below\": value}}"});
    return;
  }
  for (auto it = value.begin(); it != value.end(); ++it) {
    const std::string cp = at + "/" + it.key();
    json ignored;
    const std::size_t before = b.errors.size();
    const UntilParams p = build(until_spec(), it.value(), cp, b.errors, ignored);
    if (b.errors.size() != before) continue;
    if (std::isnan(p.above) == std::isnan(p.below)) {
      b.errors.push_back({cp, "expected {\"above\": number} or {\"below\": number}, found " + describe(it.value())});
      continue;
    }
    const bool above = !std::isnan(p.above);
    b.st.cfg.until.push_back({it.key(), above, above ? p.above : p.below});
  }
}

/// A registered monitor as a stage key: its parameters, and the walls it reads checked against
/// the stage's (names always; shapes when the wall is known before the run: a scenario wall or
/// one the stage adds; a generator's walls are checked when the monitor first samples).
StageFacet monitor_facet(const std::string& key, const RegistryEntry<Monitor>& entry) {
  auto bind = [key, entry](const json& value, const std::string& at, StageBuild& b) {
    const std::size_t before = b.errors.size();
    const ParamValues v = bind_params(value, entry.spec, at, b.errors);
    b.resolved[key] = to_json(v, entry.spec);
    if (b.errors.size() != before) return;
    std::unique_ptr<Monitor> m;
    try {
      m = entry.make(v);
    } catch (const ConfigError& e) {
      for (const auto& d : e.diagnostics()) b.errors.push_back({at + d.path, d.message});
      return;
    }
    std::map<std::string, bool> plane;  // name -> is a plane
    for (const auto& w : b.ctx.walls) plane[w.name] = w.is_plane();
    for (const auto& w : b.st.add_walls) plane[w.name] = w.is_plane();
    for (const WallUse& u : m->wall_uses()) {
      const char* want = u.plane ? "plane" : "cylinder";
      if (!b.ctx.wall_names.count(u.name))
        b.errors.push_back(
            {at + "/" + u.key, "expected the name of a wall of this stage, found \"" + u.name + "\"" + suggest(u.name, wall_list(b.ctx))});
      else if (plane.count(u.name) && plane[u.name] != u.plane)
        b.errors.push_back({at + "/" + u.key, std::string("expected a ") + want + " wall, found the " + (u.plane ? "cylinder" : "plane") +
                                                  " \"" + u.name + "\""});
    }
    b.st.monitors.push_back(std::move(m));
  };
  return {key, "object", entry.spec.doc, entry.spec, false, bind};
}

ParamSpec<QuasiStaticConfig> quasi_static_spec() {
  using P = QuasiStaticConfig;
  ParamSpec<P> s("quasi_static", "object",
                 "run the stage's mechanics inertia-free (engine/integrate/quasi_static.hpp): each step solves the contacts' "
                 "affine forces for the velocities that balance every particle, pressure walls pressing with their load as "
                 "unknowns; no mass or time scaling (time_scale, mass_scaling, mass_floor_radius stay 1, 1, 0); dt [s] is "
                 "required and split into substeps by max_strain_increment; the contact law needs an inertia-free form "
                 "(sintering)");
  s.add("max_strain_increment", &P::max_strain_increment)
      .unit("1")
      .positive()
      .doc("largest viscous flow (dashpot displacement) of any contact over a substep / its smaller radius; elastic re-balancing is not limited");
  s.add("max_approach_increment", &P::max_approach_increment)
      .unit("1")
      .positive()
      .doc("largest approach (elastic and viscous) of any contact over a substep / its smaller radius: the geometric limit of one linearisation");
  s.add("max_mean_strain_increment", &P::max_mean_strain_increment)
      .unit("1")
      .nonnegative()
      .doc("mean over the contacts of viscous flow / smaller radius per substep, the densification increment (0: no limit; "
           "with it, max_strain_increment can be a looser bound on the fastest contact)");
  s.add("tolerance", &P::tolerance).unit("1").positive().doc("relative residual of the conjugate-gradient solve");
  s.add("max_iterations", &P::max_iterations).min(1).doc("conjugate-gradient iterations per solve");
  s.add("friction_iterations", &P::friction_iterations)
      .min(1)
      .doc("rounds of the nonlinear contacts per solve (Coulomb slip by secant viscosity, unilateral opening)");
  s.add("slip_relaxation", &P::slip_relaxation)
      .unit("1")
      .positive()
      .max(1.0)
      .doc("eps in (0, 1]: a sliding contact's rounds keep this fraction of its secant viscosity along the slip and "
           "apply the rest as the constant force mu F_n (1: secant rounds, contracting by mu F_n / driving force per "
           "round; smaller: nearer Newton, fewer rounds)");
  s.add("friction_tolerance", &P::friction_tolerance).unit("1").positive().doc("the rounds end when the same contacts are open and the motion changed by less than this fraction of its largest component");
  s.add("solver", &P::solver)
      .choices({"auto", "direct", "cg"})
      .doc("direct (sparse LDL^T), cg (conjugate gradients, incomplete-Cholesky preconditioned), auto: direct up to 60,000 unknowns");
  s.add("max_substeps", &P::max_substeps).min(1).doc("substeps a step may be split into (then an error)");
  return s;
}
/// "quasi_static": the inertia-free path and its settings.
void bind_quasi_static(const json& value, const std::string& at, StageBuild& b) {
  json rs;
  auto& c = b.st.cfg;
  c.quasi = build(quasi_static_spec(), value, at, b.errors, rs);
  c.quasi_static = true;
  b.resolved["quasi_static"] = rs;
  if (!(c.dt > 0.0)) b.errors.push_back({b.path + "/dt", "a quasi-static stage needs dt [s] (its substeps follow max_strain_increment)"});
  if (c.time_scale != 1.0)
    b.errors.push_back({b.path + "/time_scale", "expected 1 in a quasi-static stage (no inertia to scale), found " + std::to_string(c.time_scale)});
  if (c.mass_scaling != 1.0)
    b.errors.push_back({b.path + "/mass_scaling", "expected 1 in a quasi-static stage (no inertia to scale), found " + std::to_string(c.mass_scaling)});
  if (c.mass_floor_radius != 0.0)
    b.errors.push_back({b.path + "/mass_floor_radius", "expected 0 in a quasi-static stage (no inertia to scale), found " +
                                                           std::to_string(c.mass_floor_radius)});
}

/// "snapshots": states saved during a stepping stage.
void bind_snapshots(const json& value, const std::string& at, StageBuild& b) {
  json rs;
  const std::size_t before = b.errors.size();
  const SnapshotParams q = build(snapshot_spec(), value, at, b.errors, rs);
  if (b.errors.size() == before) {
    if (!b.st.dynamics && !b.generator_failed)
      b.errors.push_back({at, "only a stage that steps (dynamics, or a generator that settles its packing) takes snapshots; this one is `" +
                                  b.st.type + "`"});
    if (q.at.empty() && q.every_steps == 0) b.errors.push_back({at, "give `at` (values of `column`) or `every_steps`"});
    if (!q.at.empty() && q.every_steps > 0) b.errors.push_back({at + "/every_steps", "give either `at` or `every_steps`, not both"});
    if (!q.at.empty() && q.column.empty())
      b.errors.push_back({at + "/column", "`at` needs the time-series column it refers to (e.g. \"time\", \"packing_density\")"});
    if (q.every_steps > 0 && q.check_every > 0)
      b.errors.push_back({at + "/check_every", "check_every applies to `at`; every_steps snapshots are taken at their steps"});
  }
  b.st.snapshots = SnapshotSpec{q.column.empty() && q.every_steps > 0 ? "time" : q.column, q.at, q.every_steps, q.check_every};
  b.resolved["snapshots"] = rs;
}

}  // namespace

// ------------------------------------------------------------------------ the facet table
std::vector<StageFacet> stage_facets(const Registry& reg) {
  std::vector<StageFacet> f = {
      {"generator", "object", "the parameters of the generator named by the stage's `type` (see \"generators\")", {}, true, bind_generator},
      {"modules", "object {module name: {parameters, \"clock\": module_clock}}", "modules run by the stage (see \"modules\")",
       clock_schema(), true, bind_modules},
      {"create_bonds", "object", create_bonds_spec().spec().doc, create_bonds_spec().spec(), false, bind_create_bonds},
      {"contact", "object {\"law\": contact law, \"params\": {...}}", "the stage's own contact law (else the scenario's)", {}, false, bind_contact},
      {"add_walls", "array of walls", "walls added at the stage start (see \"wall\")", wall_schema(), false, bind_add_walls},
      {"remove_walls", "array of wall names", "walls removed at the stage start", {}, false, bind_remove_walls},
      {"affine", "object", affine_spec().spec().doc, affine_spec().spec(), false, bind_affine},
      {"walls", "object {wall name: motion}", "wall motions during the stage (see \"motion\")", motion_schema(), false, bind_walls},
      {"sets", "array of particle-set names", "particle sets evaluated at the stage start (fields set/<name>)", {}, false, bind_sets},
      {"delete_sets",
       "array of particle-set names",
       "their members at the stage start (after the generator) are deleted, with their contacts and bonds; summary.json "
       "reports the counts (deleted_particles)",
       {},
       false,
       bind_delete_sets},
      {"prescribe", "object {set name: [vx, vy, vz] | prescribe}", prescribe_spec().spec().doc, prescribe_spec().spec(), false,
       bind_prescribe},
      {"until", "object {time-series column: until}", until_spec().spec().doc, until_spec().spec(), false, bind_until},
      {"quasi_static", "object", quasi_static_spec().spec().doc, quasi_static_spec().spec(), false, bind_quasi_static},
  };
  for (const auto& [k, entry] : reg.monitors()) f.push_back(monitor_facet(k, entry));
  f.push_back({"snapshots", "object", snapshot_spec().spec().doc, snapshot_spec().spec(), false, bind_snapshots});
  return f;
}

StageDef build_stage(StageContext& ctx, const json& js, const std::string& path, std::vector<Diagnostic>& errors, json& r) {
  const std::size_t before = errors.size();
  const std::vector<StageFacet> facets = stage_facets(*ctx.reg);
  std::set<std::string> keys = {"sweep"};  // left to the caller
  for (const auto& f : facets) keys.insert(f.key);
  // "dt" is a number (a fixed step) or an object (an adaptive step, its own spec).
  const bool adaptive = js.is_object() && js.contains("dt") && js["dt"].is_object();
  json fixed = js;
  if (adaptive) fixed.erase("dt");
  const StageParams p = build(stage_spec(*ctx.reg), fixed, path, errors, r, keys);
  StageDef st = stage_from_params(p, path);
  if (adaptive) {
    json ra;
    st.cfg.adaptive = build(adaptive_dt_spec(), js["dt"], path + "/dt", errors, ra, {});
    if (!js["dt"].contains("adaptive")) errors.push_back({path + "/dt/adaptive", "required: the fraction F of the stable step (0 < F <= 1)"});
    r["dt"] = ra;
  }
  StageBuild b{ctx, st, js, path, errors, r};
  bind_from_snapshot(p.from_snapshot, b);
  for (const auto& f : facets) {
    const bool given = js.is_object() && js.contains(f.key);
    if (given || f.always) f.bind(given ? js[f.key] : json(), path + "/" + f.key, b);
  }
  if (!b.generator_failed) check_stop_and_dt(b);
  finish_stage(b, before);
  return st;
}

std::string unknown_column(const std::string& column, const std::vector<std::string>& cols) {
  if (std::find(cols.begin(), cols.end(), column) != cols.end()) return "";
  return "\"" + column + "\" is not a time-series column of this stage" + suggest(column, cols) + "; columns: " + list_names(cols);
}

json stage_schema(const Registry& reg) {
  json j = spec_to_json(stage_spec(reg).spec());
  for (const auto& f : stage_facets(reg)) {
    json k = {{"form", f.form}, {"doc", f.doc}};
    if (!f.params.params.empty()) k["params"] = spec_to_json(f.params)["params"];
    j["keys"][f.key] = k;
  }
  return j;
}

}  // namespace sparkdem::io
