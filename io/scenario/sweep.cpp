#include "io/scenario/sweep.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <numeric>
#include <optional>
#include <set>

#include "engine/core/error.hpp"
#include "io/hdf5/results_writer.hpp"
#include "io/restart/checkpoint_file.hpp"
#include "io/restart/hdf5_archive.hpp"
#include "io/mpi/ranks.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/sweep_items.hpp"

namespace sparkdem::io {

namespace fs = std::filesystem;

namespace {

json number_or_null(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }
json columns_json(const std::map<std::string, double>& columns) {
  json j = json::object();
  for (const auto& [name, v] : columns) j[name] = number_or_null(v);
  return j;
}
double number_of(const json& j) { return j.is_number() ? j.get<double>() : std::nan(""); }

/// `file` relative to `dir` when it lies inside it, else as it is.
std::string shown(const fs::path& file, const fs::path& dir) {
  const fs::path rel = fs::path(file).lexically_normal().lexically_relative(fs::absolute(dir).lexically_normal());
  if (!rel.empty() && *rel.begin() != "..") return rel.generic_string();
  return file.string();
}

void write_text_atomic(const fs::path& file, const std::string& text) {
  const auto tmp = file.string() + ".tmp";
  {
    std::ofstream out(tmp);
    if (!out) throw SetupError("cannot write '" + tmp + "'");
    out << text;
    if (!out) throw SetupError("cannot write '" + tmp + "'");
  }
  fs::rename(tmp, file);
}

/// A state file (checkpoint format, no module or pipeline data).
void write_state(const fs::path& file, State& s) {
  Hdf5Archive ar = Hdf5Archive::for_writing(file);
  s.visit(ar);
  ar.commit();
}

/// A checkpoint inside a sweep stage at its input state, recording the sweep's progress in the
/// pipeline record (the format of the pipeline's checkpoints, without module data).
void write_progress_checkpoint(const fs::path& file, State& s, const json& record) {
  keep_previous_checkpoint(file);  // the newest two are kept
  Hdf5Archive ar = Hdf5Archive::for_writing(file);
  s.visit(ar);
  std::int64_t in_stage = 1;
  ar.visit("pipeline/in_stage", in_stage);
  std::string r = record.dump();
  ar.visit("pipeline/record", r);
  ar.commit();
}

/// One CSV cell: integers as such, other numbers with 17 significant digits (they read back
/// exactly), null as nan, anything else as its JSON text, quoted when it holds a comma or quote.
std::string cell(const json& v) {
  if (v.is_null()) return "nan";
  if (v.is_number_integer() || v.is_number_unsigned()) return v.dump();
  if (v.is_number_float()) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v.get<double>());
    return buf;
  }
  std::string t = v.is_string() ? v.get<std::string>() : v.dump();
  if (t.find_first_of(",\"\n") == std::string::npos) return t;
  std::string q = "\"";
  for (char c : t) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

/// The columns of a row that identify its item, per sweep kind.
std::vector<std::string> key_columns(const SweepDef& sw) {
  if (sw.calibrate) return {"phase", "value", "snapshot", "snapshot_step", "snapshot_time", "snapshot_value"};
  switch (sw.kind) {
    case SweepDef::Kind::Parameter:
      return {"value"};
    case SweepDef::Kind::Seeds:
      return {"seed"};
    case SweepDef::Kind::Snapshots:
      return {"snapshot", "snapshot_step", "snapshot_time", "snapshot_value"};
  }
  return {};
}

const char* kind_name(SweepDef::Kind kind) {
  switch (kind) {
    case SweepDef::Kind::Parameter:
      return "parameter";
    case SweepDef::Kind::Seeds:
      return "seeds";
    case SweepDef::Kind::Snapshots:
      return "snapshots";
  }
  return "?";
}

/// Table columns: `collect`, or every value name of the rows in first-seen order.
std::vector<std::string> table_columns(const SweepDef& sw, const json& rows) {
  if (!sw.collect.empty()) return sw.collect;
  std::vector<std::string> cols;
  std::set<std::string> seen;
  for (const auto& r : rows)
    if (r.contains("values"))
      for (auto it = r["values"].begin(); it != r["values"].end(); ++it)
        if (seen.insert(it.key()).second) cols.push_back(it.key());
  return cols;
}

std::string table_csv(const SweepDef& sw, const json& rows, const std::vector<std::string>& cols) {
  std::string out = "item";
  auto add = [&out](const std::string& c) {
    out += ',';
    out += c;
  };
  const auto keys = key_columns(sw);
  for (const auto& k : keys) add(k);
  add("status");
  for (const auto& c : cols) add(cell(json(c)));
  out += '\n';
  for (const auto& r : rows) {
    out += cell(r["item"]);
    for (const auto& k : keys) add(cell(r.value(k, json(nullptr))));
    add(cell(r["status"]));
    const json values = r.value("values", json::object());
    for (const auto& c : cols) add(cell(values.value(c, json(nullptr))));
    out += '\n';
  }
  return out;
}

/// Rows as shown in the table and summary: their files relative to `outdir` when inside it (the
/// rows themselves keep absolute paths: after a restart into another directory, the items run
/// before it are in the first one).
json shown_rows(const json& rows, const fs::path& outdir) {
  json out = rows;
  for (auto& r : out)
    for (const char* k : {"snapshot", "directory"})
      if (r.contains(k) && r[k].is_string()) r[k] = shown(r[k].get<std::string>(), outdir);
  return out;
}

/// Every final value of a stage's summary entry: time-series columns by name, generator report
/// values as packing.<key>.
json values_of(const json& entry) {
  json v = json::object();
  if (entry.contains("final"))
    for (auto it = entry["final"].begin(); it != entry["final"].end(); ++it) v[it.key()] = it.value();
  if (entry.contains("packing"))
    for (auto it = entry["packing"].begin(); it != entry["packing"].end(); ++it)
      if (it.value().is_number() || it.value().is_null()) v["packing." + it.key()] = it.value();
  return v;
}

/// The calibration's state from the rows so far: the evaluated (value, column) points on the
/// calibration snapshot, and the calibrated value once one is within tolerance.
struct CalibrationState {
  std::vector<std::pair<double, double>> points;  ///< sorted by value
  double found = std::nan("");
  double achieved = std::nan("");
  std::size_t searches = 0;
};

CalibrationState calibration_state(const SweepDef::Calibration& c, const json& rows) {
  CalibrationState st;
  for (const auto& r : rows) {
    const std::string phase = r.value("phase", "");
    if (phase == "search") ++st.searches;
    if ((phase != "scan" && phase != "search") || r.value("status", "") != "completed") continue;
    const double v = number_of(r.value("value", json(nullptr)));
    const double y = number_of(r.value("values", json::object()).value(c.column, json(nullptr)));
    if (!std::isfinite(v) || !(y > 0.0)) continue;
    st.points.emplace_back(v, y);
    if (std::abs(y / c.target - 1.0) <= c.tolerance &&
        (!std::isfinite(st.found) || std::abs(y / c.target - 1.0) < std::abs(st.achieved / c.target - 1.0))) {
      st.found = v;
      st.achieved = y;
    }
  }
  std::sort(st.points.begin(), st.points.end());
  return st;
}

/// Next search value: the secant of f = ln(column / target) against ln(value) across the
/// tightest sign change among the evaluated points, kept in the middle 80 % of that bracket
/// (in ln value) so the bracket shrinks by at least 10 % per item.
double next_search_value(const SweepDef::Calibration& c, const CalibrationState& st, const std::string& stage) {
  for (std::size_t q = 0; q + 1 < st.points.size(); ++q) {
    const double fa = std::log(st.points[q].second / c.target), fb = std::log(st.points[q + 1].second / c.target);
    if ((fa < 0.0) == (fb < 0.0)) continue;
    const double a = std::log(st.points[q].first), b = std::log(st.points[q + 1].first);
    double x = a - fa * (b - a) / (fb - fa);
    x = std::clamp(x, a + 0.1 * (b - a), b - 0.1 * (b - a));
    return std::exp(x);
  }
  std::string seen;
  for (const auto& [v, y] : st.points) seen += (seen.empty() ? "" : ", ") + std::to_string(v) + " -> " + std::to_string(y);
  throw SetupError("stage '" + stage + "': the calibration target " + c.column + " = " + std::to_string(c.target) +
                   " is not bracketed by the scan (" + (seen.empty() ? std::string("no completed item") : seen) + "); widen calibrate/scan");
}

}  // namespace

