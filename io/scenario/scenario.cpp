#include "io/scenario/scenario.hpp"

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
#include "io/scenario/scenario_parts.hpp"
#include "io/scenario/stage_facets.hpp"

namespace sparkdem::io {

namespace {

// ------------------------------------------------------------------------ scenario-level specs
struct TopParams {
  std::string name = "scenario";
  std::int64_t seed = 12345;
  std::string description;
};
ParamSpec<TopParams> top_spec() {
  ParamSpec<TopParams> s("scenario", "scenario", "top level: materials, contact, walls, stages (each stage: a generator or dynamics)");
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
  s.add("thickness", &SetParams::thickness)
      .unit("m")
      .nonnegative()
      .doc("top/bottom_layer: centres within this height of the extreme centre");
  s.add("wall", &SetParams::wall).doc("touching_wall: wall name");
  s.add("tolerance", &SetParams::tolerance).unit("m").nonnegative().doc("touching_wall: allowed surface gap");
  s.add("ids", &SetParams::ids).nonnegative().doc("ids: particle ids");
  s.add_vec3("lo", &SetParams::lo).unit("m").doc("box: lower corner");
  s.add_vec3("hi", &SetParams::hi).unit("m").doc("box: upper corner");
  s.add_vec3("axis_point", &SetParams::axis_point).unit("m").doc("cylinder: a point of the axis (the cylinder is unbounded along it)");
  s.add_vec3("axis", &SetParams::axis).unit("1").doc("cylinder: axis direction (any non-zero length)");
  s.add("radius", &SetParams::radius).unit("m").nonnegative().doc("cylinder: radius (required, > 0)");
  s.add("criterion", &SetParams::criterion)
      .choices({"centre", "overlap"})
      .doc(
          "cylinder: members are the particles whose centre lies within the radius of the axis (centre), or that reach into the cylinder "
          "(overlap: distance < radius + particle radius)");
  return s;
}

struct SweepParams {
  std::string snapshots_of;
  std::string parameter;
  bool keep_item_states = true;
};
ParamSpec<SweepParams> sweep_spec() {
  ParamSpec<SweepParams> s("sweep", "object",
                           "run the stage once per item, each from the same input state into OUTDIR/sweep_<stage>/<item>/, "
                           "results in OUTDIR/sweep_<stage>.csv and summary.json; the main state after the stage is the "
                           "state before it. Exactly one of snapshots_of, parameter (+ values), seeds");
  s.add("snapshots_of", &SweepParams::snapshots_of).doc("one item per snapshot of this earlier stage");
  s.add("parameter", &SweepParams::parameter)
      .doc("JSON pointer relative to the stage (e.g. /modules/gravity/acceleration/2) substituted by each of `values`");
  s.add("keep_item_states", &SweepParams::keep_item_states)
      .doc("keep each completed item's final_state.h5 (a full checkpoint); false removes it as the item completes: its "
           "frames keep the fields (potentials, currents), and a restart needs only the table and the sweep's checkpoint");
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
  s.add("scan", &Calibration::scan)
      .doc("increasing positive values of the parameter run first (the map); the target must lie between two of them");
  s.add("tolerance", &Calibration::tolerance).unit("1").positive().doc("relative tolerance on `column`");
  s.add("max_iterations", &Calibration::max_iterations).min(1).doc("search items after the scan");
  return s;
}

json sweep_schema() {
  json j = spec_to_json(sweep_spec().spec());
  j["params"].push_back(
      {{"name", "values"}, {"type", "array"}, {"doc", "parameter: one item per value (any JSON value, validated in place)"}});
  j["params"].push_back(
      {{"name", "seeds"},
       {"type", "array of integers"},
       {"minimum", 0},
       {"doc", "one item per seed of the random generator (an ensemble; the table gets mean, sample std and count per column)"}});
  j["params"].push_back({{"name", "collect"},
                         {"type", "array of strings"},
                         {"doc", "table columns: final time-series columns and `packing.<key>` report values (default: all)"}});
  return j;
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
  } catch (const json::exception&) { return "\"" + text + "\" is not a JSON pointer" + example; }
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
  while (!rest.empty()) {
    tokens.insert(tokens.begin(), rest.back());
    rest.pop_back();
  }
  for (const auto& t : tokens) {
    walked += "/" + t;
    if (node->is_object() && node->contains(t))
      node = &(*node)[t];
    else if (node->is_array() && array_index(t, node->size()))
      node = &(*node)[std::stoull(t)];
    else
      return "\"" + text + "\": the stage has no " + walked + " (the parameter's parent must be written in the stage)";
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
  bool snapshots = false;            ///< it takes snapshots
  std::set<std::string> wall_names;  ///< its walls (those of its snapshots)
};

/// Largest number of items of one sweep: each item is a whole run that keeps its state, and 1e5
/// items took over 10 s just to bind (found by the loader fuzzing).
constexpr std::size_t kMaxSweepItems = 10000;

/// Parses a stage's "sweep" (the stage JSON `js` has one) into `sw`.
void parse_sweep(const json& js, const std::string& path, const std::vector<EarlierStage>& earlier, SweepDef& sw,
                 std::vector<Diagnostic>& errors, json& resolved) {
  const std::string sp = path + "/sweep";
  const json& j = js["sweep"];
  json r;
  const SweepParams p = build(sweep_spec(), j, sp, errors, r, {"values", "seeds", "collect", "calibrate"});
  if (!j.is_object()) return;
  sw.keep_item_states = p.keep_item_states;
  if (j.contains("calibrate")) {
    json rc;
    const Calibration c = build(calibrate_spec(), j["calibrate"], sp + "/calibrate", errors, rc, {});
    if (!j.contains("snapshots_of"))
      errors.push_back({sp + "/calibrate", "calibrate goes with snapshots_of (it calibrates on one snapshot)"});
    for (const char* k : {"parameter", "column", "target", "scan"})
      if (j["calibrate"].is_object() && !j["calibrate"].contains(k)) errors.push_back({sp + "/calibrate/" + k, "required"});
    bool increasing = c.scan.size() >= 2;
    for (std::size_t q = 0; q < c.scan.size(); ++q)
      if (!(c.scan[q] > 0.0) || (q > 0 && !(c.scan[q] > c.scan[q - 1]))) increasing = false;
    if (j["calibrate"].is_object() && j["calibrate"].contains("scan") && !increasing)
      errors.push_back(
          {sp + "/calibrate/scan", "expected at least two positive, increasing values, found " + describe(j["calibrate"]["scan"])});
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
      errors.push_back({sp + "/snapshots_of", exists ? "stage \"" + p.snapshots_of + "\" takes no snapshots (give it \"snapshots\")"
                                                     : "no earlier stage named \"" + p.snapshots_of + "\" takes snapshots" +
                                                           suggest(p.snapshots_of, with) +
                                                           (with.empty() ? std::string("; no earlier stage takes any")
                                                                         : "; stages with snapshots: " + list_names(with))});
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
      errors.push_back({sp + "/seeds", "expected at most " + std::to_string(kMaxSweepItems) + " seeds, found " + std::to_string(x.size()) +
                                           " (split the sweep into several scenarios)"});
    } else {
      for (std::size_t q = 0; q < x.size(); ++q) {
        const bool ok = x[q].is_number_unsigned() || (x[q].is_number_integer() && x[q].get<std::int64_t>() >= 0);
        if (!ok) {
          errors.push_back({sp + "/seeds/" + std::to_string(q), "expected a non-negative integer seed, found " + describe(x[q])});
          continue;
        }
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
StageDef build_sweep_stage(StageContext& ctx, const json& js, const std::string& path, const std::vector<EarlierStage>& earlier,
                           std::vector<Diagnostic>& errors, json& r) {
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
    try {
      absent = !sw->stage_json.contains(ptr);
    } catch (const json::exception&) { absent = true; }
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
      if (i == 0) {
        st = std::move(sti);
        r = ri;
        columns = c.columns;
      }
    }
    std::set<std::pair<std::string, std::string>> reported;
    for (std::size_t i = 0; i < sw->values.size(); ++i) {
      const std::string vpath = path + "/sweep/values/" + std::to_string(i);
      const std::string what = "value " + sw->values[i].dump() + " for " + sw->parameter + ": ";
      for (const auto& d : per_item[i]) {
        const bool here = d.path == target || d.path.rfind(target + "/", 0) == 0;
        const bool no_key = d.message.rfind("unknown key", 0) == 0 || d.message.find("\" is no longer a key of") != std::string::npos;
        if (here && absent && d.path == target && no_key) {
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
    errors.push_back({path + "/sweep/collect", std::to_string(more_unknown.size()) +
                                                   " more entries are not time-series columns of "
                                                   "this stage (indices " +
                                                   list_names(more_unknown) + ")"});
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
    throw ConfigError("", "cannot read the scenario file '" + file.string() +
                              "': " + (std::filesystem::exists(file, ec) ? "not a regular file" : "no such file"));
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
void expand_includes(json& j, const std::filesystem::path& dir, const std::string& path, int depth, std::vector<Diagnostic>& errors) {
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
    if (!j["checks"].is_array())
      errors.push_back({"/checks", "expected an array of checks, found " + describe(j["checks"])});
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
          errors.push_back(
              {cp + "/stage",
               "expected a stage that steps (a check with a tolerance band needs the stage's final "
               "values), found \"" +
                   c.stage + "\", " +
                   (stage->sweep ? "a sweep stage (its items' values are in its sweep table)" : "a generator stage without dynamics") +
                   "; use tolerance 0 (report only)"});
        sc.checks.push_back(c);
        sc.resolved["checks"].push_back(r);
      }
  }
}

/// The top-level "particle_sets" {name: selector}; each resolved into resolved_top.
static std::map<std::string, SetSelector> parse_particle_sets(const json& j, std::vector<Diagnostic>& errors, json& resolved_top) {
  std::map<std::string, SetSelector> sets;
  if (j.contains("particle_sets")) {
    if (!j["particle_sets"].is_object())
      errors.push_back({"/particle_sets", "expected an object {name: selector}, found " + describe(j["particle_sets"])});
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
                                                (it.value().is_object() && it.value().contains("radius") ? it.value()["radius"].dump()
                                                                                                         : std::string("nothing"))});
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
  return sets;
}

/// The "stages": each bound in order (build_stage, or build_sweep_stage for a sweep), the context
/// (walls, particles) carried from one to the next; stage names that name files must be unique.
static void parse_stages(const json& j, const Registry& reg, const std::filesystem::path& base_dir,
                         const std::map<std::string, SetSelector>& sets, const std::set<std::string>& wall_names, Scenario& sc,
                         std::vector<Diagnostic>& errors) {
  sc.resolved["stages"] = json::array();
  if (!j.contains("stages") || !j["stages"].is_array() || j["stages"].empty()) {
    errors.push_back({"/stages", "expected a non-empty array of stages, found " +
                                     (j.contains("stages") ? describe(j["stages"]) : std::string("nothing"))});
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
          errors.push_back({"/stages/" + std::to_string(k) + "/name",
                            "a stage with snapshots or a sweep needs a unique name (it names "
                            "its files); stage " +
                                std::to_string(q) + " is also \"" + sc.stages[k].cfg.name + "\""});
          break;
        }
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
  const TopParams top = build(top_spec(), j, "", errors, resolved_top,
                              {"materials", "contact", "bonds", "walls", "stages", "particle_sets", "checks"});
  const std::map<std::string, SetSelector> sets = parse_particle_sets(j, errors, resolved_top);
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
  if (!j.contains("contact"))
    errors.push_back({"/contact", "missing required key \"contact\" ({\"law\": name, \"params\": {...}}); registered laws: " +
                                      list_names(names_of(reg.laws()))});
  else {
    json r;
    sc.law = make_law(j["contact"], reg, "/contact", errors, r);
    sc.resolved["contact"] = r;
  }
  // Bond law (optional): {"law", "params", "contact_rule": "exclude"|"add"}
  if (j.contains("bonds")) {
    json r;
    sc.bond_law = make_named(j["bonds"], reg.bond_laws(), "bond law", "/bonds", errors, r, {"contact_rule"});
    if (j["bonds"].is_object() && j["bonds"].contains("contact_rule")) {
      const json& cr = j["bonds"]["contact_rule"];
      if (cr == "add")
        sc.bond_contact_rule = BondTable::ContactRule::Add;
      else if (cr != "exclude")
        errors.push_back(
            {"/bonds/contact_rule",
             "expected \"exclude\" (bonded pairs get no contact force, default) or \"add\" (bond and contact forces add up), found " +
                 describe(cr)});
    }
    r["contact_rule"] = sc.bond_contact_rule == BondTable::ContactRule::Add ? "add" : "exclude";
    sc.resolved["bonds"] = r;
  }
  // Walls
  std::set<std::string> wall_names;
  sc.resolved["walls"] = json::array();
  if (j.contains("walls")) {
    if (!j["walls"].is_array())
      errors.push_back({"/walls", "expected an array of walls, found " + describe(j["walls"])});
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
  parse_stages(j, reg, base_dir, sets, wall_names, sc, errors);
  load_checks(j, sc, errors);
  if (!errors.empty()) throw ConfigError(errors);
  return sc;
}

json schema_json(const Registry& reg) {
  json j;
  j["scenario"] = spec_to_json(top_spec().spec());
  j["material"] = spec_to_json(material_spec().spec());
  j["wall"] = spec_to_json(wall_schema());
  j["motion"] = spec_to_json(motion_schema());
  j["stage"] = stage_schema(reg);
  j["stage"]["keys"]["sweep"] = sweep_schema();
  j["particle_set"] = spec_to_json(set_spec().spec());
  j["check"] = spec_to_json(check_spec().spec());
  for (const auto& [k, v] : reg.laws()) j["contact_laws"][k] = spec_to_json(v.spec);
  for (const auto& [k, v] : reg.bond_laws()) j["bond_laws"][k] = spec_to_json(v.spec);
  for (const auto& [k, v] : reg.modules()) j["modules"][k] = spec_to_json(v.spec);
  for (const auto& [k, v] : reg.monitors()) j["monitors"][k] = spec_to_json(v.spec);
  j["module_clock"] = spec_to_json(clock_schema());
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
