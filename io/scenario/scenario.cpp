#include "io/scenario/scenario.hpp"
#include "io/scenario/pipeline.hpp"

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <cmath>
#include <fstream>
#include <limits>
#include <optional>
#include <map>
#include <set>
#include <sstream>

#include "io/scenario/json_binder.hpp"
#include "physics/packing/compact.hpp"

namespace sparkdem::io {

namespace {

// ------------------------------------------------------------------------ scenario-level specs
struct TopParams {
  std::string name = "scenario";
  std::int64_t seed = 12345;
  std::string description;
};
ParamSpec<TopParams> top_spec() {
  ParamSpec<TopParams> s("scenario", "scenario",
                         "top level: materials, contact, walls, stages (each stage: a generator or dynamics)");
  s.add("name", &TopParams::name).doc("scenario name");
  s.add("seed", &TopParams::seed).nonnegative().doc("random seed of every generator");
  s.add("description", &TopParams::description).doc("free text: what the scenario is and the choices behind it (not used by the run)");
  return s;
}

ParamSpec<CheckDef> check_spec() {
  ParamSpec<CheckDef> s("check", "object",
                        "a validation figure: the final value of a stage's time-series column minus `offset`, against a reference "
                        "fixed before the run; summary.json gets value, reference, relative error, band and the stage's wall time");
  s.add("name", &CheckDef::name).required().doc("name of the figure in summary.json \"checks\"");
  s.add("stage", &CheckDef::stage).required().doc("stage name");
  s.add("column", &CheckDef::column).required().doc("time-series column (final value)");
  s.add("offset", &CheckDef::offset).doc("subtracted from the value (column unit)");
  s.add("reference", &CheckDef::reference).required().doc("reference value (column unit), fixed before the run");
  s.add("tolerance", &CheckDef::tolerance).unit("1").nonnegative().doc("relative band; 0: report only");
  s.add("source", &CheckDef::source).doc("where the reference comes from");
  return s;
}
struct MaterialParams {
  std::string name = "material";
  double density = 0.0;
};
ParamSpec<MaterialParams> material_spec() {
  ParamSpec<MaterialParams> s("material", "material", "a particle material (referenced by its index)");
  s.add("name", &MaterialParams::name).doc("material name");
  s.add("density", &MaterialParams::density).unit("kg/m^3").positive().required().doc("mass density");
  return s;
}
struct WallParams {
  std::string name;
  std::string type = "plane";
  Vec3 point = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();
  Vec3 base = Vec3::Zero();
  Vec3 axis = Vec3::UnitZ();
  double radius = 0.0;
  double clearance = -1.0;
};
ParamSpec<WallParams> wall_spec() {
  ParamSpec<WallParams> s("wall", "wall", "a plane (normal into the domain) or a cylinder (particles inside)");
  s.add("name", &WallParams::name).required().doc("unique wall name");
  s.add("type", &WallParams::type).choices({"plane", "cylinder"}).doc("shape");
  s.add_vec3("point", &WallParams::point).unit("m").doc("plane: a point on the plane");
  s.add_vec3("normal", &WallParams::normal).unit("1").doc("plane: normal pointing into the particle domain");
  s.add("clearance", &WallParams::clearance).unit("m")
      .doc("plane added by a stage: placed along its normal at this gap from the nearest particle surface at the stage start (e.g. a punch on a packing); < 0: at `point`");
  s.add_vec3("base", &WallParams::base).unit("m").doc("cylinder: a point on the axis");
  s.add_vec3("axis", &WallParams::axis).unit("1").doc("cylinder: axis direction");
  s.add("radius", &WallParams::radius).unit("m").nonnegative().doc("cylinder: radius");
  return s;
}
struct MotionParams {
  std::string type = "fixed";
  double speed = 0.0;
  double travel = std::numeric_limits<double>::infinity();
  std::vector<double> times, displacements, pressures;
  double area = 0.0;
  double max_speed = 0.0;
};
ParamSpec<MotionParams> motion_spec() {
  ParamSpec<MotionParams> s("motion", "motion",
                            "wall motion during a stage, as an offset u along the inward normal (plane) or a radius "
                            "decrease (cylinder)");
  s.add("type", &MotionParams::type).choices({"fixed", "velocity", "table", "pressure"}).doc("kind of motion");
  s.add("speed", &MotionParams::speed).unit("m/s").doc("velocity: du/dt (positive moves into the domain)");
  s.add("travel", &MotionParams::travel).unit("m").positive().doc("velocity: stop after this displacement");
  s.add("times", &MotionParams::times).unit("s").nonnegative().doc("table/pressure: physical times from the stage start (stage time x time_scale; = stage time when time_scale is 1)");
  s.add("displacements", &MotionParams::displacements).unit("m").doc("table: displacement at each time");
  s.add("pressures", &MotionParams::pressures).unit("Pa").nonnegative().doc("pressure: target pressure at each time");
  s.add("area", &MotionParams::area).unit("m^2").nonnegative().doc("pressure: loaded area (0 = die cross-section)");
  s.add("max_speed", &MotionParams::max_speed).unit("m/s").nonnegative().doc("pressure: servo speed limit");
  return s;
}
struct SetParams {
  std::string type = "top_layer";
  double thickness = 0.0;
  std::string wall;
  double tolerance = 0.0;
  std::vector<double> ids;
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();
  Vec3 axis_point = Vec3::Zero();
  Vec3 axis = Vec3::UnitZ();
  double radius = 0.0;
  std::string criterion = "centre";
};
ParamSpec<SetParams> set_spec() {
  ParamSpec<SetParams> s("particle_set", "particle_set",
                         "a named particle set, evaluated at the start of each stage that lists it in `sets` or "
                         "`prescribe`; stored as the field set/<name>");
  s.add("type", &SetParams::type).choices({"top_layer", "bottom_layer", "touching_wall", "ids", "box", "cylinder"}).doc("selector");
  s.add("thickness", &SetParams::thickness).unit("m").nonnegative().doc("top/bottom_layer: centres within this height of the extreme centre");
  s.add("wall", &SetParams::wall).doc("touching_wall: wall name");
  s.add("tolerance", &SetParams::tolerance).unit("m").nonnegative().doc("touching_wall: allowed surface gap");
  s.add("ids", &SetParams::ids).nonnegative().doc("ids: particle ids");
  s.add_vec3("lo", &SetParams::lo).unit("m").doc("box: lower corner");
  s.add_vec3("hi", &SetParams::hi).unit("m").doc("box: upper corner");
  s.add_vec3("axis_point", &SetParams::axis_point).unit("m").doc("cylinder: a point of the axis (the cylinder is unbounded along it)");
  s.add_vec3("axis", &SetParams::axis).unit("1").doc("cylinder: axis direction (any non-zero length)");
  s.add("radius", &SetParams::radius).unit("m").nonnegative().doc("cylinder: radius (required, > 0)");
  s.add("criterion", &SetParams::criterion).choices({"centre", "overlap"})
      .doc("cylinder: members are the particles whose centre lies within the radius of the axis (centre), or that reach into the cylinder (overlap: distance < radius + particle radius)");
  return s;
}

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
  } output;
  struct Watchdog {
    std::int64_t check_every = 10;
    double max_overlap_ratio = 0.0;
    double max_speed = 0.0;
    double energy_growth_factor = 1e4;
    std::int64_t energy_window = 5;
    double energy_floor_fraction = 0.01;
    std::int64_t snapshot_every_checks = 10;
  } watchdog;
};
ParamSpec<StageParams::Watchdog> watchdog_spec() {
  using P = StageParams::Watchdog;
  ParamSpec<P> s("watchdog", "object",
                 "run watchdog (engine/watchdog.hpp): checks that stop a run going wrong (exit code 3) with the step, "
                 "time, particle ids, quantity, value and bound, and write the last state that passed them as "
                 "OUTDIR/checkpoint_before_failure.h5 (loadable with --restart); the defaults never fire on a healthy run");
  s.add("check_every", &P::check_every).min(1).doc("steps between checks (also checked before step 0 and at the stage end)");
  s.add("max_overlap_ratio", &P::max_overlap_ratio).unit("1").nonnegative()
      .doc("largest overlap / smaller radius of a particle pair (walls are not checked); 0: the contact law's bound "
           "(0.5 for elastic laws, max(1, creep_overlap_limit) + 0.5 for sintering)");
  s.add("max_speed", &P::max_speed).unit("m/s").nonnegative()
      .doc("a particle speed above this is a blow-up (0: blowup_speed, or else each particle's radius per step, r/dt)");
  s.add("energy_growth_factor", &P::energy_growth_factor).unit("1").nonnegative()
      .doc("stop when the kinetic energy per unit mass grew by more than this factor over energy_window checks, at "
           "every check, while its rms speed exceeds energy_floor_fraction of the blow-up speed (a numerical "
           "instability; 0: off)");
  s.add("energy_window", &P::energy_window).min(1).doc("checks over which the kinetic-energy growth is measured");
  s.add("energy_floor_fraction", &P::energy_floor_fraction).unit("1").nonnegative()
      .doc("rms speed sqrt(2 KE / M) below this fraction of the blow-up speed (max_speed or min radius / dt) never counts as growth");
  s.add("snapshot_every_checks", &P::snapshot_every_checks).min(0)
      .doc("checks between in-memory copies of the last healthy state (one more at the stage start; memory: about one "
           "checkpoint; 0: none, and no checkpoint_before_failure.h5)");
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
  return s;
}
ParamSpec<StageParams> stage_spec(const Registry& reg) {
  ParamSpec<StageParams> s("stage", "stage",
                           "one stage: a generator (type = lattice|deposit|fill|relax|cpc_fillers, parameters in `generator`) or "
                           "`dynamics`; plus modules, wall motions, stop condition and output");
  std::vector<std::string> types = {"dynamics"};
  for (const auto& [k, v] : reg.generators()) types.push_back(k);
  s.add("name", &StageParams::name).doc("stage name");
  s.add("type", &StageParams::type).choices(types).doc("dynamics or a generator name");
  s.add("dt", &StageParams::dt).unit("s").nonnegative().doc("time step (0: dt_fraction of the stable step)");
  s.add("dt_fraction", &StageParams::dt_fraction).unit("1").range(0.0, 10.0).doc("time step as a fraction of the stable step at stage start");
  s.add("mechanics", &StageParams::mechanics).choices({"on", "frozen"})
      .doc("frozen: no mechanical step (positions and contacts of the stage start kept; only coupling modules run); dt_fraction then refers to the smallest module stable step");
  s.add("allow_unstable_dt", &StageParams::allow_unstable_dt).doc("run above the stable step (explicit override)");
  s.add("mass_scaling", &StageParams::mass_scaling).unit("1").min(1.0).doc("mass scaling factor (reported; 1 = off)");
  s.add("mass_floor_radius", &StageParams::mass_floor_radius).unit("m").nonnegative().doc("particles smaller than this radius take the mass (and inertia) of a sphere of this radius during the stage, on top of mass_scaling: density scaling of the fines for quasi-static stages (0 = off)");
  s.add("time_scale", &StageParams::time_scale).unit("1").positive().doc("physical seconds per mechanical second: modules in physical time (thermal, sintering kinetics) advance time_scale x dt per step; both clocks are reported");
  s.add("skin", &StageParams::skin).unit("m").nonnegative().doc("Verlet skin (0: 0.3 x smallest radius)");
  s.add("blowup_speed", &StageParams::blowup_speed).unit("m/s").nonnegative().doc("speed that counts as a blow-up (0: radius per step); watchdog.max_speed, when set, takes precedence");
  s.add("sort_every_rebuilds", &StageParams::sort_every_rebuilds).min(0).doc("spatial sort period in neighbour rebuilds (0: never)");
  s.add("stability_check_every", &StageParams::stability_check_every).min(0).doc("steps between stable-step checks (0: start only)");
  s.add("initial_overlap", &StageParams::initial_overlap).choices({"allow", "refuse", "relax"})
      .doc("overlaps of the starting packing above initial_overlap_limit (always reported in summary.json): run as is (allow), refuse before step 0 naming the worst pair (refuse), or move the particles apart first (relax)");
  s.add("initial_overlap_limit", &StageParams::initial_overlap_limit).unit("1").positive()
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
  s.add("check_every", &SnapshotParams::check_every).min(0).doc("stage steps between checks of `at` besides the time-series rows (0: rows only)");
  return s;
}
struct SweepParams {
  std::string snapshots_of;
  std::string parameter;
};
ParamSpec<SweepParams> sweep_spec() {
  ParamSpec<SweepParams> s("sweep", "object",
                           "run the stage once per item, each from the same input state into OUTDIR/sweep_<stage>/<item>/, "
                           "results in OUTDIR/sweep_<stage>.csv and summary.json; the main state after the stage is the "
                           "state before it. Exactly one of snapshots_of, parameter (+ values), seeds");
  s.add("snapshots_of", &SweepParams::snapshots_of).doc("one item per snapshot of this earlier stage");
  s.add("parameter", &SweepParams::parameter).doc("JSON pointer relative to the stage (e.g. /modules/gravity/acceleration/2) substituted by each of `values`");
  return s;
}
using Calibration = SweepDef::Calibration;
ParamSpec<Calibration> calibrate_spec() {
  ParamSpec<Calibration> s("calibrate", "object",
                           "with snapshots_of: find the value of `parameter` for which the final `column` on snapshot "
                           "`snapshot` equals `target` (a scan for the map, then a bracketed search), then run every "
                           "snapshot at that value");
  s.add("parameter", &Calibration::parameter).doc("JSON pointer relative to the stage of the calibrated number");
  s.add("column", &Calibration::column).doc("time-series column whose final value is matched");
  s.add("snapshot", &Calibration::snapshot).min(0).doc("index k of the calibration snapshot (its at[k])");
  s.add("target", &Calibration::target).doc("value of `column` to reach");
  s.add("scan", &Calibration::scan).doc("increasing positive values of the parameter run first (the map); the target must lie between two of them");
  s.add("tolerance", &Calibration::tolerance).unit("1").positive().doc("relative tolerance on `column`");
  s.add("max_iterations", &Calibration::max_iterations).min(1).doc("search items after the scan");
  return s;
}