// ---------------------------------------------------------------------------------- RunRecord
json RunRecord::to_json() const {
  json j;
  j["snapshots"] = json::array();
  for (const auto& r : snapshots)
    j["snapshots"].push_back({{"stage_index", r.stage_index},
                              {"stage", r.stage},
                              {"index", r.index},
                              {"column", r.column},
                              {"target", number_or_null(r.target)},
                              {"value", number_or_null(r.value)},
                              {"step", r.step},
                              {"time", r.time},
                              {"file", r.file},
                              {"columns", columns_json(r.columns)}});
  j["first_values"] = json::object();
  for (const auto& [k, v] : first_values) j["first_values"][std::to_string(k)] = number_or_null(v);
  j["sweep"] = sweep;
  if (!sweep_outputs.is_null()) j["sweep_outputs"] = sweep_outputs;
  return j;
}

RunRecord RunRecord::from_json(const json& j) {
  RunRecord r;
  try {
    for (const auto& x : j.at("snapshots")) {
      SnapshotRecord s;
      s.stage_index = x.at("stage_index").get<std::int64_t>();
      s.stage = x.at("stage").get<std::string>();
      s.index = x.at("index").get<std::int64_t>();
      s.column = x.at("column").get<std::string>();
      s.target = number_of(x.at("target"));
      s.value = number_of(x.at("value"));
      s.step = x.at("step").get<Step>();
      s.time = x.at("time").get<double>();
      s.file = x.at("file").get<std::string>();
      if (x.contains("columns"))  // absent in records written before issue 36
        for (auto it = x.at("columns").begin(); it != x.at("columns").end(); ++it) s.columns[it.key()] = number_of(it.value());
      r.snapshots.push_back(std::move(s));
    }
    for (auto it = j.at("first_values").begin(); it != j.at("first_values").end(); ++it)
      r.first_values[std::stoll(it.key())] = number_of(it.value());
    r.sweep = j.at("sweep");
    if (j.contains("sweep_outputs")) r.sweep_outputs = j.at("sweep_outputs");
  } catch (const std::exception& e) { throw SetupError(std::string("the checkpoint's pipeline record is malformed: ") + e.what()); }
  return r;
}

std::vector<SnapshotRecord> RunRecord::of_stage(std::int64_t stage_index) const {
  std::vector<SnapshotRecord> out;
  for (const auto& r : snapshots)
    if (r.stage_index == stage_index) out.push_back(r);
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.index < b.index; });
  return out;
}

void RunRecord::forget_stage(std::int64_t stage_index) {
  std::erase_if(snapshots, [&](const SnapshotRecord& r) { return r.stage_index == stage_index; });
  first_values.erase(stage_index);
}

std::string file_name_of(const std::string& stage) {
  std::string out = stage.empty() ? "stage" : stage;
  for (char& c : out)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.')) c = '_';
  if (out == "." || out == "..") out = "stage";
  return out;
}

// --------------------------------------------------------------------------- SnapshotObserver
Step SnapshotObserver::watch_every() const {
  return std::gcd(inner_.watch_every(), spec_.every_steps > 0 ? spec_.every_steps : spec_.check_every);
}

bool SnapshotObserver::taken(std::int64_t index) const {
  return std::any_of(record_.snapshots.begin(), record_.snapshots.end(),
                     [&](const SnapshotRecord& r) { return r.stage_index == stage_index_ && r.index == index; });
}

void SnapshotObserver::take(State& s, std::int64_t index, double target, double value, const std::vector<std::string>& cols,
                            const std::vector<double>& vals) {
  // outdir_ is the run's physical output directory (resolve_output_directory): no lexical
  // normalisation here, which would take "LINK/.." to LINK's parent instead of its target's.
  const fs::path file = fs::absolute(outdir_ / "snapshots" / (file_name_of(stage_) + "_" + std::to_string(index) + ".h5"));
  std::error_code ec;
  fs::create_directories(file.parent_path(), ec);
  if (ec) throw SetupError("snapshot directory '" + file.parent_path().string() + "': cannot create it: " + ec.message());
  std::map<std::string, double> columns;
  for (std::size_t k = 0; k < cols.size() && k < vals.size(); ++k) columns[cols[k]] = vals[k];
  record_.snapshots.push_back({stage_index_, stage_, index, spec_.column, target, value, s.step, s.time, file.string(), std::move(columns)});
  save_(file, s);
}

void SnapshotObserver::watch(State& s, const std::vector<std::string>& cols, const std::vector<double>& vals) {
  inner_.watch(s, cols, vals);
  const auto it = std::find(cols.begin(), cols.end(), spec_.column);
  if (it == cols.end()) {
    std::string list;
    for (const auto& c : cols) list += (list.empty() ? "" : ", ") + c;
    throw SetupError("stage '" + stage_ + "': the snapshot column '" + spec_.column + "' is not a time-series column of this stage (" +
                     list + ")");
  }
  const double v = vals[static_cast<std::size_t>(it - cols.begin())];
  if (spec_.every_steps > 0) {
    const Step k = s.step - s.stage_step0;
    if (k > 0 && k % spec_.every_steps == 0 && !taken(k / spec_.every_steps - 1))
      take(s, k / spec_.every_steps - 1, std::nan(""), v, cols, vals);
    return;
  }
  auto first = record_.first_values.find(stage_index_);
  if (first == record_.first_values.end()) {
    if (!std::isfinite(v)) return;
    first = record_.first_values.emplace(stage_index_, v).first;
  }
  const double v0 = first->second;
  for (std::size_t k = 0; k < spec_.at.size(); ++k) {
    const auto index = static_cast<std::int64_t>(k);
    if (taken(index)) continue;
    const double a = spec_.at[k];
    if (v0 <= a ? v >= a : v <= a) take(s, index, a, v, cols, vals);
  }
}