json sweep_schema() {
  json j = spec_to_json(sweep_spec().spec());
  j["params"].push_back({{"name", "values"}, {"type", "array"}, {"doc", "parameter: one item per value (any JSON value, validated in place)"}});
  j["params"].push_back({{"name", "seeds"}, {"type", "array of integers"}, {"minimum", 0}, {"doc", "one item per seed of the random generator (an ensemble; the table gets mean, sample std and count per column)"}});
  j["params"].push_back({{"name", "collect"}, {"type", "array of strings"}, {"doc", "table columns: final time-series columns and `packing.<key>` report values (default: all)"}});
  return j;
}

// ------------------------------------------------------------------------------------ helpers
template <class P>
P build(const ParamSpec<P>& ps, const json& obj, const std::string& path, std::vector<Diagnostic>& errors,
        json& resolved, const std::set<std::string>& extra = {}) {
  const ParamValues v = bind_params(obj, ps.spec(), path, errors, extra);
  resolved = to_json(v, ps.spec());
  // Build only from values that bound; missing ones keep the aggregate's defaults.
  return ps.build(v);
}

std::vector<std::string> names_of(const auto& map) {
  std::vector<std::string> n;
  for (const auto& [k, v] : map) n.push_back(k);
  return n;
}

std::string list_names(const std::vector<std::string>& n) {
  std::string s;
  for (const auto& x : n) s += (s.empty() ? "" : ", ") + x;
  return s;
}

/// An object {"law": name, "params": {...}} (plus `extra` keys, checked by the caller) naming an
/// entry of a registry table; `what` is "contact law" or "bond law".
template <class T>
std::unique_ptr<T> make_named(const json& c, const std::map<std::string, RegistryEntry<T>>& table, const std::string& what,
                              const std::string& path, std::vector<Diagnostic>& errors, json& resolved,
                              const std::set<std::string>& extra = {}) {
  if (!c.is_object()) { errors.push_back({path, "expected an object {\"law\": ..., \"params\": {...}}, found " + describe(c)}); return nullptr; }
  for (auto it = c.begin(); it != c.end(); ++it)
    if (it.key() != "law" && it.key() != "params" && !extra.count(it.key()))
      errors.push_back({path + "/" + it.key(), "unknown key \"" + it.key() + "\" (expected \"law\" and \"params\")"});
  if (!c.contains("law") || !c["law"].is_string()) {
    errors.push_back({path + "/law", "missing or non-string " + what + " name; registered: " + list_names(names_of(table))});
    return nullptr;
  }
  const auto name = c["law"].get<std::string>();
  auto it = table.find(name);
  if (it == table.end()) {
    const auto dym = did_you_mean(name, names_of(table));
    errors.push_back({path + "/law", "unknown " + what + " \"" + name + "\"" + (dym.empty() ? "" : " (did you mean \"" + dym + "\"?)") +
                                         "; registered: " + list_names(names_of(table))});
    return nullptr;
  }
  const std::size_t before = errors.size();
  const ParamValues v = bind_params(c.value("params", json::object()), it->second.spec, path + "/params", errors);
  resolved = {{"law", name}, {"params", to_json(v, it->second.spec)}};
  if (errors.size() != before) return nullptr;
  return it->second.make(v);
}

std::unique_ptr<ContactModel> make_law(const json& c, const Registry& reg, const std::string& path,
                                       std::vector<Diagnostic>& errors, json& resolved) {
  return make_named(c, reg.laws(), "contact law", path, errors, resolved);
}

/// A module clock: {"kind": every_step|every_n_steps|substeps|adaptive_substeps|on_event, "n",
/// and for on_event the trigger conditions}.
struct ClockParams {
  std::string kind = "every_step";
  std::int64_t n = 1;
  double moved_beyond = std::numeric_limits<double>::infinity();
  std::string field;
  double field_change = std::numeric_limits<double>::infinity();
  bool bond_broke = false;
  std::int64_t max_interval = 0;
};
ParamSpec<ClockParams> clock_spec() {
  using P = ClockParams;
  ParamSpec<P> s("clock", "object", "when a module runs relative to the mechanical step");
  s.add("kind", &P::kind).choices({"every_step", "every_n_steps", "substeps", "adaptive_substeps", "on_event"})
      .doc("every step; every n steps (dt = n dt_m); n substeps per step (dt = dt_m/n); adaptive substeps (at least n, more when the module's stable step shrinks); on an event");
  s.add("n", &P::n).min(1).doc("steps per call (every_n_steps) or (minimum) substeps per step");
  s.add("moved_beyond", &P::moved_beyond).unit("m").positive().doc("on_event: a particle moved more than this since the last call");
  s.add("field", &P::field).doc("on_event: particle field watched for changes");
  s.add("field_change", &P::field_change).positive().doc("on_event: change of `field` (its unit) that triggers a call");
  s.add("bond_broke", &P::bond_broke).doc("on_event: a bond broke since the last call");
  s.add("max_interval", &P::max_interval).min(0).doc("on_event: also call after this many steps (0: never)");
  return s;
}
Clock make_clock(const json& j, const std::string& path, std::vector<Diagnostic>& errors, json& resolved) {
  const ClockParams p = build(clock_spec(), j, path, errors, resolved);
  Clock c;
  c.n = p.n;
  if (p.kind == "every_n_steps") c.kind = Clock::Kind::EveryNSteps;
  else if (p.kind == "substeps") c.kind = Clock::Kind::SubstepsPerStep;
  else if (p.kind == "adaptive_substeps") c.kind = Clock::Kind::AdaptiveSubsteps;
  else if (p.kind == "on_event") c.kind = Clock::Kind::OnEvent;
  c.trigger = {p.moved_beyond, p.field, p.field_change, p.bond_broke, p.max_interval};
  const bool event_keys = std::isfinite(p.moved_beyond) || !p.field.empty() || std::isfinite(p.field_change) ||
                          p.bond_broke || p.max_interval > 0;
  if (c.kind == Clock::Kind::OnEvent) {
    if (!(std::isfinite(p.moved_beyond) || (!p.field.empty() && std::isfinite(p.field_change)) || p.bond_broke ||
          p.max_interval > 0))
      errors.push_back({path, "an on_event clock needs a condition: moved_beyond, field + field_change, bond_broke or max_interval"});
    if (p.field.empty() != !std::isfinite(p.field_change))
      errors.push_back({path + "/field_change", "field and field_change go together"});
  } else if (event_keys) {
    errors.push_back({path + "/kind", "trigger conditions are given but kind is \"" + p.kind + "\", not \"on_event\""});
  }
  return c;
}