json snapshots_summary(const RunRecord& record, std::int64_t stage_index, const SnapshotSpec& spec, const fs::path& outdir) {
  json j;
  j["column"] = spec.column;
  if (spec.every_steps > 0) j["every_steps"] = spec.every_steps;
  j["taken"] = json::array();
  std::set<std::int64_t> have;
  for (const auto& r : record.of_stage(stage_index)) {
    have.insert(r.index);
    json x = {{"index", r.index},
              {"value", number_or_null(r.value)},
              {"step", r.step},
              {"time", r.time},
              {"file", shown(r.file, outdir)},
              {"columns", columns_json(r.columns)}};
    if (std::isfinite(r.target)) x["target"] = r.target;
    j["taken"].push_back(x);
  }
  if (!spec.at.empty()) {
    j["not_reached"] = json::array();
    for (std::size_t k = 0; k < spec.at.size(); ++k)
      if (!have.count(static_cast<std::int64_t>(k))) j["not_reached"].push_back(spec.at[k]);
  }
  return j;
}

json column_statistics(const json& rows, const std::vector<std::string>& columns) {
  json out = json::object();
  for (const auto& c : columns) {
    std::vector<double> x;
    for (const auto& r : rows) {
      if (r.value("status", "") != "completed" || !r.contains("values")) continue;
      const double v = number_of(r["values"].value(c, json(nullptr)));
      if (std::isfinite(v)) x.push_back(v);
    }
    double sum = 0.0;
    for (double v : x) sum += v;
    const double n = static_cast<double>(x.size());
    const double mean = x.empty() ? std::nan("") : sum / n;
    double ss = 0.0;
    for (double v : x) ss += (v - mean) * (v - mean);
    out[c] = {{"count", x.size()},
              {"mean", number_or_null(mean)},
              {"std", x.size() >= 2 ? number_or_null(std::sqrt(ss / (n - 1.0))) : json(nullptr)}};
  }
  return out;
}