Wall make_wall(const json& w, const std::string& path, std::vector<Diagnostic>& errors, json& resolved) {
  const WallParams p = build(wall_spec(), w, path, errors, resolved);
  Wall out;
  out.name = p.name;
  if (p.type == "plane") {
    if (p.normal.norm() == 0.0) errors.push_back({path + "/normal", "expected a non-zero normal, found [0, 0, 0]"});
    out.shape = PlaneShape{p.point, p.normal.norm() > 0 ? Vec3(p.normal.normalized()) : Vec3(Vec3::UnitZ())};
  } else {
    if (p.axis.norm() == 0.0) errors.push_back({path + "/axis", "expected a non-zero axis, found [0, 0, 0]"});
    if (!(p.radius > 0.0)) errors.push_back({path + "/radius", "a cylinder needs a radius > 0 [m], found " + std::to_string(p.radius)});
    out.shape = CylinderShape{p.base, p.axis.norm() > 0 ? Vec3(p.axis.normalized()) : Vec3(Vec3::UnitZ()), p.radius};
  }
  return out;
}

WallMotion make_motion(const json& m, const std::string& path, std::vector<Diagnostic>& errors, json& resolved) {
  const MotionParams p = build(motion_spec(), m, path, errors, resolved);
  WallMotion out;
  out.physical_time = true;  // tables in physical seconds, like the physical-time modules
  if (p.type == "fixed") out.kind = WallMotion::Kind::Fixed;
  if (p.type == "velocity") { out.kind = WallMotion::Kind::Velocity; out.speed = p.speed; out.travel = p.travel; }
  auto check_table = [&](const std::vector<double>& values, const char* key) {
    if (p.times.empty()) errors.push_back({path + "/times", std::string("a ") + p.type + " motion needs `times`, found none"});
    if (values.size() != p.times.size())
      errors.push_back({path + "/" + key, "expected " + std::to_string(p.times.size()) + " values (one per time), found " + std::to_string(values.size())});
    for (std::size_t k = 1; k < p.times.size(); ++k)
      if (!(p.times[k] > p.times[k - 1])) errors.push_back({path + "/times/" + std::to_string(k), "times must increase strictly"});
  };
  if (p.type == "table") {
    out.kind = WallMotion::Kind::Table;
    check_table(p.displacements, "displacements");
    out.table_time = p.times;
    out.table_disp = p.displacements;
  }
  if (p.type == "pressure") {
    out.kind = WallMotion::Kind::Pressure;
    check_table(p.pressures, "pressures");
    if (!(p.max_speed > 0.0)) errors.push_back({path + "/max_speed", "a pressure motion needs max_speed > 0 [m/s]"});
    out.pressure_time = p.times;
    out.pressure_value = p.pressures;
    out.area = p.area;
    out.max_speed = p.max_speed;
  }
  return out;
}

/// Are the particle centres of a scratch generation inside every wall?
void check_enclosed(const State& s, const std::string& path, std::vector<Diagnostic>& errors) {
  for (const auto& w : s.walls) {
    std::size_t outside = 0;
    Id first = -1;
    for (std::size_t i = 0; i < s.particles.size(); ++i) {
      Vec3 n;
      double d;
      w.distance(s.particles.position[i], n, d);
      if (d < 0.0) { if (!outside) first = s.particles.id[i]; ++outside; }
    }
    if (outside)
      errors.push_back({path, std::to_string(outside) + " of " + std::to_string(s.particles.size()) +
                                  " particles (first id " + std::to_string(first) + ") lie outside wall '" + w.name +
                                  "': the walls do not enclose the particles"});
  }
}

/// JSON pointer of a value nested more than `limit` levels deep in `j`, or "". The walk stops at
/// the limit, so it never recurses deeper itself (copying a JSON value is recursive: a document
/// nested 1e5 levels deep would overflow the stack in the loader).
std::string too_deep(const json& j, int limit, const std::string& path) {
  if (!j.is_structured()) return "";
  if (limit == 0) return path.empty() ? "/" : path;
  std::size_t k = 0;
  for (auto it = j.begin(); it != j.end(); ++it, ++k) {
    const std::string p = too_deep(it.value(), limit - 1, path + "/" + (j.is_object() ? it.key() : std::to_string(k)));
    if (!p.empty()) return p;
  }
  return "";
}

/// What checking a stage depends on from the scenario and the stages before it.
struct StageContext {
  std::shared_ptr<const Registry> reg;
  std::filesystem::path base_dir;
  std::map<std::string, SetSelector> sets;  ///< the scenario's particle sets
  std::set<std::string> wall_names;         ///< walls at the stage start (the stage updates it)
  bool has_particles = false;               ///< an earlier stage creates particles (updated)
  std::vector<Material> materials;          ///< for the lattice enclosure check
  std::vector<Wall> walls;                  ///< scenario walls, for the lattice enclosure check
  bool has_bond_law = false;                ///< the scenario names a bond law
  /// Output: the time-series columns of the stage just built (none when unknown before the run:
  /// a stage from a snapshot file).
  std::optional<std::vector<std::string>> columns;
};

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

/// "" if `column` is one of `cols`, else the problem (with a did-you-mean).
std::string unknown_column(const std::string& column, const std::vector<std::string>& cols) {
  if (std::find(cols.begin(), cols.end(), column) != cols.end()) return "";
  const auto dym = did_you_mean(column, cols);
  return "\"" + column + "\" is not a time-series column of this stage" + (dym.empty() ? "" : " (did you mean \"" + dym + "\"?)") +
         "; columns: " + list_names(cols);
}

/// Bind and check one stage (its "sweep" key is left to the caller); appends every problem to
/// `errors` and the resolved stage to `r`.
StageDef build_stage(StageContext& ctx, const json& js, const std::string& path, std::vector<Diagnostic>& errors, json& r) {
  const std::size_t before = errors.size();
  const StageParams p = build(stage_spec(*ctx.reg), js, path, errors, r, {"generator", "modules", "walls", "add_walls", "remove_walls", "until", "contact", "sets", "delete_sets", "prescribe", "snapshots", "sweep", "create_bonds", "compact"});
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
  st.from_snapshot = p.from_snapshot.empty() ? "" : (ctx.base_dir / p.from_snapshot).string();
  // (error_code overloads: a name too long for the file system is "cannot read", not an exception)
  std::error_code snapshot_ec;
  const bool snapshot_exists = !st.from_snapshot.empty() && std::filesystem::exists(st.from_snapshot, snapshot_ec);
  if (!st.from_snapshot.empty() && !snapshot_exists)
    errors.push_back({path + "/from_snapshot", "cannot read the snapshot file '" + st.from_snapshot + "'"});
  if (!st.from_snapshot.empty()) ctx.has_particles = true;
  if (snapshot_exists) {
    // The stage starts with the snapshot's walls: their names (and shapes) are checked against it.
    try {
      State snap;
      (void)read_checkpoint(st.from_snapshot, snap);
      ctx.wall_names.clear();
      ctx.walls = snap.walls;
      for (const auto& w : snap.walls) ctx.wall_names.insert(w.name);
    } catch (const SetupError&) {
      throw;  // a damaged snapshot is a set-up failure (exit 4), as when the stage starts
    } catch (const std::exception& e) {
      errors.push_back({path + "/from_snapshot", std::string("cannot load the snapshot: ") + e.what()});
    }
  }
  // Generator
  if (st.type != "dynamics") {
    auto g = ctx.reg->generators().find(st.type);
    if (g != ctx.reg->generators().end()) {
      const json jg = js.value("generator", json::object());
      const std::size_t b2 = errors.size();
      ParamValues v = bind_params(jg, g->second.spec, path + "/generator", errors);
      // Resolve relative CSV paths of size distributions against the scenario directory.
      auto csv = v.find("size_distribution.csv");
      if (csv != v.end() && !std::get<std::string>(csv->second).empty())
        csv->second = (ctx.base_dir / std::get<std::string>(csv->second)).string();
      r["generator"] = to_json(v, g->second.spec);
      // `fill` with a given mean radius: N radii uniform in r(1 +- spread) have
      // <r^3> = r^3 (1 + spread^2), so their solid fraction N 4/3 pi r^3 (1 + spread^2) / V must
      // not exceed 0.74 (densest sphere packing). (Without mean_radius, Eq. 1 sizes the radii
      // to exactly target_density <= 0.7 of the container.)
      if (st.type == "fill" && errors.size() == b2 && get_real(v, "mean_radius") > 0.0) {
        constexpr double kPi = 3.14159265358979323846;
        double volume = 0.0;
        if (get_text(v, "shape") == "cylinder") {
          volume = kPi * get_real(v, "radius") * get_real(v, "radius") * get_real(v, "length");
        } else {
          const auto lo = get_list(v, "lo"), hi = get_list(v, "hi");
          volume = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
        }
        const double n = static_cast<double>(get_int(v, "particles")), rbar = get_real(v, "mean_radius"),
                     spread = get_real(v, "spread");
        const double phi = n * 4.0 / 3.0 * kPi * rbar * rbar * rbar * (1.0 + spread * spread) / volume;
        if (!(volume > 0.0) || !(phi <= 0.74)) {
          std::ostringstream msg;
          msg.precision(4);
          msg << get_int(v, "particles") << " particles of mean radius " << rbar << " m (spread " << spread
              << ") do not fit the container of volume " << volume << " m^3: solid fraction " << phi
              << " > 0.74; use fewer particles, a smaller mean_radius or a larger container";
          errors.push_back({path + "/generator/particles", msg.str()});
        }
      }
      if (errors.size() == b2) {
        try {
          st.generator = g->second.make(v);
          r["estimated_particles"] = st.generator->estimated_particles();
        } catch (const ConfigError& e) {
          for (const auto& d : e.diagnostics()) {
            std::string sub = d.path;
            if (sub.rfind("/", 0) == 0 && (st.type == "deposit")) sub = "/size_distribution" + sub;
            errors.push_back({path + "/generator" + sub, d.message});
          }
        }
      }
      st.dynamics = st.generator ? st.generator->steps() : (st.type == "deposit" || st.type == "fill" || st.type == "cpc_fillers");
      ctx.has_particles = true;
    }
  } else if (js.contains("generator")) {
    errors.push_back({path + "/generator", "a `dynamics` stage takes no generator; set \"type\" to one of " + list_names(names_of(ctx.reg->generators()))});
  }
  if (st.type == "dynamics" && !ctx.has_particles)
    errors.push_back({path + "/type", "this dynamics stage has no particles: no earlier stage generates them and it has no from_snapshot"});
  if (st.dynamics && std::isinf(c.duration) && c.max_steps == std::numeric_limits<std::int64_t>::max())
    errors.push_back({path + "/stop", "a stage needs a hard stop: stop.time [s] or stop.steps"});
  if (st.dynamics && c.dt == 0.0 && c.dt_fraction == 0.0)
    errors.push_back({path + "/dt", "set dt [s] or dt_fraction (fraction of the stable step)"});
  if (c.dt > 0.0 && c.dt_fraction > 0.0)
    errors.push_back({path + "/dt_fraction", "give either dt or dt_fraction, not both"});
  // Modules
  r["modules"] = json::object();
  const std::size_t errors_before_modules = errors.size();
  if (js.contains("modules")) {
    if (!js["modules"].is_object()) errors.push_back({path + "/modules", "expected an object {module name: {params}}, found " + describe(js["modules"])});
    else
      for (auto it = js["modules"].begin(); it != js["modules"].end(); ++it) {
        auto m = ctx.reg->modules().find(it.key());
        if (m == ctx.reg->modules().end()) {
          const auto dym = did_you_mean(it.key(), names_of(ctx.reg->modules()));
          errors.push_back({path + "/modules/" + it.key(), "unknown module \"" + it.key() + "\"" + (dym.empty() ? "" : " (did you mean \"" + dym + "\"?)") + "; registered modules: " + list_names(names_of(ctx.reg->modules()))});
          continue;
        }
        const std::size_t b2 = errors.size();
        const ParamValues v = bind_params(it.value(), m->second.spec, path + "/modules/" + it.key(), errors, {"clock"});
        r["modules"][it.key()] = to_json(v, m->second.spec);
        std::optional<Clock> clk;
        if (it.value().is_object() && it.value().contains("clock")) {
          json rc;
          clk = make_clock(it.value()["clock"], path + "/modules/" + it.key() + "/clock", errors, rc);
          r["modules"][it.key()]["clock"] = rc;
        }
        if (errors.size() == b2) {
          try {
            st.modules.push_back(m->second.make(v));
            if (clk) st.modules.back()->set_clock(*clk);
          } catch (const ConfigError& e) {  // a module's own consistency checks (paths relative to it)
            for (const auto& d : e.diagnostics()) errors.push_back({path + "/modules/" + it.key() + d.path, d.message});
          }
        }
      }
  }
  // A module that failed to build has no columns: the stage's columns are then unknown and the
  // checks against them (snapshot column, sweep collect) are left out rather than reported for
  // every column of the failed module.
  const bool modules_built = errors.size() == errors_before_modules;
  // Bonds created at the stage start
  if (js.contains("create_bonds")) {
    const std::string bp = path + "/create_bonds";
    const json& cb = js["create_bonds"];
    const bool rel = cb.is_object() && cb.contains("gap_tolerance_relative");
    const char* key = rel ? "gap_tolerance_relative" : "gap_tolerance";
    if (!cb.is_object() || cb.size() != 1 || !cb.contains(key) || !cb[key].is_number() || !(cb[key].get<double>() >= 0.0))
      errors.push_back({bp, "expected {\"gap_tolerance\": number >= 0} [m] or {\"gap_tolerance_relative\": number >= 0} "
                            "[1, of the mean radius at the stage start] (bond every pair whose gap is at most this; 0 = "
                            "touching pairs), found " + describe(cb)});
    else {
      st.create_bonds_gap = cb[key].get<double>();
      st.create_bonds_gap_relative = rel;
    }
    if (!ctx.has_bond_law) errors.push_back({bp, "creating bonds needs a bond law: add \"bonds\": {\"law\": ...} at the top level"});
    r["create_bonds"] = cb;
  }
  // Contact law override
  if (js.contains("contact")) { json rc; st.law = make_law(js["contact"], *ctx.reg, path + "/contact", errors, rc); r["contact"] = rc; }
  // Walls added / removed / moved
  if (js.contains("add_walls")) {
    if (!js["add_walls"].is_array()) errors.push_back({path + "/add_walls", "expected an array of walls, found " + describe(js["add_walls"])});
    else {
      r["add_walls"] = json::array();
      for (std::size_t q = 0; q < js["add_walls"].size(); ++q) {
        json rw;
        st.add_walls.push_back(make_wall(js["add_walls"][q], path + "/add_walls/" + std::to_string(q), errors, rw));
        const double clearance = rw.value("clearance", -1.0);
        if (clearance >= 0.0 && !st.add_walls.back().is_plane())
          errors.push_back({path + "/add_walls/" + std::to_string(q) + "/clearance", "expected a plane wall for `clearance`, found a cylinder"});
        st.add_wall_clearance.push_back(clearance);
        if (!ctx.wall_names.insert(st.add_walls.back().name).second)
          errors.push_back({path + "/add_walls/" + std::to_string(q) + "/name", "duplicate wall name \"" + st.add_walls.back().name + "\""});
        r["add_walls"].push_back(rw);
      }
    }
  }
  if (st.type == "deposit") { ctx.wall_names.insert("die"); ctx.wall_names.insert("bottom"); }
  if (st.type == "fill" || st.type == "relax") for (const char* n : {"die", "bottom", "top", "xlo", "xhi", "ylo", "yhi"}) ctx.wall_names.insert(n);
  if (st.type == "cpc_fillers") for (const char* n : {"bottom", "top", "xlo", "xhi", "ylo", "yhi"}) ctx.wall_names.insert(n);
  if (js.contains("remove_walls")) {
    if (!js["remove_walls"].is_array()) errors.push_back({path + "/remove_walls", "expected an array of wall names"});
    else
      for (std::size_t q = 0; q < js["remove_walls"].size(); ++q) {
        const auto& x = js["remove_walls"][q];
        if (!x.is_string() || !ctx.wall_names.count(x.get<std::string>()))
          errors.push_back({path + "/remove_walls/" + std::to_string(q), "expected the name of an existing wall, found " + describe(x)});
        else { st.remove_walls.push_back(x.get<std::string>()); ctx.wall_names.erase(x.get<std::string>()); }
      }
    r["remove_walls"] = js["remove_walls"];
  }
  if (js.contains("walls")) {
    if (!js["walls"].is_object()) errors.push_back({path + "/walls", "expected an object {wall name: motion}, found " + describe(js["walls"])});
    else {
      r["walls"] = json::object();
      for (auto it = js["walls"].begin(); it != js["walls"].end(); ++it) {
        if (!ctx.wall_names.count(it.key())) {
          const auto dym = did_you_mean(it.key(), std::vector<std::string>(ctx.wall_names.begin(), ctx.wall_names.end()));
          errors.push_back({path + "/walls/" + it.key(), "no wall named \"" + it.key() + "\" exists in this stage" + (dym.empty() ? "" : " (did you mean \"" + dym + "\"?)")});
          continue;
        }
        json rm;
        c.motions[it.key()] = make_motion(it.value(), path + "/walls/" + it.key(), errors, rm);
        r["walls"][it.key()] = rm;
      }
    }
  }
  // Particle sets evaluated at the stage start, and sets held at a prescribed velocity.
  auto use_set = [&](const std::string& name, const std::string& at) {
    auto it = ctx.sets.find(name);
    if (it == ctx.sets.end()) {
      std::vector<std::string> names;
      for (const auto& [k, v] : ctx.sets) names.push_back(k);
      const auto dym = did_you_mean(name, names);
      errors.push_back({at, "no particle set named \"" + name + "\" in /particle_sets" + (dym.empty() ? "" : " (did you mean \"" + dym + "\"?)")});
      return;
    }
    for (const auto& [n, s2] : st.sets)
      if (n == name) return;
    st.sets.emplace_back(name, it->second);
  };
  if (js.contains("sets")) {
    if (!js["sets"].is_array()) errors.push_back({path + "/sets", "expected an array of particle set names"});
    else
      for (std::size_t q = 0; q < js["sets"].size(); ++q) {
        if (!js["sets"][q].is_string()) errors.push_back({path + "/sets/" + std::to_string(q), "expected a set name, found " + describe(js["sets"][q])});
        else use_set(js["sets"][q].get<std::string>(), path + "/sets/" + std::to_string(q));
      }
    r["sets"] = js["sets"];
  }
  if (js.contains("delete_sets")) {
    const std::string dp = path + "/delete_sets";
    std::vector<std::string> defined;
    for (const auto& [k, v] : ctx.sets) defined.push_back(k);
    const std::string known = defined.empty() ? std::string("none is defined") : "defined: " + list_names(defined);
    if (!js["delete_sets"].is_array())
      errors.push_back({dp, "expected an array of names of particle sets in /particle_sets (" + known + "), found " + describe(js["delete_sets"])});
    else
      for (std::size_t q = 0; q < js["delete_sets"].size(); ++q) {
        const json& x = js["delete_sets"][q];
        const std::string at = dp + "/" + std::to_string(q);
        if (!x.is_string() || !ctx.sets.count(x.get<std::string>())) {
          const auto dym = x.is_string() ? did_you_mean(x.get<std::string>(), defined) : std::string();
          errors.push_back({at, "expected the name of a particle set in /particle_sets (" + known + "), found " + describe(x) +
                                    (dym.empty() ? "" : " (did you mean \"" + dym + "\"?)")});
          continue;
        }
        bool dup = false;
        for (const auto& [n, s2] : st.delete_sets) dup = dup || n == x.get<std::string>();
        if (dup) errors.push_back({at, "expected each set once, found \"" + x.get<std::string>() + "\" twice"});
        else st.delete_sets.emplace_back(x.get<std::string>(), ctx.sets.at(x.get<std::string>()));
      }
    r["delete_sets"] = js["delete_sets"];
  }
  if (js.contains("prescribe")) {
    if (!js["prescribe"].is_object()) errors.push_back({path + "/prescribe", "expected an object {set name: [vx, vy, vz] or {velocity, angular_velocity, center}}"});
    else
      for (auto it = js["prescribe"].begin(); it != js["prescribe"].end(); ++it) {
        const std::string at = path + "/prescribe/" + it.key();
        const auto& v = it.value();
        auto vec3 = [&](const json& x, const std::string& where, const char* what, Vec3& out) {
          if (!x.is_array() || x.size() != 3 || !x[0].is_number() || !x[1].is_number() || !x[2].is_number()) {
            errors.push_back({where, std::string("expected ") + what + ", found " + describe(x)});
            return;
          }
          out = Vec3(x[0].get<double>(), x[1].get<double>(), x[2].get<double>());
        };
        PrescribedMotion m;
        if (v.is_object()) {
          for (auto k = v.begin(); k != v.end(); ++k)
            if (k.key() != "velocity" && k.key() != "angular_velocity" && k.key() != "center")
              errors.push_back({at + "/" + k.key(), "unknown key; expected velocity, angular_velocity or center"});
          if (v.contains("velocity")) vec3(v["velocity"], at + "/velocity", "a velocity [vx, vy, vz] in m/s", m.velocity);
          if (v.contains("angular_velocity"))
            vec3(v["angular_velocity"], at + "/angular_velocity", "an angular velocity [wx, wy, wz] in rad/s", m.angular_velocity);
          if (v.contains("center")) vec3(v["center"], at + "/center", "a point [x, y, z] in m", m.center);
        } else {
          vec3(v, at, "a velocity [vx, vy, vz] in m/s or {velocity, angular_velocity, center}", m.velocity);
        }
        use_set(it.key(), at);
        c.prescribed_sets[it.key()] = m;
      }
    r["prescribe"] = js["prescribe"];
  }
  // Until
  if (js.contains("until")) {
    if (!js["until"].is_object()) errors.push_back({path + "/until", "expected an object {quantity: {\"above\"|\"below\": value}}"});
    else
      for (auto it = js["until"].begin(); it != js["until"].end(); ++it) {
        const auto& cond = it.value();
        const std::string cp = path + "/until/" + it.key();
        if (!cond.is_object() || cond.size() != 1 || !(cond.contains("above") || cond.contains("below")) ||
            !cond.begin().value().is_number()) {
          errors.push_back({cp, "expected {\"above\": number} or {\"below\": number}, found " + describe(cond)});
          continue;
        }
        c.until.push_back({it.key(), cond.contains("above"), cond.begin().value().get<double>()});
      }
    r["until"] = js["until"];
  }
  // Porosity of a compact in a die (monitor columns porosity, porosity_interior, ...).
  if (js.contains("compact")) {
    const std::string cp = path + "/compact";
    json rc;
    const std::size_t b2 = errors.size();
    const physics::CompactParams q = build(physics::compact_spec(), js["compact"], cp, errors, rc);
    if (errors.size() == b2) {
      // Shapes are checked here when the wall is known at load time (scenario or added walls; a
      // generator's walls are checked when the monitor first samples).
      std::map<std::string, bool> plane;  // name -> is a plane
      for (const auto& w : ctx.walls) plane[w.name] = w.is_plane();
      for (const auto& w : st.add_walls) plane[w.name] = w.is_plane();
      auto check = [&](const std::string& key, const std::string& name, bool want_plane) {
        if (!ctx.wall_names.count(name)) {
          const auto dym = did_you_mean(name, std::vector<std::string>(ctx.wall_names.begin(), ctx.wall_names.end()));
          errors.push_back({cp + "/" + key, "expected the name of a wall of this stage, found \"" + name + "\"" +
                                                (dym.empty() ? "" : " (did you mean \"" + dym + "\"?)")});
        } else if (plane.count(name) && plane[name] != want_plane) {
          errors.push_back({cp + "/" + key, std::string("expected a ") + (want_plane ? "plane" : "cylinder") + " wall, found the " +
                                                (want_plane ? "cylinder" : "plane") + " \"" + name + "\""});
        }
      };
      check("die", q.die, false);
      check("bottom", q.bottom, true);
      check("top", q.top, true);
      if (q.bottom == q.top) errors.push_back({cp + "/top", "expected a wall other than the bottom punch, found \"" + q.top + "\""});
    }
    st.monitors.push_back(std::make_shared<physics::CompactMonitor>(q));
    r["compact"] = rc;
  }
  // Generator-defined settling: motions and stop conditions.
  if (st.generator) {
    st.generator->configure_stage(c);
    for (auto& m : st.generator->modules()) st.modules.push_back(std::move(m));
  }
  // Consistency: a lattice inside the scenario walls (scratch generation, no dynamics).
  // Cheap only up to ~1e6 particles; a larger lattice is not generated just for this check,
  // and one that could never be allocated (a typo in spacing or hi) is an error.
  const double lattice_n = st.generator && st.type == "lattice" ? st.generator->estimated_particles() : 0.0;
  if (!(lattice_n <= 1e9))
    errors.push_back({path + "/generator", "the lattice would create " + std::to_string(lattice_n) +
                                               " particles (more than 1e9); check spacing, lo and hi"});
  if (st.generator && st.type == "lattice" && errors.size() == before && lattice_n <= 1e6) {
    State scratch;
    scratch.materials = ctx.materials;
    scratch.walls = ctx.walls;
    try {
      st.generator->generate(scratch);
      check_enclosed(scratch, path + "/generator", errors);
    } catch (const ConfigError& e) {
      for (const auto& d : e.diagnostics()) errors.push_back({path + "/generator" + d.path, d.message});
    }
  }
  // Snapshots taken during the stage.
  if (js.contains("snapshots")) {
    const std::string sp = path + "/snapshots";
    json rs;
    const std::size_t b2 = errors.size();
    const SnapshotParams q = build(snapshot_spec(), js["snapshots"], sp, errors, rs);
    if (errors.size() == b2) {
      if (!st.dynamics)
        errors.push_back({sp, "only a stage that steps (dynamics, deposit, fill) takes snapshots; this one is `" + st.type + "`"});
      if (q.at.empty() && q.every_steps == 0)
        errors.push_back({sp, "give `at` (values of `column`) or `every_steps`"});
      if (!q.at.empty() && q.every_steps > 0)
        errors.push_back({sp + "/every_steps", "give either `at` or `every_steps`, not both"});
      if (!q.at.empty() && q.column.empty())
        errors.push_back({sp + "/column", "`at` needs the time-series column it refers to (e.g. \"time\", \"packing_density\")"});
      if (q.every_steps > 0 && q.check_every > 0)
        errors.push_back({sp + "/check_every", "check_every applies to `at`; every_steps snapshots are taken at their steps"});
    }
    st.snapshots = SnapshotSpec{q.column.empty() && q.every_steps > 0 ? "time" : q.column, q.at, q.every_steps, q.check_every};
    r["snapshots"] = rs;
  }
  ctx.columns.reset();
  if (st.from_snapshot.empty() && modules_built) ctx.columns = stage_columns(st, ctx.wall_names, ctx.has_bond_law);
  if (st.snapshots && ctx.columns && js["snapshots"].is_object() && js["snapshots"].contains("column") &&
      js["snapshots"]["column"].is_string() && !st.snapshots->column.empty()) {
    const std::string bad = unknown_column(st.snapshots->column, *ctx.columns);
    if (!bad.empty()) errors.push_back({path + "/snapshots/column", bad});
  }
  return st;
}