// ------------------------------------------------------------------------------------ items
namespace sweep_detail {

std::optional<Item> plan_item(const SweepContext& ctx, std::size_t j, const std::map<std::size_t, json>& rows_by_item) {
  const SweepDef& sw = *ctx.sw;
  if (!sw.calibrate) {
    if (j >= ctx.n) return std::nullopt;
    return Item{j, std::nan(""), ""};
  }
  const auto& c = *sw.calibrate;
  const std::string& stage = ctx.stage_name;
  if (ctx.cal_pos < 0)
    throw SetupError("stage '" + stage + "': calibrate/snapshot " + std::to_string(c.snapshot) + " was not taken (" +
                     std::to_string(ctx.n) + " snapshots taken)");
  const auto ks = static_cast<std::size_t>(ctx.cal_pos);
  if (j < c.scan.size()) return Item{ks, c.scan[j], "scan"};
  const json rows = rows_before(rows_by_item, j);
  const CalibrationState st = calibration_state(c, rows);
  if (!std::isfinite(st.found)) {
    if (st.searches >= static_cast<std::size_t>(c.max_iterations))
      throw SetupError("stage '" + stage + "': the calibration did not reach " + c.column + " within " + std::to_string(c.tolerance) +
                       " of the target in " + std::to_string(c.max_iterations) + " search items");
    return Item{ks, next_search_value(c, st, stage), "search"};
  }
  std::size_t validated = 0;
  for (const auto& r : rows) validated += r.value("phase", "") == "validate";
  if (validated >= ctx.n) return std::nullopt;
  return Item{validated, st.found, "validate"};
}

json ItemJob::to_json() const {
  return {{"stage", stage},
          {"stage_index", stage_index},
          {"j", j},
          {"index", item.index},
          {"value", number_or_null(item.value)},
          {"phase", item.phase},
          {"input_state", input_state},
          {"snapshot", snapshot},
          {"directory", directory},
          {"quiet", quiet}};
}

ItemJob ItemJob::from_json(const json& x) {
  ItemJob job;
  job.stage = x.at("stage").get<std::size_t>();
  job.stage_index = x.at("stage_index").get<std::int64_t>();
  job.j = x.at("j").get<std::size_t>();
  job.item = Item{x.at("index").get<std::size_t>(), number_of(x.at("value")), x.at("phase").get<std::string>()};
  job.input_state = x.at("input_state").get<std::string>();
  job.snapshot = x.at("snapshot");
  job.directory = x.at("directory").get<std::string>();
  job.quiet = x.value("quiet", true);
  return job;
}

ItemJob job_of(const SweepContext& ctx, std::size_t j, const Item& item) {
  ItemJob job;
  job.stage = ctx.stage;
  job.stage_index = ctx.stage_index;
  job.j = j;
  job.item = item;
  job.input_state = ctx.input_file;
  if (ctx.sw->kind == SweepDef::Kind::Snapshots) {
    const SnapshotRecord& r = ctx.snaps.at(item.index);
    job.snapshot = {{"file", r.file}, {"index", r.index}, {"step", r.step}, {"time", r.time}, {"value", number_or_null(r.value)}};
  }
  job.directory = fs::absolute(ctx.dir / std::to_string(j)).string();  // ctx.dir: physical (see sweep_context)
  job.quiet = ctx.quiet;
  return job;
}

namespace {

/// The one-stage scenario of an item and the keys of its row (before its results).
Scenario item_scenario(const Scenario& sc, const ItemJob& job, json& row) {
  const SweepDef& sw = *sc.stages.at(job.stage).sweep;
  const std::size_t i = job.item.index;
  json resolved_stage;
  Scenario sub;
  sub.stages.push_back(sw.build(sw.calibrate ? sw.calibration_json(job.item.value) : sw.item_json(i), resolved_stage));
  sub.name = sc.name;
  sub.seed = sc.seed;
  sub.materials = sc.materials;
  sub.law = sc.law;
  sub.bond_law = sc.bond_law;
  sub.bond_contact_rule = sc.bond_contact_rule;
  sub.walls = sc.walls;
  sub.resolved = sc.resolved;
  sub.resolved["stages"] = json::array({resolved_stage});
  row["item"] = job.j;
  if (sw.calibrate) {
    row["phase"] = job.item.phase;
    row["value"] = job.item.value;
  }
  switch (sw.kind) {
    case SweepDef::Kind::Parameter:
      row["value"] = sw.values.at(i);
      break;
    case SweepDef::Kind::Seeds:
      row["seed"] = sw.seeds.at(i);
      break;
    case SweepDef::Kind::Snapshots:
      row["snapshot"] = job.snapshot.at("file");
      row["snapshot_index"] = job.snapshot.at("index");
      row["snapshot_step"] = job.snapshot.at("step");
      row["snapshot_time"] = job.snapshot.at("time");
      row["snapshot_value"] = job.snapshot.at("value");
      break;
  }
  row["directory"] = job.directory;
  sub.resolved["sweep_item"] = row;
  return sub;
}

/// The item's start state: its snapshot (with the input's materials and random generator), or
/// the input state (reseeded for a seed ensemble).
State item_start(const Scenario& sc, const ItemJob& job, const State& input) {
  const SweepDef& sw = *sc.stages.at(job.stage).sweep;
  State start;
  if (sw.kind == SweepDef::Kind::Snapshots) {
    read_checkpoint(job.snapshot.at("file").get<std::string>(), start);
    start.materials = sc.materials;
    start.rng = input.rng;
  } else {
    start = input;
    if (sw.kind == SweepDef::Kind::Seeds) start.rng.seed(sw.seeds.at(job.item.index));
  }
  return start;
}

}  // namespace

ItemResult run_item(Scenario& sc, const ItemJob& job, const State& input, RunOptions o) {
  const SweepDef& sw = *sc.stages.at(job.stage).sweep;
  ItemResult res;
  json& row = res.row;
  Scenario sub = item_scenario(sc, job, row);
  State start;
  if (!o.restart) start = item_start(sc, job, input);
  o.outdir = job.directory;
  o.quiet = job.quiet;
  o.start = o.restart ? nullptr : &start;
  o.stage_offset = job.stage_index;
  try {
    const json summary = run_scenario(sub, o);
    const json& e = summary["stages"].at(0);
    row["status"] = "completed";
    row["steps"] = e.value("steps", std::int64_t{0});
    if (e.contains("until_reached")) row["until_reached"] = e["until_reached"];
    const json all = values_of(e);
    if (sw.collect.empty()) {
      row["values"] = all;
    } else {
      row["values"] = json::object();
      for (const auto& c : sw.collect) {
        row["values"][c] = all.value(c, json(nullptr));
        if (!all.contains(c)) row["missing"].push_back(c);
      }
    }
    res.steps = summary.value("steps", Step{0});
    if (!sw.keep_item_states) remove_if_present(fs::path(job.directory) / "final_state.h5");
    res.particle_steps = static_cast<double>(row["steps"].get<std::int64_t>()) * e.value("particles", 0.0);
  } catch (const PhysicsError& e) {
    row["status"] = "failed";
    row["error"] = e.what();
  }
  return res;
}

json rows_in_order(const std::map<std::size_t, json>& rows) {
  json out = json::array();
  for (const auto& [j, r] : rows) out.push_back(r);
  return out;
}

json rows_before(const std::map<std::size_t, json>& rows, std::size_t j) {
  json out = json::array();
  for (const auto& [q, r] : rows)
    if (q < j) out.push_back(r);
  return out;
}

/// sweep_<stage>/results.xdmf: the last frame of every completed item, in row order, one
/// ParaView time step per item (listed at the row's place in the table, 0, 1, 2, ...; each
/// grid's Information holds the frame's own time, step and stage), pointing into the items'
/// frame files (<item>/frames/...).
void write_sweep_xdmf(const SweepContext& ctx, const json& rows) {
  std::vector<FrameInfo> frames;
  std::vector<double> listed;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const json& r = rows[k];
    if (r.value("status", std::string()) != "completed" || !r.contains("directory")) continue;
    const fs::path dir = r["directory"].get<std::string>();
    std::error_code ec;
    std::string last;
    for (const auto& e : fs::directory_iterator(dir / "frames", ec)) {
      const std::string name = e.path().filename().string();
      if (name.size() > 3 && name.substr(name.size() - 3) == ".h5" && name > last) last = name;
    }
    if (last.empty()) continue;  // an item of a restart into another directory: its frames stayed behind
    frames.push_back(read_frame_info(ctx.dir, (fs::relative(dir, ctx.dir) / "frames" / last).generic_string()));
    listed.push_back(static_cast<double>(k));
  }
  write_text_atomic(ctx.dir / "results.xdmf", xdmf_of_frames(frames, listed));
}