/// Is `token` an index of an array of `size` elements (RFC 6901: digits, no leading zero)?
bool array_index(const std::string& token, std::size_t size) {
  if (token.empty() || token.size() > 18 || (token.size() > 1 && token[0] == '0')) return false;
  if (!std::all_of(token.begin(), token.end(), [](char c) { return c >= '0' && c <= '9'; })) return false;
  return std::stoull(token) < size;
}

/// Checks the swept parameter's pointer against the stage JSON; returns a problem or "".
std::string check_parameter(const json& stage, const std::string& text, json::json_pointer& ptr) {
  const std::string example = " (e.g. \"/modules/gravity/acceleration/2\" or \"/contact/params/friction\")";
  try {
    ptr = json::json_pointer(text);
  } catch (const json::exception&) {
    return "\"" + text + "\" is not a JSON pointer" + example;
  }
  if (ptr.empty()) return "expected a JSON pointer to one value of the stage" + example + ", found \"\"";
  json::json_pointer top = ptr;
  while (!top.parent_pointer().empty()) top = top.parent_pointer();
  if (top.back() == "sweep" || top.back() == "name" || top.back() == "type")
    return "\"" + text + "\": the stage's " + top.back() + " cannot be swept";
  const json::json_pointer parent = ptr.parent_pointer();
  // Walk the parent by hand: contains() on a malformed array token would throw.
  const json* node = &stage;
  std::string walked;
  json::json_pointer rest = parent;
  std::vector<std::string> tokens;
  while (!rest.empty()) { tokens.insert(tokens.begin(), rest.back()); rest.pop_back(); }
  for (const auto& t : tokens) {
    walked += "/" + t;
    if (node->is_object() && node->contains(t)) node = &(*node)[t];
    else if (node->is_array() && array_index(t, node->size())) node = &(*node)[std::stoull(t)];
    else return "\"" + text + "\": the stage has no " + walked + " (the parameter's parent must be written in the stage)";
  }
  if (node->is_array() && !array_index(ptr.back(), node->size()))
    return "\"" + text + "\": " + (parent.empty() ? std::string("/") : parent.to_string()) + " is an array of " +
           std::to_string(node->size()) + ", \"" + ptr.back() + "\" is not one of its indices";
  if (!node->is_object() && !node->is_array())
    return "\"" + text + "\": " + parent.to_string() + " is " + describe(*node) + ", not an object or array";
  return "";
}

/// What a sweep over snapshots needs to know of a stage before it.
struct EarlierStage {
  std::string name;
  bool snapshots = false;             ///< it takes snapshots
  std::set<std::string> wall_names;   ///< its walls (those of its snapshots)
};

/// Largest number of items of one sweep: each item is a whole run that keeps its state, and 1e5
/// items took over 10 s just to bind (found by the loader fuzzing).
constexpr std::size_t kMaxSweepItems = 10000;

/// Parses a stage's "sweep" (the stage JSON `js` has one) into `sw`.
void parse_sweep(const json& js, const std::string& path, const std::vector<EarlierStage>& earlier,
                 SweepDef& sw, std::vector<Diagnostic>& errors, json& resolved) {
  const std::string sp = path + "/sweep";
  const json& j = js["sweep"];
  json r;
  const SweepParams p = build(sweep_spec(), j, sp, errors, r, {"values", "seeds", "collect", "calibrate"});
  if (!j.is_object()) return;
  if (j.contains("calibrate")) {
    json rc;
    const Calibration c = build(calibrate_spec(), j["calibrate"], sp + "/calibrate", errors, rc, {});
    if (!j.contains("snapshots_of")) errors.push_back({sp + "/calibrate", "calibrate goes with snapshots_of (it calibrates on one snapshot)"});
    for (const char* k : {"parameter", "column", "target", "scan"})
      if (j["calibrate"].is_object() && !j["calibrate"].contains(k)) errors.push_back({sp + "/calibrate/" + k, "required"});
    bool increasing = c.scan.size() >= 2;
    for (std::size_t q = 0; q < c.scan.size(); ++q)
      if (!(c.scan[q] > 0.0) || (q > 0 && !(c.scan[q] > c.scan[q - 1]))) increasing = false;
    if (j["calibrate"].is_object() && j["calibrate"].contains("scan") && !increasing)
      errors.push_back({sp + "/calibrate/scan", "expected at least two positive, increasing values, found " + describe(j["calibrate"]["scan"])});
    sw.calibrate = c;
    r["calibrate"] = rc;
  }
  std::vector<std::string> kinds;
  for (const char* k : {"snapshots_of", "parameter", "seeds"})
    if (j.contains(k)) kinds.push_back(k);
  if (kinds.size() != 1) {
    errors.push_back({sp, kinds.empty() ? std::string("give one of snapshots_of, parameter (with values) or seeds")
                                        : "give exactly one of snapshots_of, parameter, seeds; found " + list_names(kinds)});
  }
  if (j.contains("values") && !j.contains("parameter"))
    errors.push_back({sp + "/values", "values go with `parameter` (the JSON pointer they replace)"});
  if (kinds.size() == 1 && kinds[0] == "snapshots_of") {
    sw.kind = SweepDef::Kind::Snapshots;
    sw.snapshots_of = p.snapshots_of;
    std::vector<std::string> with;
    for (std::size_t q = 0; q < earlier.size(); ++q) {
      if (earlier[q].snapshots) with.push_back(earlier[q].name);
      if (earlier[q].name == p.snapshots_of && earlier[q].snapshots) sw.snapshots_stage = static_cast<std::int64_t>(q);
    }
    if (j["snapshots_of"].is_string() && sw.snapshots_stage < 0) {
      const bool exists = std::any_of(earlier.begin(), earlier.end(), [&](const auto& e) { return e.name == p.snapshots_of; });
      const auto dym = did_you_mean(p.snapshots_of, with);
      errors.push_back({sp + "/snapshots_of",
                        exists ? "stage \"" + p.snapshots_of + "\" takes no snapshots (give it \"snapshots\")"
                               : "no earlier stage named \"" + p.snapshots_of + "\" takes snapshots" +
                                     (dym.empty() ? "" : " (did you mean \"" + dym + "\"?)") +
                                     (with.empty() ? std::string("; no earlier stage takes any") : "; stages with snapshots: " + list_names(with))});
    }
  }
  if (kinds.size() == 1 && kinds[0] == "parameter") {
    sw.kind = SweepDef::Kind::Parameter;
    sw.parameter = p.parameter;
    if (!j.contains("values") || !j["values"].is_array() || j["values"].empty())
      errors.push_back({sp + "/values", "expected a non-empty array of values for " + p.parameter + ", found " +
                                            (j.contains("values") ? describe(j["values"]) : std::string("nothing"))});
    else if (j["values"].size() > kMaxSweepItems)
      errors.push_back({sp + "/values", "expected at most " + std::to_string(kMaxSweepItems) + " sweep values, found " +
                                            std::to_string(j["values"].size()) + " (split the sweep into several scenarios)"});
    else
      for (const auto& v : j["values"]) sw.values.push_back(v);
    r["values"] = j.value("values", json::array());
  }
  if (kinds.size() == 1 && kinds[0] == "seeds") {
    sw.kind = SweepDef::Kind::Seeds;
    const json& x = j["seeds"];
    if (!x.is_array() || x.empty()) {
      errors.push_back({sp + "/seeds", "expected a non-empty array of seeds (non-negative integers), found " + describe(x)});
    } else if (x.size() > kMaxSweepItems) {
      errors.push_back({sp + "/seeds", "expected at most " + std::to_string(kMaxSweepItems) + " seeds, found " +
                                           std::to_string(x.size()) + " (split the sweep into several scenarios)"});
    } else {
      for (std::size_t q = 0; q < x.size(); ++q) {
        const bool ok = x[q].is_number_unsigned() || (x[q].is_number_integer() && x[q].get<std::int64_t>() >= 0);
        if (!ok) { errors.push_back({sp + "/seeds/" + std::to_string(q), "expected a non-negative integer seed, found " + describe(x[q])}); continue; }
        const auto seed = x[q].get<std::uint64_t>();
        if (std::find(sw.seeds.begin(), sw.seeds.end(), seed) != sw.seeds.end())
          errors.push_back({sp + "/seeds/" + std::to_string(q), "duplicate seed " + std::to_string(seed)});
        sw.seeds.push_back(seed);
      }
    }
    r["seeds"] = x;
  }
  if (j.contains("collect")) {
    const json& c = j["collect"];
    if (!c.is_array() || c.empty()) {
      errors.push_back({sp + "/collect", "expected a non-empty array of column names, found " + describe(c)});
    } else {
      for (std::size_t q = 0; q < c.size(); ++q) {
        if (!c[q].is_string() || c[q].get<std::string>().empty()) {
          errors.push_back({sp + "/collect/" + std::to_string(q), "expected a column name, found " + describe(c[q])});
          continue;
        }
        const auto name = c[q].get<std::string>();
        if (std::find(sw.collect.begin(), sw.collect.end(), name) != sw.collect.end())
          errors.push_back({sp + "/collect/" + std::to_string(q), "duplicate column \"" + name + "\""});
        sw.collect.push_back(name);
      }
    }
    r["collect"] = c;
  }
  resolved = json::object();
  if (j.contains("snapshots_of")) resolved["snapshots_of"] = j["snapshots_of"];
  if (j.contains("parameter")) resolved["parameter"] = j["parameter"];
  for (const char* k : {"values", "seeds", "collect", "calibrate"})
    if (r.contains(k)) resolved[k] = r[k];
}