void write_table(const SweepContext& ctx, const json& rows) {
  write_text_atomic(ctx.table, table_csv(*ctx.sw, shown_rows(rows, ctx.outdir), table_columns(*ctx.sw, rows)));
  // The XDMF is a viewer's index over the items' frames, rewritten with every table (also on the
  // way out of a failed or interrupted sweep): an item frame it cannot read must not replace that
  // error, nor stop a sweep whose rows are safe; the next table write tries again.
  try {
    write_sweep_xdmf(ctx, rows);
  } catch (const std::exception&) {}
}

}  // namespace sweep_detail

// ------------------------------------------------------------------------------------ sweeps
namespace {

using namespace sweep_detail;

/// The sweep's context: the input state (the state before the stage, moved out of the main state
/// s for the sweep and given back by run_sweep; kept in a file for a restart; on a restart read
/// back from it), its items, and the rows a restart carries over.
SweepContext sweep_context(Scenario& sc, std::size_t k, State& s, const RunRecord& record, bool resuming, const RunOptions& opt) {
  SweepContext ctx;
  const StageDef& st = sc.stages[k];
  ctx.stage = k;
  ctx.sw = st.sweep.get();
  ctx.stage_name = st.cfg.name;
  ctx.stage_index = opt.stage_offset + static_cast<std::int64_t>(k);
  ctx.quiet = opt.quiet;
  const std::string name = file_name_of(st.cfg.name);
  // opt.outdir is the run's physical output directory (run_scenario resolves it): every path of
  // the sweep is built on it as is. (A lexical normalisation of "LINK/../out" gave "out" beside
  // LINK while the directories were made in LINK's target's parent: issue 34 item 5.)
  ctx.outdir = opt.outdir;
  ctx.dir = opt.outdir / ("sweep_" + name);
  ctx.table = opt.outdir / ("sweep_" + name + ".csv");
  ctx.checkpoint = opt.checkpoint_file.empty() ? opt.outdir / "checkpoint.h5" : opt.checkpoint_file;
  std::error_code ec;
  fs::create_directories(ctx.dir, ec);
  if (ec) throw SetupError("sweep directory '" + ctx.dir.string() + "': cannot create it: " + ec.message());
  ctx.input_file = fs::absolute(ctx.dir / "input_state.h5").string();
  if (resuming) {
    const json& p = record.sweep;
    if (!p.is_object() || p.value("stage", std::int64_t{-1}) != ctx.stage_index || !p.contains("rows"))
      throw SetupError("the checkpoint lies inside sweep stage '" + st.cfg.name + "' but records no progress of it");
    for (const auto& r : p["rows"]) ctx.done[r.at("item").get<std::size_t>()] = r;
    // A one-rank checkpoint lies inside item "item"; a checkpoint of a run on several ranks
    // records finished rows only (its state is the input state).
    if (p.contains("item") && p["item"].is_number()) ctx.resume_item = p["item"].get<std::size_t>();
    ctx.input_file = p.value("input_state", ctx.input_file);
    read_checkpoint(ctx.input_file, ctx.input);
    ctx.input.materials = sc.materials;
  } else {
    ctx.input = std::move(s);  // a branch: the main state waits in ctx.input (run_sweep gives it back)
    try {
      write_state(ctx.input_file, ctx.input);
    } catch (...) {
      s = std::move(ctx.input);
      throw;
    }
  }
  const SweepDef& sw = *ctx.sw;
  if (sw.kind == SweepDef::Kind::Parameter) ctx.n = sw.values.size();
  if (sw.kind == SweepDef::Kind::Seeds) ctx.n = sw.seeds.size();
  if (sw.kind == SweepDef::Kind::Snapshots) {
    ctx.snaps = record.of_stage(sw.snapshots_stage);
    ctx.n = ctx.snaps.size();
  }
  if (sw.calibrate)
    for (std::size_t q = 0; q < ctx.snaps.size(); ++q)
      if (ctx.snaps[q].index == sw.calibrate->snapshot) ctx.cal_pos = static_cast<std::int64_t>(q);
  return ctx;
}

/// One rank: a checkpoint at the stage's input state recording the finished rows (as on several
/// ranks), so that a kill between items loses no finished item. A snapshot sweep's input state
/// waits in its file (run_sweep), from which it is read for this.
void write_rows_checkpoint(const SweepContext& ctx, RunRecord& record, const std::map<std::size_t, json>& rows) {
  State input;
  if (ctx.sw->kind == SweepDef::Kind::Snapshots)
    read_checkpoint(ctx.input_file, input);
  else
    input = ctx.input;
  input.stage_index = ctx.stage_index;
  record.sweep = {{"stage", ctx.stage_index}, {"item", nullptr}, {"rows", rows_in_order(rows)}, {"input_state", ctx.input_file}};
  write_progress_checkpoint(ctx.checkpoint, input, record.to_json());
}

/// One rank: the items in order, each a nested run whose checkpoints go to the main checkpoint
/// file with the sweep's progress in the pipeline record (a restart resumes inside the item).
/// Rows finished before a restart are kept, not rerun. After an item, when the stage's
/// output.checkpoint_every_s passed since the sweep started or its last such checkpoint, a
/// checkpoint records the finished rows (write_rows_checkpoint).
std::map<std::size_t, ItemResult> run_items_in_order(Scenario& sc, const SweepContext& ctx, RunRecord& record, const RunOptions& opt) {
  std::map<std::size_t, ItemResult> ran;
  std::map<std::size_t, json> rows = ctx.done;
  const double every = sc.stages[ctx.stage].cfg.checkpoint_every_s;
  auto last = std::chrono::steady_clock::now();
  for (std::size_t j = 0;; ++j) {
    std::optional<Item> item;
    try {
      item = plan_item(ctx, j, rows);
    } catch (...) {
      write_table(ctx, rows_in_order(rows));
      throw;
    }
    if (!item) break;
    if (rows.count(j)) continue;  // finished before the restart
    RunOptions o;
    o.checkpoint_file = ctx.checkpoint;
    if (ctx.resume_item == j) {
      o.restart = opt.restart;
      o.in_place = opt.in_place;
    }
    record.sweep = {{"stage", ctx.stage_index}, {"item", j}, {"rows", rows_in_order(rows)}, {"input_state", ctx.input_file}};
    o.record = [&record] { return record.to_json(); };
    try {
      ItemResult r = run_item(sc, job_of(ctx, j, *item), ctx.input, o);
      rows[j] = r.row;
      ran[j] = std::move(r);
    } catch (...) {
      write_table(ctx, rows_in_order(rows));
      throw;
    }
    write_table(ctx, rows_in_order(rows));
    if (every > 0.0 && std::chrono::duration<double>(std::chrono::steady_clock::now() - last).count() >= every) {
      write_rows_checkpoint(ctx, record, rows);
      last = std::chrono::steady_clock::now();
    }
  }
  return ran;
}

/// Several ranks: the items spread over them (sweep_ranks.cpp). After every finished item the
/// table and a checkpoint at the stage's input state recording the finished rows are written;
/// a restart (on any number of ranks) reruns only the items not finished.
std::map<std::size_t, ItemResult> run_items_spread(Scenario& sc, const SweepContext& ctx, RunRecord& record) {
  State progress_state = ctx.input;
  progress_state.stage_index = ctx.stage_index;
  auto progress = [&](const std::map<std::size_t, json>& rows) {
    const json ordered = rows_in_order(rows);
    write_table(ctx, ordered);
    record.sweep = {{"stage", ctx.stage_index}, {"item", nullptr}, {"rows", ordered}, {"input_state", ctx.input_file}};
    write_progress_checkpoint(ctx.checkpoint, progress_state, record.to_json());
  };
  return run_items_over_ranks(sc, ctx, progress);
}

/// The stage's summary entry from its rows.
json sweep_entry(const SweepContext& ctx, const StageDef& st, const json& rows) {
  const SweepDef& sw = *ctx.sw;
  const auto cols = table_columns(sw, rows);
  json e;
  e["name"] = st.cfg.name;
  e["type"] = st.type;
  json& x = e["sweep"];
  x["kind"] = kind_name(sw.kind);
  if (sw.kind == SweepDef::Kind::Parameter) x["parameter"] = sw.parameter;
  if (sw.kind == SweepDef::Kind::Snapshots) x["snapshots_of"] = sw.snapshots_of;
  if (sw.calibrate) {
    const auto& c = *sw.calibrate;
    const CalibrationState cs = calibration_state(c, rows);
    json& cj = x["calibration"];
    cj = {{"parameter", c.parameter},
          {"column", c.column},
          {"snapshot", c.snapshot},
          {"target", c.target},
          {"tolerance", c.tolerance},
          {"value", number_or_null(cs.found)},
          {"achieved", number_or_null(cs.achieved)},
          {"search_items", cs.searches}};
    cj["map"] = json::array();
    for (const auto& [v, y] : cs.points) cj["map"].push_back({v, y});
  }
  x["table"] = ctx.table.filename().string();
  x["directory"] = ctx.dir.filename().string();
  x["input_state"] = shown(ctx.input_file, ctx.outdir);
  x["items"] = rows.size();
  x["failed"] = std::count_if(rows.begin(), rows.end(), [](const json& r) { return r.value("status", "") != "completed"; });
  x["columns"] = cols;
  x["rows"] = shown_rows(rows, ctx.outdir);
  if (sw.kind == SweepDef::Kind::Seeds) x["statistics"] = column_statistics(rows, cols);
  std::int64_t item_steps = 0;
  for (const auto& r : rows) item_steps += r.value("steps", std::int64_t{0});
  e["steps"] = item_steps;  // of every item, also those run before a restart
  return e;
}

}  // namespace