/// A stage with a "sweep": checks the sweep and every item's stage JSON (a parameter value that
/// does not bind is reported at /stages/k/sweep/values/i), and keeps a builder of fresh item
/// stages for the run. The context is left as before the stage: a sweep is a branch.
StageDef build_sweep_stage(StageContext& ctx, const json& js, const std::string& path,
                           const std::vector<EarlierStage>& earlier, std::vector<Diagnostic>& errors, json& r) {
  auto sw = std::make_shared<SweepDef>();
  json rsweep;
  parse_sweep(js, path, earlier, *sw, errors, rsweep);
  sw->stage_json = js;
  sw->stage_json.erase("sweep");
  StageContext item_ctx = ctx;  // copy: the items' context, and the main sequence's is unchanged
  if (sw->kind == SweepDef::Kind::Snapshots) {
    item_ctx.has_particles = true;
    if (sw->snapshots_stage >= 0) item_ctx.wall_names = earlier[static_cast<std::size_t>(sw->snapshots_stage)].wall_names;
  }
  std::optional<std::vector<std::string>> columns;  // of the (first) item
  StageDef st;
  json::json_pointer ptr;
  bool pointer_ok = false;
  if (sw->kind == SweepDef::Kind::Parameter && js["sweep"]["parameter"].is_string()) {
    const std::string bad = check_parameter(sw->stage_json, sw->parameter, ptr);
    if (!bad.empty()) errors.push_back({path + "/sweep/parameter", bad});
    pointer_ok = bad.empty();
  }
  if (pointer_ok && !sw->values.empty()) {
    // Bind the stage once per value; a problem at (or inside) the substituted value belongs to
    // that value, the others are reported once.
    const std::string target = path + ptr.to_string();
    bool absent = false;
    try { absent = !sw->stage_json.contains(ptr); } catch (const json::exception&) { absent = true; }
    // A problem at (or inside) the substituted value, or one that only some values cause (a
    // consequence, e.g. no hard stop left), belongs to those values; one every value causes is
    // reported once at its own path.
    std::vector<std::vector<Diagnostic>> per_item(sw->values.size());
    std::map<std::pair<std::string, std::string>, std::size_t> count;
    for (std::size_t i = 0; i < sw->values.size(); ++i) {
      StageContext c = item_ctx;
      json ri;
      StageDef sti = build_stage(c, sw->item_json(i), path, per_item[i], ri);
      std::set<std::pair<std::string, std::string>> once;
      for (const auto& d : per_item[i])
        if (once.insert({d.path, d.message}).second) ++count[{d.path, d.message}];
      if (i == 0) { st = std::move(sti); r = ri; columns = c.columns; }
    }
    std::set<std::pair<std::string, std::string>> reported;
    for (std::size_t i = 0; i < sw->values.size(); ++i) {
      const std::string vpath = path + "/sweep/values/" + std::to_string(i);
      const std::string what = "value " + sw->values[i].dump() + " for " + sw->parameter + ": ";
      for (const auto& d : per_item[i]) {
        const bool here = d.path == target || d.path.rfind(target + "/", 0) == 0;
        if (here && absent && d.path == target && d.message.rfind("unknown key", 0) == 0) {
          if (reported.insert({path + "/sweep/parameter", d.message}).second)
            errors.push_back({path + "/sweep/parameter", "\"" + sw->parameter + "\" names no parameter of the stage: " + d.message});
        } else if (here) {
          errors.push_back({vpath + d.path.substr(target.size()), what + d.message});
        } else if (count[{d.path, d.message}] < sw->values.size()) {
          errors.push_back({vpath, what + d.message + " (at " + d.path + ")"});
        } else if (reported.insert({d.path, d.message}).second) {
          errors.push_back(d);
        }
      }
    }
  } else if (sw->calibrate && !sw->calibrate->scan.empty()) {
    // Bind the stage with the first scan value (the others differ only in that number).
    const std::string bad = check_parameter(sw->stage_json, sw->calibrate->parameter, ptr);
    StageContext c = item_ctx;
    if (!bad.empty()) {
      errors.push_back({path + "/sweep/calibrate/parameter", bad});
      st = build_stage(c, sw->stage_json, path, errors, r);
    } else {
      st = build_stage(c, sw->calibration_json(sw->calibrate->scan.front()), path, errors, r);
    }
    columns = c.columns;
    if (columns) {
      const std::string unknown = unknown_column(sw->calibrate->column, *columns);
      if (!unknown.empty()) errors.push_back({path + "/sweep/calibrate/column", unknown});
    }
  } else {
    StageContext c = item_ctx;
    st = build_stage(c, sw->stage_json, path, errors, r);
    columns = c.columns;
  }
  // Table columns: time-series columns of the stage, or packing.<key> of its generator report.
  // The first kMaxColumnErrors unknown columns are reported one by one (with a did-you-mean over
  // the stage's columns); the rest in one line, so a long collect list of a module that lost its
  // columns (e.g. an option switched off) stays readable and cheap to check.
  constexpr std::size_t kMaxColumnErrors = 20;
  std::size_t unknown_reported = 0;
  std::vector<std::string> more_unknown;
  for (std::size_t q = 0; q < sw->collect.size(); ++q) {
    const std::string& name = sw->collect[q];
    const std::string at = path + "/sweep/collect/" + std::to_string(q);
    if (name.rfind("packing.", 0) == 0) {
      if (!st.generator) errors.push_back({at, "\"" + name + "\": this stage has no generator, so no packing report"});
    } else if (columns && std::find(columns->begin(), columns->end(), name) == columns->end()) {
      if (unknown_reported++ < kMaxColumnErrors)
        errors.push_back({at, unknown_column(name, *columns) + " (or packing.<key> of a generator's report)"});
      else
        more_unknown.push_back(std::to_string(q));
    }
  }
  if (!more_unknown.empty())
    errors.push_back({path + "/sweep/collect", std::to_string(more_unknown.size()) + " more entries are not time-series columns of "
                      "this stage (indices " + list_names(more_unknown) + ")"});
  if (st.snapshots) errors.push_back({path + "/snapshots", "a sweep stage takes no snapshots (take them in the stage it sweeps over)"});
  if (sw->kind == SweepDef::Kind::Snapshots && !st.from_snapshot.empty())
    errors.push_back({path + "/from_snapshot", "a sweep over snapshots starts from each snapshot; remove from_snapshot"});
  item_ctx.reg = std::make_shared<const Registry>(*ctx.reg);  // the builder outlives the caller's registry
  sw->build = [item_ctx, path](const json& stage_json, json& resolved) {
    StageContext c = item_ctx;
    std::vector<Diagnostic> e;
    StageDef d = build_stage(c, stage_json, path, e, resolved);
    if (!e.empty()) throw ConfigError(e);
    return d;
  };
  r["sweep"] = rsweep;
  st.sweep = std::move(sw);
  return st;
}

}  // namespace

json read_json_file(const std::filesystem::path& file) {
  // Only regular files: a device (/dev/zero), a FIFO or a directory would be read for ever or fail
  // obscurely; a size limit keeps a mistaken include from exhausting memory.
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec))
    throw ConfigError("", "cannot read the scenario file '" + file.string() + "': " +
                              (std::filesystem::exists(file, ec) ? "not a regular file" : "no such file"));
  if (std::filesystem::file_size(file, ec) > (std::uintmax_t{64} << 20))
    throw ConfigError("", "the scenario file '" + file.string() + "' is larger than 64 MiB");
  std::ifstream in(file);
  if (!in) throw ConfigError("", "cannot read the scenario file '" + file.string() + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  try {
    return json::parse(ss.str());
  } catch (const json::exception& e) {  // parse_error, or out_of_range for a number like 1e400
    throw ConfigError("", "'" + file.string() + "' is not valid JSON: " + e.what());
  }
}

/// Replace every object holding "$include": "file.json" by the object in that file (resolved
/// relative to the including file's directory), with the keys written beside "$include"
/// overriding the included ones (shallow). Included files may include others (8 levels).
/// Any other key starting with '$' ("$sources", "$comment") is an annotation and is dropped.
void expand_includes(json& j, const std::filesystem::path& dir, const std::string& path, int depth,
                     std::vector<Diagnostic>& errors) {
  if (j.is_array()) {
    for (std::size_t k = 0; k < j.size(); ++k) expand_includes(j[k], dir, path + "/" + std::to_string(k), depth, errors);
    return;
  }
  if (!j.is_object()) return;
  std::filesystem::path here = dir;
  if (j.contains("$include")) {
    const json& inc = j["$include"];
    if (!inc.is_string()) {
      errors.push_back({path + "/$include", "expected a file name (string), found " + describe(inc)});
      return;
    }
    if (depth >= 8) {
      errors.push_back({path + "/$include", "includes nested more than 8 deep (a cycle?)"});
      return;
    }
    const std::filesystem::path file = dir / inc.get<std::string>();
    json base;
    try {
      base = read_json_file(file);
    } catch (const ConfigError& e) {
      errors.push_back({path + "/$include", e.what()});
      return;
    }
    if (!base.is_object()) {
      errors.push_back({path + "/$include", "expected '" + file.string() + "' to hold a JSON object, found " + describe(base)});
      return;
    }
    expand_includes(base, file.parent_path(), path + "/$include(" + inc.get<std::string>() + ")", depth + 1, errors);
    for (auto it = j.begin(); it != j.end(); ++it)
      if (it.key() != "$include") base[it.key()] = it.value();
    j = std::move(base);
    here = dir;  // keys written beside $include belong to the including file
  }
  for (auto it = j.begin(); it != j.end(); ++it) expand_includes(it.value(), here, path + "/" + it.key(), depth, errors);
  // Other keys starting with '$' are annotations (e.g. "$sources" of a material file): dropped.
  for (auto it = j.begin(); it != j.end();) it = it.key().starts_with('$') ? j.erase(it) : std::next(it);
}

// Stage and check counts are bounded: a scene has tens of stages, and a mistaken array of 100000
// entries would take minutes to diagnose entry by entry.
constexpr std::size_t kMaxStages = 1000;

/// The top-level "checks" (validation figures in summary.json): each names a stage of `sc` (the last
/// of that name is the one it reads); a banded check needs a stage that steps.
static void load_checks(const json& j, Scenario& sc, std::vector<Diagnostic>& errors) {
  if (j.contains("checks")) {
    if (!j["checks"].is_array()) errors.push_back({"/checks", "expected an array of checks, found " + describe(j["checks"])});
    else if (j["checks"].size() > kMaxStages)
      errors.push_back({"/checks", "expected at most " + std::to_string(kMaxStages) + " checks, found " + std::to_string(j["checks"].size())});
    else
      for (std::size_t k = 0; k < j["checks"].size(); ++k) {
        const std::string cp = "/checks/" + std::to_string(k);
        json r;
        CheckDef c = build(check_spec(), j["checks"][k], cp, errors, r);
        if (c.reference == 0.0) errors.push_back({cp + "/reference", "expected a non-zero reference value, found 0"});
        const StageDef* stage = nullptr;  // the last stage of that name (the one a check reads)
        for (const StageDef& st : sc.stages)
          if (st.cfg.name == c.stage) stage = &st;
        if (!stage)
          errors.push_back({cp + "/stage", "expected the name of a stage of this scenario, found \"" + c.stage + "\""});
        else if (c.tolerance > 0.0 && (stage->sweep || !stage->dynamics))
          errors.push_back({cp + "/stage", "expected a stage that steps (a check with a tolerance band needs the stage's final "
                                           "values), found \"" + c.stage + "\", " +
                                               (stage->sweep ? "a sweep stage (its items' values are in its sweep table)"
                                                             : "a generator stage without dynamics") +
                                               "; use tolerance 0 (report only)"});
        sc.checks.push_back(c);
        sc.resolved["checks"].push_back(r);
      }
  }
}

Scenario load_scenario(const json& j_in, const Registry& reg, const std::filesystem::path& base_dir) {
  std::vector<Diagnostic> errors;
  Scenario sc;
  if (!j_in.is_object()) throw ConfigError("", "expected a JSON object at the top level, found " + describe(j_in));
  if (const std::string deep = too_deep(j_in, 32, ""); !deep.empty())
    throw ConfigError(deep, "nested more than 32 levels deep (a scenario needs fewer than 10)");
  json j = j_in;
  expand_includes(j, base_dir, "", 0, errors);
  if (!errors.empty()) throw ConfigError(std::move(errors));
  json resolved_top;
  const TopParams top = build(top_spec(), j, "", errors, resolved_top, {"materials", "contact", "bonds", "walls", "stages", "particle_sets", "checks"});
  // Particle sets
  std::map<std::string, SetSelector> sets;
  if (j.contains("particle_sets")) {
    if (!j["particle_sets"].is_object()) errors.push_back({"/particle_sets", "expected an object {name: selector}, found " + describe(j["particle_sets"])});
    else
      for (auto it = j["particle_sets"].begin(); it != j["particle_sets"].end(); ++it) {
        json r;
        const std::string sp = "/particle_sets/" + it.key();
        const SetParams sp_ = build(set_spec(), it.value(), sp, errors, r);
        SetSelector sel;
        if (sp_.type == "top_layer") sel.kind = SetSelector::Kind::TopLayer;
        if (sp_.type == "bottom_layer") sel.kind = SetSelector::Kind::BottomLayer;
        if (sp_.type == "touching_wall") sel.kind = SetSelector::Kind::TouchingWall;
        if (sp_.type == "ids") sel.kind = SetSelector::Kind::Ids;
        if (sp_.type == "box") sel.kind = SetSelector::Kind::Box;
        if (sp_.type == "cylinder") sel.kind = SetSelector::Kind::Cylinder;
        if ((sp_.type == "top_layer" || sp_.type == "bottom_layer") && !(sp_.thickness > 0.0))
          errors.push_back({sp + "/thickness", "a layer set needs thickness > 0 [m]"});
        if (sp_.type == "touching_wall" && sp_.wall.empty()) errors.push_back({sp + "/wall", "a touching_wall set needs a wall name"});
        if (sp_.type == "ids" && sp_.ids.empty()) errors.push_back({sp + "/ids", "an ids set needs at least one id"});
        const auto reported = [&errors](const std::string& path) {
          return std::any_of(errors.begin(), errors.end(), [&path](const Diagnostic& d) { return d.path == path; });
        };
        if (sp_.type == "cylinder" && !(sp_.radius > 0.0) && !reported(sp + "/radius"))
          errors.push_back({sp + "/radius", "a cylinder set needs radius > 0 [m], found " +
                                                (it.value().is_object() && it.value().contains("radius") ? it.value()["radius"].dump() : std::string("nothing"))});
        if (sp_.type == "cylinder" && !(sp_.axis.norm() > 0.0) && !reported(sp + "/axis"))
          errors.push_back({sp + "/axis", "a cylinder set needs a non-zero axis direction [1], found [0, 0, 0]"});
        sel.thickness = sp_.thickness;
        sel.wall = sp_.wall;
        sel.tolerance = sp_.tolerance;
        for (double x : sp_.ids) sel.ids.push_back(static_cast<Id>(x));
        sel.lo = sp_.lo;
        sel.hi = sp_.hi;
        sel.axis_point = sp_.axis_point;
        sel.axis = sp_.axis;
        sel.radius = sp_.radius;
        sel.overlap = sp_.criterion == "overlap";
        sets[it.key()] = sel;
        resolved_top["particle_sets"][it.key()] = r;
      }
  }
  sc.name = top.name;
  sc.seed = static_cast<std::uint64_t>(top.seed);
  sc.resolved = resolved_top;

  // Materials
  sc.resolved["materials"] = json::array();
  if (!j.contains("materials") || !j["materials"].is_array() || j["materials"].empty()) {
    errors.push_back({"/materials", "expected a non-empty array of materials [{\"name\", \"density\"}], found " +
                                        (j.contains("materials") ? describe(j["materials"]) : std::string("nothing"))});
  } else {
    for (std::size_t k = 0; k < j["materials"].size(); ++k) {
      json r;
      const auto m = build(material_spec(), j["materials"][k], "/materials/" + std::to_string(k), errors, r);
      sc.materials.push_back({m.name, m.density});
      sc.resolved["materials"].push_back(r);
    }
  }
  // Contact law
  if (!j.contains("contact")) errors.push_back({"/contact", "missing required key \"contact\" ({\"law\": name, \"params\": {...}}); registered laws: " + list_names(names_of(reg.laws()))});
  else { json r; sc.law = make_law(j["contact"], reg, "/contact", errors, r); sc.resolved["contact"] = r; }
  // Bond law (optional): {"law", "params", "contact_rule": "exclude"|"add"}
  if (j.contains("bonds")) {
    json r;
    sc.bond_law = make_named(j["bonds"], reg.bond_laws(), "bond law", "/bonds", errors, r, {"contact_rule"});
    if (j["bonds"].is_object() && j["bonds"].contains("contact_rule")) {
      const json& cr = j["bonds"]["contact_rule"];
      if (cr == "add") sc.bond_contact_rule = BondTable::ContactRule::Add;
      else if (cr != "exclude")
        errors.push_back({"/bonds/contact_rule", "expected \"exclude\" (bonded pairs get no contact force, default) or \"add\" (bond and contact forces add up), found " + describe(cr)});
    }
    r["contact_rule"] = sc.bond_contact_rule == BondTable::ContactRule::Add ? "add" : "exclude";
    sc.resolved["bonds"] = r;
  }
  // Walls
  std::set<std::string> wall_names;
  sc.resolved["walls"] = json::array();
  if (j.contains("walls")) {
    if (!j["walls"].is_array()) errors.push_back({"/walls", "expected an array of walls, found " + describe(j["walls"])});
    else
      for (std::size_t k = 0; k < j["walls"].size(); ++k) {
        json r;
        Wall w = make_wall(j["walls"][k], "/walls/" + std::to_string(k), errors, r);
        if (!w.name.empty() && !wall_names.insert(w.name).second)
          errors.push_back({"/walls/" + std::to_string(k) + "/name", "duplicate wall name \"" + w.name + "\""});
        sc.walls.push_back(w);
        sc.resolved["walls"].push_back(r);
      }
  }
  // Stages
  sc.resolved["stages"] = json::array();
  if (!j.contains("stages") || !j["stages"].is_array() || j["stages"].empty()) {
    errors.push_back({"/stages", "expected a non-empty array of stages, found " + (j.contains("stages") ? describe(j["stages"]) : std::string("nothing"))});
  } else if (j["stages"].size() > kMaxStages) {
    errors.push_back({"/stages", "expected at most " + std::to_string(kMaxStages) + " stages, found " + std::to_string(j["stages"].size())});
  } else {
    StageContext ctx;
    ctx.reg = std::shared_ptr<const Registry>(std::shared_ptr<const Registry>(), &reg);  // not owned
    ctx.base_dir = base_dir;
    ctx.has_bond_law = j.contains("bonds");
    ctx.sets = sets;
    ctx.wall_names = wall_names;
    ctx.materials = sc.materials;
    ctx.walls = sc.walls;
    std::vector<EarlierStage> earlier;
    for (std::size_t k = 0; k < j["stages"].size(); ++k) {
      const std::string path = "/stages/" + std::to_string(k);
      const json& js = j["stages"][k];
      json r;
      if (!js.is_object() || !js.contains("sweep")) {
        StageDef st = build_stage(ctx, js, path, errors, r);
        earlier.push_back({st.cfg.name, st.snapshots.has_value(), ctx.wall_names});
        sc.resolved["stages"].push_back(r);
        sc.stages.push_back(std::move(st));
        continue;
      }
      sc.stages.push_back(build_sweep_stage(ctx, js, path, earlier, errors, r));
      earlier.push_back({sc.stages.back().cfg.name, false, ctx.wall_names});
      sc.resolved["stages"].push_back(r);
    }
    // Stages with snapshots or a sweep name their files after themselves.
    for (std::size_t k = 0; k < sc.stages.size(); ++k) {
      if (!sc.stages[k].snapshots && !sc.stages[k].sweep) continue;
      for (std::size_t q = 0; q < sc.stages.size(); ++q)
        if (q != k && sc.stages[q].cfg.name == sc.stages[k].cfg.name) {
          errors.push_back({"/stages/" + std::to_string(k) + "/name", "a stage with snapshots or a sweep needs a unique name (it names "
                                                                      "its files); stage " + std::to_string(q) + " is also \"" +
                                                                      sc.stages[k].cfg.name + "\""});
          break;
        }
    }
  }
  load_checks(j, sc, errors);
  if (!errors.empty()) throw ConfigError(errors);
  return sc;
}

json schema_json(const Registry& reg) {
  json j;
  j["scenario"] = spec_to_json(top_spec().spec());
  j["material"] = spec_to_json(material_spec().spec());
  j["wall"] = spec_to_json(wall_spec().spec());
  j["motion"] = spec_to_json(motion_spec().spec());
  j["stage"] = spec_to_json(stage_spec(reg).spec());
  j["particle_set"] = spec_to_json(set_spec().spec());
  j["check"] = spec_to_json(check_spec().spec());
  j["stage"]["sets"] = "array of particle-set names evaluated at the stage start";
  j["stage"]["delete_sets"] = "array of particle-set names: their members at the stage start (after the generator) are deleted, "
                              "with their contacts and bonds; summary.json reports the counts (deleted_particles)";
  j["stage"]["prescribe"] = "object {set name: [vx, vy, vz] m/s | {\"velocity\": m/s, \"angular_velocity\": rad/s, \"center\": m}}: "
                            "the set moves rigidly (zero = clamped), turning about `center` (moving with it); columns "
                            "set_<name>_count/fx/fy/fz, torque about the centre tx/ty/tz [N m] and the turned angle [rad]";
  j["stage"]["until"] = "object {quantity: {\"above\"|\"below\": value}}; quantities are time-series columns";
  j["stage"]["snapshots"] = spec_to_json(snapshot_spec().spec());
  j["stage"]["compact"] = spec_to_json(physics::compact_spec().spec());
  j["stage"]["sweep"] = sweep_schema();
  for (const auto& [k, v] : reg.laws()) j["contact_laws"][k] = spec_to_json(v.spec);
  for (const auto& [k, v] : reg.bond_laws()) j["bond_laws"][k] = spec_to_json(v.spec);
  for (const auto& [k, v] : reg.modules()) j["modules"][k] = spec_to_json(v.spec);
  j["module_clock"] = spec_to_json(clock_spec().spec());
  j["stage"]["create_bonds"] = "object {\"gap_tolerance\": m} or {\"gap_tolerance_relative\": fraction of the mean radius}: bond every pair whose gap is at most this at the stage start";
  j["bonds"] = "object {\"law\": bond law, \"params\": {...}, \"contact_rule\": \"exclude\"|\"add\"}";
  for (const auto& [k, v] : reg.generators()) j["generators"][k] = spec_to_json(v.spec);
  return j;
}

json SweepDef::item_json(std::size_t k) const {
  json j = stage_json;
  if (kind == Kind::Parameter && k < values.size()) j[json::json_pointer(parameter)] = values[k];
  return j;
}

json SweepDef::calibration_json(double value) const {
  json j = stage_json;
  if (calibrate) j[json::json_pointer(calibrate->parameter)] = value;
  return j;
}

}  // namespace sparkdem::io