SweepOutcome run_sweep(Scenario& sc, std::size_t k, State& s, RunRecord& record, bool resuming, const RunOptions& opt) {
  const auto t0 = std::chrono::steady_clock::now();
  SweepContext ctx = sweep_context(sc, k, s, record, resuming, opt);
  // The items of a snapshot sweep start from their snapshots and take only the input's random
  // generator: on one rank the input state waits in its file (written by sweep_context) while
  // they run, not in memory beside theirs, and is read back after them as a restart reads it.
  const bool parked = ranks::size() == 1 && ctx.sw->kind == SweepDef::Kind::Snapshots;
  if (parked) {
    State rng_only;
    rng_only.rng = ctx.input.rng;
    ctx.input = std::move(rng_only);
  }
  const auto unpark = [&] {
    if (!parked) return;
    read_checkpoint(ctx.input_file, ctx.input);
    ctx.input.materials = sc.materials;
  };
  std::map<std::size_t, ItemResult> ran;
  try {
    ran = ranks::size() > 1 ? run_items_spread(sc, ctx, record) : run_items_in_order(sc, ctx, record, opt);
  } catch (...) {
    try {
      unpark();
    } catch (...) {  // the item's failure is the one to report
    }
    s = std::move(ctx.input);  // the run's summary reports the state before the sweep
    throw;
  }
  unpark();
  record.sweep = nullptr;
  std::map<std::size_t, json> rows = ctx.done;
  SweepOutcome out;
  for (const auto& [j, r] : ran) {
    rows[j] = r.row;
    out.steps += r.steps;
    out.particle_steps += r.particle_steps;
  }
  const json ordered = rows_in_order(rows);
  write_table(ctx, ordered);
  out.entry = sweep_entry(ctx, sc.stages[k], ordered);
  out.entry["wall_time_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  s = std::move(ctx.input);  // a sweep is a branch: the main state goes on from the state before it
  s.stage_index = ctx.stage_index;
  return out;
}

}  // namespace sparkdem::io
