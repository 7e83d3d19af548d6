#include <limits>
#include "io/scenario/pipeline.hpp"

#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <set>

#include "engine/core/error.hpp"
#include "engine/core/memory.hpp"
#include "engine/core/memory_archive.hpp"
#include "engine/state/affine_map.hpp"
#include "engine/state/delete_particles.hpp"
#include "engine/state/pair_transfer.hpp"
#include "engine/state/particle_set.hpp"
#include "io/files/durable_file.hpp"
#include "io/hdf5/results_writer.hpp"
#include "io/restart/checkpoint_file.hpp"
#include "io/restart/hdf5_archive.hpp"
#include "io/scenario/sweep.hpp"
#include "io/version/build_info.hpp"

namespace sparkdem::io {

namespace {

using steady = std::chrono::steady_clock;

json finite_or_null(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }

/// Compact text of a number (9 significant digits), for log lines.
std::string short_number(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.9g", x);
  return buffer;
}

/// Appends a line to the run log on an error path: a failing log must not hide the error.
void note(RunLog& log, const std::string& text) noexcept {
  try {
    log.line(text);
  } catch (...) {}
}

/// A frame's particle fields: the kinematics, radius, id, material and every output field. The
/// particles' double columns are viewed, not copied (FrameField::view; the frame is written
/// before the state changes): 3.15 MB less at the main scenario's frames (issue 63 item 3).
std::vector<FrameField> frame_particles(const ParticleStore& p) {
  static_assert(sizeof(Vec3) == 3 * sizeof(double), "a Vec3 column is viewed as 3 doubles per particle");
  std::vector<FrameField> f;
  auto view = [&](const char* name, int components, std::span<const double> v, const char* unit) {
    FrameField x{name, components, {}, unit};
    x.view = v;
    f.push_back(std::move(x));
  };
  auto vec3 = [&](const char* name, const std::vector<Vec3>& v, const char* unit) {
    view(name, 3, std::span<const double>(v.empty() ? nullptr : v.front().data(), 3 * v.size()), unit);
  };
  vec3("position", p.position, "m");
  vec3("velocity", p.velocity, "m/s");
  vec3("omega", p.omega, "rad/s");
  vec3("force", p.force, "N");
  view("radius", 1, p.radius, "m");
  f.push_back({"id", 1, std::vector<double>(p.id.begin(), p.id.end()), "1"});
  f.push_back({"material", 1, std::vector<double>(p.material.begin(), p.material.end()), "1"});
  for (const auto& name : p.fields.names()) {
    const auto& info = p.fields.info(name);
    // Field names may hold '/' (e.g. "set/top"); a frame dataset name may not.
    std::string out = name;
    std::replace(out.begin(), out.end(), '/', '_');
    if (info.output) view(out.c_str(), info.components, p.fields.data(name), info.unit.c_str());
  }
  return f;
}

/// A frame's contacts: the rows that touch or carry a force (a sintered neck in tension), with
/// their overlap, force on i and, under a sintering law, neck radius. The pairs are gathered now,
/// the columns when the writer comes to each (FrameField::make): a frame of the main scenario's
/// 79,000 contacts held 4.4 MB of gathered columns at once. `t` must outlive the frame's writing.
ContactFrame frame_contacts(const ContactTable& t) {
  ContactFrame c;
  const int neck_column = t.column("neck_radius");
  const auto force = [&t](std::size_t r) { return r < t.force().size() ? t.force()[r] : Vec3::Zero(); };  // none before a force pass
  auto rows = std::make_shared<std::vector<std::size_t>>();
  for (std::size_t r = 0; r < t.size(); ++r)
    if (t.overlap()[r] > 0.0 || force(r) != Vec3::Zero()) rows->push_back(r);
  c.pairs.reserve(2 * rows->size());
  for (const std::size_t r : *rows) {
    c.pairs.push_back(t.id_i()[r]);
    c.pairs.push_back(t.id_j()[r]);
  }
  const auto column = [&](const char* name, int components, const char* unit, auto value) {
    FrameField f{name, components, {}, unit};
    f.rows = rows->size();
    f.make = [rows, components, value] {
      std::vector<double> v;
      v.reserve(rows->size() * static_cast<std::size_t>(components));
      for (const std::size_t r : *rows)
        for (int d = 0; d < components; ++d) v.push_back(value(r, d));
      return v;
    };
    c.fields.push_back(std::move(f));
  };
  column("overlap", 1, "m", [&t](std::size_t r, int) { return t.overlap()[r]; });
  column("force", 3, "N", [force](std::size_t r, int d) { return force(r)[d]; });
  if (neck_column >= 0) column("neck_radius", 1, "m", [&t, neck_column](std::size_t r, int) { return t.state(r)[neck_column]; });
  return c;
}

/// A frame's bonds, every row: broken (1) or intact (0), the step it broke at (-1: intact), the
/// force on i (zero once broken).
ContactFrame frame_bonds(const State& s) {
  const BondTable& b = s.bonds;
  ContactFrame c;
  FrameField broken{"broken", 1, {}, "1"}, step{"broken_step", 1, {}, "1"}, fn{"force", 3, {}, "N"};
  for (std::size_t r = 0; r < b.size(); ++r) {
    c.pairs.push_back(b.id_i()[r]);
    c.pairs.push_back(b.id_j()[r]);
    broken.data.push_back(b.broken(r) ? 1.0 : 0.0);
    step.data.push_back(b.broken(r) ? static_cast<double>(b.broken_step(r)) : -1.0);
    const Vec3 f = b.broken(r) || r >= b.force().size() ? Vec3::Zero() : b.force()[r];
    for (int d = 0; d < 3; ++d) fn.data.push_back(f[d]);
  }
  c.fields.push_back(std::move(broken));
  c.fields.push_back(std::move(step));
  c.fields.push_back(std::move(fn));
  return c;
}

std::vector<EdgeOutput*> pointers_to(std::vector<EdgeOutput>& v) {
  std::vector<EdgeOutput*> p;
  for (EdgeOutput& e : v) p.push_back(&e);
  return p;
}

/// Modules' held edge outputs whose arrays a frame's networks hold: handed back (moved) when it
/// goes out of scope, whether the frame was written or not.
class LentEdges {
 public:
  explicit LentEdges(std::vector<std::pair<std::string, ContactFrame>>& networks) : networks_(networks) {}
  LentEdges(const LentEdges&) = delete;
  LentEdges& operator=(const LentEdges&) = delete;
  /// `to` lent its arrays to network `index` (whose fields are in the order of to->fields).
  void add(EdgeOutput* to, std::size_t index) { lent_.push_back({to, index}); }
  ~LentEdges() {
    for (auto& [to, index] : lent_) {
      ContactFrame& frame = networks_[index].second;
      to->pairs = std::move(frame.pairs);
      for (std::size_t k = 0; k < to->fields.size() && k < frame.fields.size(); ++k) to->fields[k].values = std::move(frame.fields[k].data);
    }
  }

 private:
  std::vector<std::pair<std::string, ContactFrame>>& networks_;
  std::vector<std::pair<EdgeOutput*, std::size_t>> lent_;
};

json start_entries(const StageResult& r);

/// The I/O side of a run: frames, time series, checkpoints, progress, the run log.
class OutputObserver final : public Observer {
 public:
  /// `kept`: a continuation in place, what the folder held at the restart point (the
  /// "outputs" of its pipeline record, see outputs()); null: a fresh start of the folder's results.
  OutputObserver(const std::filesystem::path& outdir, bool quiet, RunLog& log, const json& kept = json())
      : outdir_(outdir), log_(log), writer_(outdir, kept_results(kept)), quiet_(quiet) {
    tty_ = isatty(fileno(stderr));
    remove_healthy_files();  // a killed run's scratch copy (and its tmp file) is nobody's state any more
    // A kill between keep_previous_checkpoint's link and its rename leaves the link's tmp name.
    std::error_code ec;
    std::filesystem::remove(tmp_name(previous_checkpoint_name(outdir_ / "checkpoint.h5")), ec);
    columns_ = writer_.columns();
    for (std::size_t c = 0; c < columns_.size(); ++c) col_index_[columns_[c]] = c;
    rows_ = writer_.rows();
  }
  /// What the folder's results hold now, for the pipeline record of every state file ("outputs"):
  /// frames, time-series columns and rows, the summary's stage entries so far (`stages`) and the
  /// opening part of the running stage's entry. A continuation in place keeps exactly these.
  json outputs() const {
    json o = {{"frames", writer_.frames()}, {"columns", columns_.size()}, {"rows", rows_.size()}};
    o["stages"] = stages_ ? *stages_ : json::array();
    if (!stage_entry_.is_null()) o["stage_entry"] = stage_entry_;
    if (!start_entries_.is_null()) o["stage_start"] = start_entries_;
    return o;
  }
  /// The summary's stage entries (outputs()); the running stage's opening entry (null: none).
  void set_summary_stages(const json* stages) { stages_ = stages; }
  void set_stage_entry(json entry) {
    stage_entry_ = std::move(entry);
    start_entries_ = json();
  }
  /// The running stage's start entries (start_entries): measured by its start, or on a resume
  /// those the restart point kept (set_stage_start), which the resumed start does not replace.
  void stage_started(const StageResult& r) override {
    if (start_entries_.is_null()) start_entries_ = start_entries(r);
  }
  void set_stage_start(json start) { start_entries_ = std::move(start); }
  const json& stage_start() const { return start_entries_; }
  ~OutputObserver() override { drop_healthy_file(); }
  OutputObserver(const OutputObserver&) = delete;
  OutputObserver& operator=(const OutputObserver&) = delete;
  /// Sweeps: checkpoints go to this file, and every state file carries this pipeline record.
  void set_checkpoint_file(const std::filesystem::path& f) { checkpoint_file_ = f; }
  void set_record(std::function<json()> record) { record_ = std::move(record); }
  void set_stage(const std::string& name, std::vector<Module*> modules, const StageConfig& cfg) {
    stage_ = name;
    modules_ = std::move(modules);
    cfg_ = cfg;
    stage_start_ = steady::now();
    last_print_ = stage_start_;
    last_frame_step_.reset();
  }
  /// A stage resumed in place at `step`: a kept frame of this stage at that step is not written
  /// again (a checkpoint taken at the stage's last step follows that step's periodic frame, and
  /// the stage's closing frame would repeat it).
  void resumed_at(Step step) {
    const FrameInfo* last = writer_.last_frame();
    if (last && last->stage == stage_ && last->step == step) last_frame_step_ = step;
  }
  void frame(const State& s) override {
    // A stage reports its last step twice when it is also a frame_every step (the periodic frame
    // and the closing frame), and a stage of no steps its start twice: the same state, written once.
    if (last_frame_step_ == s.step) return;
    last_frame_step_ = s.step;
    FrameContent fc{s.step, s.time, stage_, frame_particles(s.particles), frame_contacts(s.contacts), std::nullopt, {}, false, false};
    if (s.bonds.size() > 0) fc.bonds = frame_bonds(s);
    // A module's held edge output is lent to the frame (its arrays moved in, and moved back by
    // `lent` once the frame is written, or fails), not copied; other modules' are copies.
    LentEdges lent(fc.networks);
    for (Module* m : modules_) {
      EdgeOutput* held = m->held_edges();
      if (held && held->name.empty()) continue;  // nothing held yet: edge_outputs() is empty too
      std::vector<EdgeOutput> copies;
      if (!held) copies = m->edge_outputs();
      for (EdgeOutput* eo : held ? std::vector<EdgeOutput*>{held} : pointers_to(copies)) {
        ContactFrame n;
        n.pairs = std::move(eo->pairs);
        for (EdgeField& ef : eo->fields) n.fields.push_back({ef.name, 1, std::move(ef.values), ef.unit});
        fc.networks.emplace_back(eo->name, std::move(n));
        if (held) lent.add(held, fc.networks.size() - 1);
      }
    }
    const std::string& mode = cfg_.network_output;
    const bool automatic = mode == "auto" && (!fc.networks.empty() || fc.bonds);
    fc.contact_lines = automatic || mode == "contacts" || mode == "both";
    fc.bond_lines = automatic || mode == "bonds" || mode == "both";
    const int index = writer_.frames();
    const std::string file = writer_.write_frame(fc);
    dirty_ = true;
    // Only now, with the frame file complete on disk, is the frame reported.
    char counter[16];
    std::snprintf(counter, sizeof counter, "%06d", index);
    log_.line(std::string("frame ") + counter + " written: " + file + " (step " + std::to_string(s.step) + ", t = " + short_number(s.time) +
              " s, stage '" + stage_ + "')");
  }
  void event(const std::string& text) override { log_.line(text); }
  void timeseries(const std::vector<std::string>& cols, const std::vector<double>& vals) override {
    std::vector<double> row(columns_.size(), std::nan(""));
    for (std::size_t k = 0; k < cols.size(); ++k) {
      auto it = col_index_.find(cols[k]);
      if (it == col_index_.end()) {
        it = col_index_.emplace(cols[k], columns_.size()).first;
        columns_.push_back(cols[k]);
        row.push_back(std::nan(""));
      }
      row[it->second] = vals[k];
    }
    rows_.push_back(std::move(row));
    dirty_ = true;
  }
  bool checkpoint_due() override {
    return cfg_.checkpoint_every_s > 0.0 && std::chrono::duration<double>(steady::now() - last_checkpoint_).count() >= cfg_.checkpoint_every_s;
  }
  void checkpoint(State& s) override {
    const std::filesystem::path file = checkpoint_file_.empty() ? outdir_ / "checkpoint.h5" : checkpoint_file_;
    publish();  // first: the index then holds at least what the checkpoint records (outputs())
    keep_previous_checkpoint(file);  // the newest two are kept
    write_checkpoint(file, s, true);
    log_.line("checkpoint written: " + (checkpoint_file_.empty() ? std::string("checkpoint.h5") : file.string()) + " (step " +
              std::to_string(s.step) + ", stage '" + stage_ + "')");
    // The wall-clock interval counts from the end of the last checkpoint of any kind: a run
    // computes for at least checkpoint_every_s between two, however long writing one takes.
    last_checkpoint_ = steady::now();
  }
  /// The watchdog passed: keep a copy of what a checkpoint of this state would hold, in memory
  /// when a checkpoint would store it in at most watchdog.snapshot_memory_max_bytes, else as the
  /// scratch file OUTDIR/.healthy_state.h5 (unsealed and not synced: the reader refuses it until
  /// write_last_healthy seals it). A file's fixed cost (about a millisecond to create, write and
  /// close an HDF5 file) would dominate a small copy; a large copy in memory would double the state.
  void healthy(State& s) override {
    ByteCountArchive size;
    write_state(size, s, true);
    if (static_cast<std::int64_t>(size.bytes()) <= cfg_.watchdog.snapshot_memory_max_bytes) {
      drop_healthy_file();
      healthy_.begin();
      write_state(healthy_, s, true);
      healthy_.end();
      healthy_step_ = s.step;
      return;
    }
    healthy_.clear();
    if (!healthy_in_file_)
      note(log_, "stage '" + stage_ + "': copies of the last healthy state go to " + healthy_file().filename().string() + " (" +
                std::to_string(size.bytes()) + " bytes, above watchdog.snapshot_memory_max_bytes)");
    try {
      Hdf5Archive ar = Hdf5Archive::for_writing(healthy_file());
      write_state(ar, s, true);
      ar.commit_unsealed();  // replaces the previous copy at once
      healthy_in_file_ = true;
      healthy_step_ = s.step;
    } catch (const SetupError& e) {
      // A safety copy that cannot be written (disk full) must not stop a healthy run: the run
      // goes on without one, and a failure then leaves no checkpoint_before_failure.h5.
      remove_healthy_files();  // whatever is left of the previous copy
      healthy_in_file_ = false;
      healthy_step_ = -1;
      note(log_, std::string("copy of the last healthy state not written: ") + e.what());
    }
  }
  /// After a failure: writes the last healthy copy as the sealed checkpoint
  /// OUTDIR/checkpoint_before_failure.h5 (loadable with --restart); returns its path, or an empty
  /// path when there is no copy of the failing stage.
  std::filesystem::path write_last_healthy() {
    if (healthy_.empty() && !healthy_in_file_) return {};
    const std::filesystem::path file = outdir_ / "checkpoint_before_failure.h5";
    if (healthy_in_file_) {
      seal_checkpoint(healthy_file());
      rename_durably(healthy_file(), file);
      healthy_in_file_ = false;
    } else {
      Hdf5Archive ar = Hdf5Archive::for_writing(file);
      healthy_.replay(ar);
      ar.commit();
    }
    log_.line("checkpoint before failure written: checkpoint_before_failure.h5 (step " + std::to_string(healthy_step_) + ", stage '" +
              stage_ + "')");
    return file;
  }
  Step healthy_step() const { return healthy_step_; }
  /// The state after a stage: final_state.h5, then the index files. `committed` is called as
  /// soon as final_state.h5 is in place (before the log line and the index files, which may fail).
  void final_state(State& s, const std::function<void(const std::filesystem::path&)>& committed = {}) {
    healthy_.clear();  // a later failure is not this stage's
    drop_healthy_file();
    publish();  // first: the index then holds at least what the state file records (outputs())
    write_checkpoint(outdir_ / "final_state.h5", s, false);
    if (committed) committed(outdir_ / "final_state.h5");
    log_.line("final state written: final_state.h5 (step " + std::to_string(s.step) + ", after stage '" + stage_ + "')");
  }
  void write_checkpoint(const std::filesystem::path& file, State& s, bool in_stage) {
    Hdf5Archive ar = Hdf5Archive::for_writing(file);
    write_state(ar, s, in_stage);
    ar.commit();
  }
  /// Everything a checkpoint holds: the state, the modules' states, the pipeline record.
  void write_state(Archive& ar, State& s, bool in_stage) {
    // The watchdog's kinetic-energy samples (marks "watchdog/...", engine/watchdog.hpp) stay out
    // of every file, so the state files of a run are those of a run without the watchdog; a
    // restart samples afresh.
    std::map<std::string, double> held;
    for (auto it = s.marks.begin(); it != s.marks.end();) {
      if (it->first.rfind("watchdog/", 0) == 0) {
        held.insert(*it);
        it = s.marks.erase(it);
      } else {
        ++it;
      }
    }
    try {
      s.visit(ar);
    } catch (...) {
      s.marks.insert(held.begin(), held.end());
      throw;
    }
    s.marks.insert(held.begin(), held.end());
    std::int64_t flag = in_stage ? 1 : 0;
    ar.visit("pipeline/in_stage", flag);
    for (Module* m : modules_) m->visit(ar, "modules/" + m->name());
    if (record_) {
      json rec = record_();
      rec["outputs"] = outputs();
      std::string r = rec.dump();
      ar.visit("pipeline/record", r);
    }
  }
  void progress(const State& s, Step k, double t, double dt) override {
    if (quiet_) return;
    const auto now = steady::now();
    const double since = std::chrono::duration<double>(now - last_print_).count();
    if (since < (tty_ ? 0.25 : 10.0)) return;
    last_print_ = now;
    const double el = std::chrono::duration<double>(now - stage_start_).count();
    const double rate = el > 0 ? static_cast<double>(k - k0_) / el : 0.0;
    double remaining = std::nan("");
    if (std::isfinite(cfg_.duration)) remaining = (cfg_.duration - t) / dt;
    if (cfg_.max_steps < std::numeric_limits<Step>::max())
      remaining = std::min(std::isnan(remaining) ? 1e300 : remaining, static_cast<double>(cfg_.max_steps - k));
    const auto cols = builtin_columns(s);
    const auto vals = builtin_values(s);
    auto value = [&](const char* name) {
      for (std::size_t q = 0; q < cols.size(); ++q)
        if (cols[q] == name) return vals[q];
      return std::nan("");
    };
    char buf[320];
    std::snprintf(buf, sizeof buf, "[%s] step %lld  t = %.4g s  KE/m = %.3g J/kg  max overlap %.3g  %.3g steps/s  ETA %s%s", stage_.c_str(),
                  static_cast<long long>(s.step), s.time, value("kinetic_energy_per_mass"), value("max_overlap_ratio"), rate,
                  std::isnan(remaining) || rate <= 0 ? "? (until-condition)"
                                                     : (std::to_string(static_cast<long long>(remaining / rate)) + " s").c_str(),
                  cfg_.until.empty() ? "" : " (or earlier)");
    if (tty_)
      std::cerr << "\r" << buf << "\033[K" << std::flush;
    else
      std::cerr << buf << "\n";
  }
  void steps_planned(double dt, double stable, const std::vector<ModuleStep>& modules) override {
    if (quiet_) return;
    char buf[400];
    std::snprintf(buf, sizeof buf, "[%s] mechanical step %.4g s (stable %.4g s)%s\n", stage_.c_str(), dt, stable,
                  cfg_.mechanics ? "" : ", mechanics frozen");
    std::cerr << buf;
    for (const auto& m : modules) {
      std::snprintf(buf, sizeof buf, "[%s]   %-22s stable step %.4g s, runs with %.4g s, %s (%.4g calls per step)\n", stage_.c_str(),
                    m.name.c_str(), m.stable_dt, m.dt, m.clock.c_str(), m.calls_per_step);
      std::cerr << buf;
    }
  }
  void end_stage_line() {
    if (tty_ && !quiet_) std::cerr << "\n";
  }
  void set_k0(Step k0) { k0_ = k0; }
  /// Rewrites results.h5, results.xdmf and timeseries.csv with everything so far.
  void publish() {
    set_timeseries();
    writer_.write_index();
    dirty_ = false;
    log_index();
  }
  /// The last publish(), unless nothing changed since the previous one.
  void finalize() {
    if (dirty_) set_timeseries();
    if (writer_.finalize()) log_index();
  }

 private:
  void set_timeseries() {
    std::vector<std::vector<double>> rows = rows_;  // a column that appeared later is NaN in the rows before it
    for (auto& r : rows) r.resize(columns_.size(), std::nan(""));
    writer_.set_timeseries(columns_, rows);
  }
  void log_index() {
    log_.line("index written: results.h5, results.xdmf, timeseries.csv (" + std::to_string(writer_.frames()) + " frames, " +
              std::to_string(rows_.size()) + " time-series rows)");
  }

  std::filesystem::path outdir_;
  RunLog& log_;
  ResultsWriter writer_;
  bool quiet_, tty_ = false;
  std::string stage_;
  std::optional<Step> last_frame_step_;  ///< step of the last frame written in the current stage
  std::vector<Module*> modules_;
  StageConfig cfg_;
  std::vector<std::string> columns_;
  std::map<std::string, std::size_t> col_index_;
  /// Time-series rows, one value per column of columns_ known when the row was added (a row of
  /// a map from column name to value held ~90 bytes a value: 1.6 MB for the main scenario's 450 rows).
  std::vector<std::vector<double>> rows_;
  bool dirty_ = true;  ///< frames or time-series rows not yet in the index files
  steady::time_point stage_start_, last_print_;
  steady::time_point last_checkpoint_ = steady::now();  ///< the run's start, then its last checkpoint (checkpoint_every_s)
  Step k0_ = 0;
  std::filesystem::path checkpoint_file_;
  std::function<json()> record_;
  std::filesystem::path healthy_file() const { return outdir_ / ".healthy_state.h5"; }
  void remove_healthy_files() noexcept {
    std::error_code ec;
    std::filesystem::remove(healthy_file(), ec);
    std::filesystem::remove(tmp_name(healthy_file()), ec);
  }
  void drop_healthy_file() noexcept {
    if (!healthy_in_file_) return;
    remove_healthy_files();
    healthy_in_file_ = false;
  }
  /// The writer's continuation from the "outputs" of a restart point's record (none: null).
  static std::optional<ResultsWriter::Kept> kept_results(const json& kept) {
    if (!kept.is_object()) return std::nullopt;
    try {
      return ResultsWriter::Kept{kept.at("frames").get<int>(), kept.at("columns").get<std::size_t>(), kept.at("rows").get<std::size_t>()};
    } catch (const json::exception& e) { throw SetupError(std::string("the restart point's record of the folder's outputs is malformed: ") + e.what()); }
  }
  const json* stages_ = nullptr;
  json stage_entry_, start_entries_;
  MemoryArchive healthy_;          ///< the last state that passed the watchdog (see healthy()), when small
  bool healthy_in_file_ = false;   ///< the last healthy state is healthy_file() instead
  Step healthy_step_ = -1;
};

}  // namespace

json write_broken_bonds(const State& s, const BondModel& law, const std::filesystem::path& outdir) {
  const std::vector<std::string> modes = law.failure_modes();
  auto mode_name = [&](std::int64_t m) {
    if (m == kBreakModeHydrostatic) return std::string("hydrostatic");
    if (m == kBreakModeVirialVonMises) return std::string("virial_von_mises");
    return m >= 1 && static_cast<std::size_t>(m) <= modes.size() ? modes[static_cast<std::size_t>(m - 1)] : std::string("unknown");
  };
  std::vector<std::size_t> rows;
  for (std::size_t r = 0; r < s.bonds.size(); ++r)
    if (s.bonds.broken(r)) rows.push_back(r);
  std::stable_sort(rows.begin(), rows.end(), [&](std::size_t a, std::size_t b) { return s.bonds.broken_step(a) < s.bonds.broken_step(b); });
  std::string out = "step,time,id_i,id_j,x,y,z,mode\n";
  json counts = json::object();
  char buf[256];
  for (const std::size_t r : rows) {
    const BondBreakRecord& b = s.bonds.break_record(r);
    const std::string m = mode_name(b.mode);
    std::snprintf(buf, sizeof buf, "%lld,%.12g,%lld,%lld,%.12g,%.12g,%.12g,", static_cast<long long>(s.bonds.broken_step(r)), b.time,
                  static_cast<long long>(s.bonds.id_i()[r]), static_cast<long long>(s.bonds.id_j()[r]), b.position[0], b.position[1],
                  b.position[2]);
    out += buf + m + "\n";
    counts[m] = counts.value(m, 0) + 1;
  }
  write_file_atomic(outdir / "broken_bonds.csv", out);
  return counts;
}

void write_json_atomic(const std::filesystem::path& file, const json& j) { write_file_atomic(file, j.dump(2) + "\n"); }

namespace {}  // namespace

namespace {

constexpr const char* kDeletedMark = "stage_start/deleted/";

/// `delete_sets` of a stage: every set's selector is evaluated on the state at the stage start
/// and the union of the members is deleted (delete_particles). The counts go to the state's
/// marks (checkpointed), so that a stage resumed from a checkpoint reports them too; the marks
/// of an earlier stage are cleared at every stage start.
void delete_stage_sets(State& s, const std::vector<std::pair<std::string, SetSelector>>& sets) {
  std::erase_if(s.marks, [](const auto& kv) { return kv.first.rfind(kDeletedMark, 0) == 0; });
  if (sets.empty()) return;
  std::vector<bool> remove(s.particles.size(), false);
  for (const auto& [name, sel] : sets) {
    std::size_t n = 0;  // members not already taken by an earlier set of the list
    for (Index i : select_particles(s, sel))
      if (!remove[i]) {
        remove[i] = true;
        ++n;
      }
    std::string mark(kDeletedMark);  // appended in place: GCC 12's -Warray-bounds misreads string + "..." + name here
    mark.append("set/").append(name);
    s.marks[mark] = static_cast<double>(n);
  }
  const DeletionCounts c = delete_particles(s, remove);
  s.marks[std::string(kDeletedMark) + "total"] = static_cast<double>(c.particles);
  s.marks[std::string(kDeletedMark) + "contacts"] = static_cast<double>(c.contacts);
  s.marks[std::string(kDeletedMark) + "bonds"] = static_cast<double>(c.bonds);
}

json deletion_summary(const State& s, const std::vector<std::pair<std::string, SetSelector>>& sets) {
  auto mark = [&](const std::string& k) {
    const auto it = s.marks.find(kDeletedMark + k);
    return it == s.marks.end() ? json(nullptr) : json(static_cast<std::int64_t>(it->second));
  };
  json j;
  j["total"] = mark("total");
  for (const auto& [name, sel] : sets) j["sets"][name] = mark("set/" + name);
  j["contacts_removed"] = mark("contacts");
  j["bonds_removed"] = mark("bonds");
  return j;
}

}  // namespace

namespace {

/// Percent text of a relative figure ("+1.25 %").
std::string percent(double x, bool sign) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, sign ? "%+.4g %%" : "%.4g %%", 100.0 * x);
  return buffer;
}

/// One check against the summary's stages (the last stage of its name that ran in this process):
/// its entry of summary["checks"]; "failure" holds why a banded check failed.
json evaluate_check(const CheckDef& c, const json& stages) {
  json jc = {{"stage", c.stage}, {"column", c.column}, {"reference", c.reference}, {"offset", c.offset}, {"source", c.source}};
  if (c.tolerance > 0.0) jc["tolerance"] = c.tolerance;
  const json* stage = nullptr;
  for (const auto& js : stages)
    if (js.value("name", "") == c.stage) stage = &js;
  if (!stage || !stage->contains("final") || !(*stage)["final"].contains(c.column) || (*stage)["final"][c.column].is_null()) {
    jc["error"] = stage ? "the stage has no final value of this column" : "the stage did not run in this process";
    if (c.tolerance > 0.0) jc["failure"] = "not evaluated: " + jc["error"].get<std::string>();
    return jc;
  }
  const double v = (*stage)["final"][c.column].get<double>() - c.offset;
  const double err = (v - c.reference) / std::abs(c.reference);
  jc["value"] = v;
  jc["error_rel"] = finite_or_null(err);
  jc["stage_wall_time_s"] = stage->value("wall_time_s", 0.0);
  if (c.tolerance > 0.0) {
    const bool within = std::abs(err) <= c.tolerance;
    jc["within_tolerance"] = within;
    if (!within)
      jc["failure"] = "value " + short_number(v) + " against reference " + short_number(c.reference) + ": relative error " +
                      percent(err, true) + ", outside the band +-" + percent(c.tolerance, false) + " by " +
                      percent(std::abs(err) - c.tolerance, false) +
                      " of the reference (|value - reference| = " + short_number(std::abs(v - c.reference)) + ", the band allows " +
                      short_number(c.tolerance * std::abs(c.reference)) + ")";
  }
  return jc;
}

/// summary["checks"] (every check) and summary["checks_failed"] (the names of the banded checks,
/// tolerance > 0, that are outside their band or could not be evaluated), one log line each.
void evaluate_checks(const std::vector<CheckDef>& checks, json& summary, RunLog& log) {
  summary["checks_failed"] = json::array();
  for (const auto& c : checks) {
    const json jc = evaluate_check(c, summary["stages"]);
    if (jc.contains("value"))
      log.line("check '" + c.name + "': " + short_number(jc["value"].get<double>()) + " against " + short_number(c.reference) + " (" +
               percent(jc["error_rel"].is_null() ? std::nan("") : jc["error_rel"].get<double>(), true) + ")");
    if (jc.contains("failure")) {
      log.line("check '" + c.name + "' failed: " + jc["failure"].get<std::string>());
      summary["checks_failed"].push_back(c.name);
    }
    summary["checks"][c.name] = jc;
  }
}

/// Where a run starts: the first stage to run, whether it resumes inside that stage, and the
/// verified checkpoint image (kept until the resumed stage's modules have read their state).
struct RestartPoint {
  std::size_t first = 0;
  bool resume = false;
  std::unique_ptr<Hdf5Archive> archive;
  /// A continuation in place (RunOptions::in_place): what the folder held at the restart point
  /// (OutputObserver::outputs()); null otherwise, or when the file records none.
  json outputs;
};

/// The restart checkpoint of `opt` read into `s` and `record` (one verified read: the state and
/// the module states come from the same bytes); without one the run starts at stage 0.
RestartPoint read_restart(const Scenario& sc, const RunOptions& opt, State& s, RunRecord& record, RunLog& log) {
  RestartPoint rp;
  if (!opt.restart) return rp;
  rp.archive = std::make_unique<Hdf5Archive>(Hdf5Archive::for_reading(*opt.restart));
  auto [kc, in_stage] = read_state(*rp.archive, s);
  const std::int64_t k = kc - opt.stage_offset;
  if (k < 0 || k >= static_cast<std::int64_t>(sc.stages.size()))
    throw SetupError("checkpoint '" + opt.restart->string() + "' is at stage " + std::to_string(k) + ", but the scenario has " +
                     std::to_string(sc.stages.size()) + " stages");
  rp.first = static_cast<std::size_t>(in_stage ? k : k + 1);
  rp.resume = in_stage;
  if (rp.archive->has("pipeline/record")) {
    std::string r;
    rp.archive->visit("pipeline/record", r);
    const json j = json::parse(r, nullptr, false);
    if (!opt.record) record = RunRecord::from_json(j);
    // The folder's outputs at the restart point: a run's own (a checkpoint written inside a
    // sweep item records the item's folder as "outputs" and the run's as "sweep_outputs").
    if (opt.in_place && j.is_object()) {
      const json* own = !opt.record && j.contains("sweep_outputs") && !j["sweep_outputs"].is_null() ? &j["sweep_outputs"]
                                                                                                       : (j.contains("outputs") ? &j["outputs"] : nullptr);
      if (own) rp.outputs = *own;
    }
  }
  if (opt.in_place && rp.outputs.is_null())
    log.line("restart: checkpoint '" + opt.restart->string() + "' records no outputs of the folder: its results are started afresh");
  log.line("restart: checkpoint '" + opt.restart->string() + "' verified, step " + std::to_string(s.step) + ", stage " +
           std::to_string(kc) + (in_stage ? " (inside it)" : " (after it)"));
  return rp;
}

/// What preparing a stage made, for its summary entry.
struct StagePrep {
  bool generated = true;  ///< false: a dry run left out the stage's generator (see Generator::cheap_to_generate)
  std::size_t bonds_made = 0;
  double bond_gap = -1.0;  ///< [m] the gap bonds were created within (create_bonds)
  json set_counts;         ///< particles per named set
};

/// A stage's changes to the state before it runs; on a resume only the bond contact rule (the
/// rest is in the checkpoint): the snapshot it starts from, walls removed and added, the
/// generator, deleted sets, bonds created within the gap, the particle sets. A dry run
/// (`sparkdem check`) leaves out a generator that is not cheap to run (StagePrep::generated).
StagePrep prepare_stage(State& s, StageDef& st, const Scenario& sc, bool resuming, std::int64_t stage_index, bool dry_run = false) {
  StagePrep p;
  if (!resuming) {
    if (!st.from_snapshot.empty()) {
      State snap;
      read_checkpoint(st.from_snapshot, snap);
      snap.materials = s.materials;
      check_materials(snap, st.from_snapshot);
      snap.rng = s.rng;
      snap.step = s.step;
      snap.time = s.time;
      s = std::move(snap);
    }
    for (const auto& n : st.remove_walls) std::erase_if(s.walls, [&](const Wall& w) { return w.name == n; });
    for (std::size_t k = 0; k < st.add_walls.size(); ++k) {
      Wall w = st.add_walls[k];
      const double gap = k < st.add_wall_clearance.size() ? st.add_wall_clearance[k] : -1.0;
      if (gap >= 0.0) place_plane_at_clearance(w, s.particles.position, s.particles.radius, gap);
      s.walls.push_back(std::move(w));
    }
    if (st.affine_scale != Vec3::Ones()) {
      try {
        apply_affine_scale(s, st.affine_origin, st.affine_scale);
      } catch (const SetupError& e) {
        throw SetupError(st.path + "/affine: " + e.what());
      }
    }
    if (st.generator && (!dry_run || st.generator->cheap_to_generate()))
      st.generator->generate(s);
    else if (st.generator)
      p.generated = false;
    s.stage_index = stage_index;
    delete_stage_sets(s, st.delete_sets);
  }
  p.bond_gap = st.create_bonds_gap >= 0.0 && st.create_bonds_gap_relative ? st.create_bonds_gap * s.particles.mean_radius()
                                                                          : st.create_bonds_gap;
  if (!resuming && st.create_bonds_gap >= 0.0) {
    if (s.bonds.state_columns() != sc.bond_law->state_columns()) s.bonds.set_state_columns(sc.bond_law->state_columns());
    p.bonds_made = bond_within_gap(s, p.bond_gap);
  }
  s.bonds.contact_rule = sc.bond_contact_rule;
  if (!resuming) {
    for (const auto& [name, sel] : st.sets) p.set_counts[name] = assign_set(s, name, sel);
  }
  return p;
}

/// The summary entries a stage measures at its start (before step 0): the stable step then, the
/// step and its fraction of it, the module steps and the initial overlaps. A resumed stage cannot
/// measure them again: the restart point keeps them (OutputObserver::stage_started).
json start_entries(const StageResult& r) {
  json js;
  js["dt_s"] = r.dt;
  js["stable_dt_at_start_s"] = finite_or_null(r.stable_dt_at_start);
  js["dt_fraction_of_stable"] = finite_or_null(r.dt_fraction_used);
  const auto& o = r.initial_overlap;
  js["initial_overlap"] = {{"policy", o.policy},
                           {"limit", o.limit},
                           {"max_ratio", o.max_ratio},
                           {"pairs_over_limit", o.pairs_over_limit},
                           {"walls_over_limit", o.walls_over_limit},
                           {"worst_ids", {o.worst_i, o.worst_j}},
                           {"worst_wall", o.worst_wall},
                           {"relax_sweeps", o.sweeps},
                           {"max_ratio_after", o.max_ratio_after},
                           {"particles_moved", o.moved},
                           {"max_displacement_m", o.max_displacement}};
  js["module_steps"] = json::object();
  for (const auto& m : r.module_steps)
    js["module_steps"][m.name] = {
        {"stable_dt_s", finite_or_null(m.stable_dt)}, {"dt_s", m.dt}, {"calls_per_step", m.calls_per_step}, {"clock", m.clock}};
  if (r.module_steps.empty()) js.erase("module_steps");
  return js;
}

/// The summary entries of a stepping stage's result (steps, times, timers, step plan, final values).
/// `start`: on a resume, the start entries the restart point kept (null: those of `r`).
void describe_dynamics(json& js, const StageResult& r, const StageDef& st, bool resuming, const json& start = json()) {
  js["steps"] = r.steps;
  js["simulated_time_s"] = r.simulated_time;
  js["mechanical_time_s"] = r.simulated_time;
  js["physical_time_s"] = r.physical_time;
  js["time_scale"] = st.cfg.time_scale;
  for (const auto& [m, n] : r.module_calls) js["module_calls"][m] = n;
  for (const auto& [m, t] : r.module_seconds) js["module_wall_time_s"][m] = t;
  if (r.core_sampled_steps > 0) {
    // Estimated from the timed steps (one in kSplitEvery), scaled by the steps this run took.
    const double scale = static_cast<double>(r.steps_run) / static_cast<double>(r.core_sampled_steps);
    for (const auto& [item, t] : r.core_seconds) js["core_wall_time_s"][item] = t * scale;
    js["core_wall_time_sampled_steps"] = r.core_sampled_steps;
  }
  js["neighbor_rebuilds"] = r.neighbor_rebuilds;
  for (const auto& [m, n] : r.max_substeps)
    if (n > 1) js["max_substeps"][m] = n;
  js["wall_time_s"] = r.wall_seconds;
  // dt_s (the first step of an adaptive stage), the stable step, the initial overlaps and the
  // module steps, as measured at the stage start.
  json first = start.is_object() ? start : start_entries(r);
  if (resuming && !start.is_object()) first.erase("initial_overlap");  // not measured on resume
  for (const char* k : {"dt_s", "stable_dt_at_start_s", "dt_fraction_of_stable"}) js[k] = first[k];
  if (r.adaptive)  // dt_s is then the first step
    js["dt_adaptive"] = {{"fraction", st.cfg.adaptive.fraction}, {"min_s", r.adaptive->min},       {"median_s", r.adaptive->median},
                         {"max_s", r.adaptive->max},              {"changes", r.adaptive->changes}, {"overshoots", r.adaptive->overshoots},
                         {"checks", r.adaptive->checks},          {"check_wall_time_s", r.adaptive->check_seconds}};
  js["until_reached"] = r.until_reached;
  js["particles"] = r.particles;
  js["particle_steps_per_s"] = r.particle_steps_per_second;
  js["mass_scaling"] = st.cfg.mass_scaling;
  js["mass_floor_radius"] = st.cfg.mass_floor_radius;
  if (st.cfg.quasi_static) {
    const auto& q = r.quasi_static;
    js["quasi_static"] = {{"substeps", q.substeps},
                          {"rejected_substeps", q.rejected},
                          {"max_substeps_per_step", q.max_substeps},
                          {"linear_solves", q.rounds},
                          {"max_rounds_per_solve", q.max_rounds},
                          {"unsettled_solves", q.unsettled},
                          {"cg_iterations", q.cg_iterations},
                          {"factorisations", q.factorisations},
                          {"max_strain_increment", q.max_strain_increment},
                          {"max_mean_strain_increment", q.max_mean_strain_increment},
                          {"max_force_residual", q.max_residual},
                          {"last_force_residual", q.last_residual},
                          {"solve_wall_time_s", q.solve_seconds}};
  }
  if (first.contains("initial_overlap")) js["initial_overlap"] = first["initial_overlap"];
  js["step_plan"] = r.plan;
  js["mechanics"] = st.cfg.mechanics ? "on" : "frozen";
  if (first.contains("module_steps")) js["module_steps"] = first["module_steps"];
  for (const auto& [c, v] : r.final_values) js["final"][c] = finite_or_null(v);
}

/// summary["failure"] of a physics failure: where, what, the first 100 particle ids and the
/// checkpoint of the last healthy state when one was written.
json failure_entry(const PhysicsError& e) {
  const PhysicsErrorDetail& d = e.detail();
  json f = {{"step", e.step()},
            {"quantity", e.quantity()},
            {"reason", e.reason()},
            {"particles", e.ids().size()},
            {"time_s", finite_or_null(d.time)},
            {"value", finite_or_null(d.value)},
            {"bound", finite_or_null(d.bound)},
            {"hint", d.hint}};
  f["ids"] = std::vector<Id>(e.ids().begin(), e.ids().begin() + static_cast<std::ptrdiff_t>(std::min<std::size_t>(e.ids().size(), 100)));
  if (!d.checkpoint.empty()) f["checkpoint_before_failure"] = {{"file", "checkpoint_before_failure.h5"}, {"step", d.checkpoint_step}};
  return f;
}

/// The physics error with the checkpoint of the last state that passed the watchdog (a failure
/// to write it must not hide the physics error).
PhysicsError with_healthy_checkpoint(const PhysicsError& e, OutputObserver& obs, RunLog& log) {
  PhysicsErrorDetail d = e.detail();
  try {
    const std::filesystem::path f = obs.write_last_healthy();
    if (!f.empty()) {
      d.checkpoint = f.string();
      d.checkpoint_step = obs.healthy_step();
    }
  } catch (const std::exception& w) { note(log, std::string("checkpoint before failure not written: ") + w.what()); }
  return PhysicsError(e.step(), e.ids(), e.quantity(), e.reason(), d);
}

/// Counters a run adds up over its stages.
struct RunTotals {
  Step steps = 0;
  double particle_steps = 0.0;
};

/// Stage k (not a sweep) from preparation to its summary entry, its final state committed.
/// `rp` holds the checkpoint image while the stage resumes from it.
void run_plain_stage(Scenario& sc, std::size_t k, State& s, OutputObserver& obs, RunRecord& record, RestartPoint& rp, const RunOptions& opt,
                     RunLog& log, json& summary, RunTotals& totals, const std::function<void(const std::filesystem::path&)>& committed_ok,
                     const std::function<void(const std::filesystem::path&)>& committed_unmet) {
  StageDef& st = sc.stages[k];
  const bool resuming = rp.resume && k == rp.first;
  const auto ts = steady::now();
  const std::int64_t stage_index = opt.stage_offset + static_cast<std::int64_t>(k);
  const StagePrep prep = prepare_stage(s, st, sc, resuming, stage_index);
  const ContactModel& law = sc.law_of(st);
  Simulation sim(s, law, sc.bond_law.get());
  std::vector<Module*> mods;
  for (auto& m : st.modules) {
    sim.add_module(m.get());
    mods.push_back(m.get());
  }
  std::vector<std::unique_ptr<Monitor>> mons;
  if (st.generator) mons = st.generator->monitors();
  for (auto& m : mons) sim.add_monitor(m.get());
  for (const auto& m : st.monitors) sim.add_monitor(m.get());
  if (resuming) {
    for (Module* m : mods) m->visit(*rp.archive, "modules/" + m->name());
    rp.archive.reset();  // everything is restored: close the checkpoint
  }
  obs.set_stage(st.cfg.name, mods, st.cfg);
  if (resuming) obs.resumed_at(s.step);
  log.line("stage '" + st.cfg.name + "' (" + std::to_string(k + 1) + " of " + std::to_string(sc.stages.size()) + ") " +
           (resuming ? "resumed" : "started") + " at step " + std::to_string(s.step));
  obs.set_k0(resuming ? s.step - s.stage_step0 : 0);
  json js;
  js["name"] = st.cfg.name;
  js["type"] = st.type;
  if (!prep.set_counts.is_null()) js["particle_sets"] = prep.set_counts;
  if (!st.delete_sets.empty()) js["deleted_particles"] = deletion_summary(s, st.delete_sets);
  if (st.create_bonds_gap >= 0.0) {
    js["bonds_created"] = prep.bonds_made;
    js["bonds_created_gap_m"] = prep.bond_gap;
  }
  // A stage continued in place reports what its start reported (set counts, bonds made): kept in
  // every state file of the stage (OutputObserver::outputs()).
  if (resuming && rp.outputs.is_object() && rp.outputs.contains("stage_entry")) js = rp.outputs["stage_entry"];
  obs.set_stage_entry(js);
  if (resuming && rp.outputs.is_object() && rp.outputs.contains("stage_start")) obs.set_stage_start(rp.outputs["stage_start"]);
  if (st.dynamics) {
    std::optional<SnapshotObserver> snap;
    if (st.snapshots) {
      if (!resuming) record.forget_stage(stage_index);
      snap.emplace(obs, *st.snapshots, stage_index, st.cfg.name, opt.outdir, record,
                   [&obs](const std::filesystem::path& f, State& x) {
                     obs.publish();  // first: the index then holds at least what the snapshot records
                     obs.write_checkpoint(f, x, true);
                   });
    }
    const StageResult r = sim.run_stage(st.cfg, snap ? static_cast<Observer&>(*snap) : obs, resuming);
    obs.end_stage_line();
    describe_dynamics(js, r, st, resuming, obs.stage_start());
    if (sc.bond_law) {
      js["bonds"] = {{"intact", s.bonds.intact_count()}, {"broken", s.bonds.broken_count()}};
      if (s.bonds.broken_count() > 0) js["bonds"]["broken_by_mode"] = write_broken_bonds(s, *sc.bond_law, opt.outdir);
    }
    if (st.snapshots) js["snapshots"] = snapshots_summary(record, stage_index, *st.snapshots, opt.outdir);
    totals.steps += r.steps;
    totals.particle_steps += static_cast<double>(r.steps_run) * static_cast<double>(r.particles);
  } else {
    sim.prepare(st.cfg);
    s.stage_step0 = s.step;
    s.stage_t0 = s.time;
    s.contacts.rebuild(find_pairs(s.particles.position, s.particles.radius, 0.0), s.particles.id, s.particles.size());
    js["particles"] = s.particles.size();
    js["wall_time_s"] = std::chrono::duration<double>(steady::now() - ts).count();
    obs.frame(s);
  }
  if (st.generator) {
    for (const auto& [key, v] : st.generator->report(s)) js["packing"][key] = finite_or_null(v);
    js["packing"]["coordination_histogram"] = st.generator->coordination_histogram(s);
    for (const auto& [key, v] : st.generator->report_arrays(s)) js["packing"][key] = v;
  }
  summary["stages"].push_back(js);
  const bool until_unmet = st.dynamics && st.cfg.require_until && !js["until_reached"].get<bool>();
  obs.final_state(s, until_unmet ? committed_unmet : committed_ok);
  if (until_unmet)
    throw PhysicsError(s.step, {}, "stop condition",
                       "stage '" + st.cfg.name +
                           "' reached its hard stop before its 'until' conditions held "
                           "(see the stage's \"final\" values in summary.json)");
}

/// `check`'s view of stage k, prepared exactly as the run prepares it: the particles at its start,
/// the stable steps and the time step it would take, the module steps and the step plan.
json derive_stage(const Scenario& sc, StageDef& st, State& s) {
  json d;
  Simulation sim(s, sc.law_of(st), sc.bond_law.get());
  for (auto& m : st.modules) sim.add_module(m.get());
  sim.prepare(st.cfg);
  s.contacts.rebuild(find_pairs(s.particles.position, s.particles.radius, 0.0), s.particles.id, s.particles.size());
  // A frozen or quasi-static stage has no mechanical step limit, as in the run.
  const double stable = st.cfg.mechanics && !st.cfg.quasi_static ? sim.mechanical_stable_dt() : std::numeric_limits<double>::infinity();
  d["particles_at_start"] = s.particles.size();
  d["mechanical_stable_dt_s"] = stable;
  try {
    const double dt = sim.resolve_dt(st.cfg);
    d["dt_s"] = dt;
    d["dt_fraction_of_stable"] = dt / stable;
    if (dt > stable && !st.cfg.allow_unstable_dt)
      throw ConfigError(st.path + "/dt", "dt = " + std::to_string(dt) + " s exceeds the stable step " + std::to_string(stable) +
                                             " s (set allow_unstable_dt to override)");
  } catch (const SetupError& e) { d["dt_note"] = e.what(); }
  for (const auto& [name, sdt] : sim.module_stable_dts())
    d["module_stable_dt_s"][name] = std::isfinite(sdt) ? json(sdt) : json("unconditionally stable");
  d["step_plan"] = json::array();
  for (const auto& n : sim.plan().names()) d["step_plan"].push_back(n);
  return d;
}

}  // namespace

json dry_run(Scenario& sc) {
  json j = sc.resolved;
  State s;
  s.materials = sc.materials;
  s.walls = sc.walls;
  s.rng.seed(sc.seed);
  bool known = true;  // the state at the stage start is the run's (no stage has stepped yet)
  for (std::size_t k = 0; k < sc.stages.size(); ++k) {
    StageDef& st = sc.stages[k];
    json& js = j["stages"][k];
    if (st.sweep) {  // a branch: items start from the state before it, which goes on unchanged
      js["derived"]["note"] = "sweep stage: each item starts from its own input state; not set up here";
      continue;
    }
    if (!st.from_snapshot.empty()) known = true;
    if (st.generator) js["estimated_particles"] = st.generator->estimated_particles();
    if (!known) continue;
    const StagePrep prep = prepare_stage(s, st, sc, false, static_cast<std::int64_t>(k), true);
    if (!prep.generated) {
      known = false;
      continue;
    }
    if (!st.dynamics) continue;
    js["derived"] = derive_stage(sc, st, s);
    known = false;  // later stages start from a state that only the run produces
  }
  return j;
}

namespace {

/// A fresh start's take-over of `outdir` (the frames and index files are the ResultsWriter's):
/// summary.json and the restart points an earlier run left (checkpoints, final_state.h5, the
/// checkpoint before a failure, snapshots/*.h5), which --resume would otherwise take for this
/// run's; a file a stage reads ("from_snapshot") stays.
void remove_earlier_run(const Scenario& sc, const std::filesystem::path& outdir) {
  std::set<std::filesystem::path> inputs;
  std::error_code ec;
  for (const StageDef& st : sc.stages)
    if (!st.from_snapshot.empty()) inputs.insert(std::filesystem::weakly_canonical(st.from_snapshot, ec));
  std::vector<std::filesystem::path> files;
  for (const char* name : {"summary.json", "checkpoint.h5", "checkpoint.previous.h5", "checkpoint_before_failure.h5", "final_state.h5"})
    files.push_back(outdir / name);
  for (const auto& e : std::filesystem::directory_iterator(outdir / "snapshots", ec))
    if (e.path().extension() == ".h5") files.push_back(e.path());
  for (const auto& f : files)
    if (!inputs.count(std::filesystem::weakly_canonical(f, ec))) remove_if_present(f);
}

/// The stages of the scenario from the restart point (or the first) to the last; summary.json
/// and the run's status whatever happens (a failure or interrupt is rethrown after writing them).
json run_logged(Scenario& sc, const RunOptions& opt, RunLog& log, steady::time_point t0) {
  write_json_atomic(opt.outdir / "resolved.json", sc.resolved);
  State s;
  s.materials = sc.materials;
  s.walls = sc.walls;
  s.rng.seed(sc.seed);
  if (opt.start) s = std::move(*opt.start);  // the item's own start state: no second copy
  RunRecord record;  // snapshots taken and sweep progress (see sweep.hpp)
  RestartPoint rp = read_restart(sc, opt, s, record, log);
  // A fresh start (or a restart into another folder) leaves no summary or restart point of an
  // earlier run here (--resume takes them for this run's); a continuation keeps them.
  if (!opt.in_place && !opt.record) remove_earlier_run(sc, opt.outdir);

  OutputObserver obs(opt.outdir, opt.quiet, log, rp.outputs);
  if (!opt.checkpoint_file.empty()) obs.set_checkpoint_file(opt.checkpoint_file);
  obs.set_record(opt.record ? opt.record : std::function<json()>([&record] { return record.to_json(); }));
  json summary;
  summary["scenario"] = sc.name;
  summary["version"] = SPARKDEM_VERSION;
  summary["build"] = {{"commit", build_info().commit}, {"clean", build_info().clean}};
  summary["threads"] = omp_get_max_threads();
  summary["stages"] = json::array();
  RunTotals totals;
  if (opt.restart && !rp.outputs.is_object()) summary["restarted_from"] = opt.restart->string();
  if (rp.outputs.is_object()) {  // in place: the stages completed before the restart point, as reported then
    summary["stages"] = rp.outputs.value("stages", json::array());
    for (const json& e : summary["stages"]) totals.steps += e.value("steps", Step{0});
  }
  obs.set_summary_stages(&summary["stages"]);
  std::string status = "completed";
  std::string error;
  std::optional<PhysicsError> failure;
  // Stage k's end state is committed as OUTDIR/final_state.h5: what a --restart from it continues with.
  auto completed = [&](std::size_t k, bool until_unmet) {
    return [&opt, &sc, k, until_unmet](const std::filesystem::path& file) {
      if (!opt.progress) return;
      RunProgress& p = *opt.progress;
      p.final_state = file;
      p.stage = sc.stages[k].cfg.name;
      p.stage_number = k + 1;
      p.stages = sc.stages.size();
      p.next_stage = k + 1 < sc.stages.size() ? sc.stages[k + 1].cfg.name : std::string();
      p.until_unmet = until_unmet;
    };
  };
  try {
    for (std::size_t k = rp.first; k < sc.stages.size(); ++k) {
      if (sc.stages[k].sweep) {
        // The sweep's own name in the log; no modules: its final state (the state before the
        // sweep) carries no module state of an earlier stage.
        obs.set_stage(sc.stages[k].cfg.name, {}, sc.stages[k].cfg);
        obs.set_stage_entry(json());
        record.sweep_outputs = obs.outputs();  // the folder's outputs while the sweep runs (its items record their own)
        const SweepOutcome r = run_sweep(sc, k, s, record, rp.resume && k == rp.first, opt);
        record.sweep_outputs = json();
        summary["stages"].push_back(r.entry);
        totals.steps += r.steps;
        totals.particle_steps += r.particle_steps;
        obs.final_state(s, completed(k, false));
        release_free_memory();
        continue;
      }
      run_plain_stage(sc, k, s, obs, record, rp, opt, log, summary, totals, completed(k, false), completed(k, true));
      release_free_memory();  // what the stage freed is not held while the next one runs
    }
  } catch (const Interrupted& e) {
    status = "interrupted";
    error = e.what();
  } catch (const PhysicsError& e) {
    status = "failed";
    failure.emplace(with_healthy_checkpoint(e, obs, log));
    error = failure->what();
  }
  obs.end_stage_line();
  evaluate_checks(sc.checks, summary, log);
  const double wall = std::chrono::duration<double>(steady::now() - t0).count();
  summary["status"] = status;
  if (!error.empty()) summary["error"] = error;
  if (failure) summary["failure"] = failure_entry(*failure);
  summary["wall_time_s"] = wall;
  summary["steps"] = totals.steps;
  summary["mechanical_time_s"] = s.time;
  summary["physical_time_s"] = s.physical_time;
  summary["particles"] = s.particles.size();
  summary["particle_steps_per_s"] = wall > 0 ? totals.particle_steps / wall : 0.0;
  obs.finalize();
  write_json_atomic(opt.outdir / "summary.json", summary);
  if (status == "interrupted") throw Interrupted(error);
  if (status == "failed")
    throw PhysicsError(failure->step(), failure->ids(), failure->quantity(),
                       failure->reason() + " (outputs up to the failure were written)", failure->detail());
  log.line("run completed: " + std::to_string(totals.steps) + " steps, " + short_number(wall) + " s wall");
  return summary;
}
}  // namespace

bool restart_in_place(const std::filesystem::path& file, const std::filesystem::path& outdir) {
  std::error_code ec;
  const std::filesystem::path dir = std::filesystem::canonical(file, ec).parent_path();
  if (ec) return false;  // reading the file reports what is wrong with it
  const std::filesystem::path out = std::filesystem::canonical(outdir, ec);
  return !ec && (dir == out || dir == out / "snapshots");
}

std::filesystem::path resolve_output_directory(const std::filesystem::path& outdir) {
  std::error_code ec;
  std::filesystem::create_directories(outdir, ec);
  if (ec) throw SetupError("output directory '" + outdir.string() + "': cannot create it: " + ec.message());
  std::filesystem::path physical = std::filesystem::canonical(outdir, ec);
  if (ec) throw SetupError("output directory '" + outdir.string() + "': cannot resolve it: " + ec.message());
  if (!std::filesystem::is_directory(physical, ec))
    throw SetupError("output directory '" + outdir.string() + "' (" + physical.string() + "): not a directory");
  return physical;
}

json run_scenario(Scenario& sc, const RunOptions& given) {
  if (given.threads > 0) omp_set_num_threads(given.threads);
  const auto t0 = steady::now();
  // One physical output path for everything below (files, snapshots, sweep items, checkpoints).
  RunOptions opt = given;
  opt.outdir = resolve_output_directory(given.outdir);
  // A run's restart file in its own output directory (or its snapshots/) continues the folder in
  // place; a sweep item inherits the enclosing run's choice.
  if (opt.restart && !opt.record) opt.in_place = restart_in_place(*opt.restart, opt.outdir);
  RunLog log(opt.outdir / "run.log");
  log.line("run started: scenario '" + sc.name + "', sparkdem " + SPARKDEM_VERSION + ", pid " + std::to_string(::getpid()) + ", " +
           std::to_string(omp_get_max_threads()) + " thread(s)" +
           (opt.restart ? ", restarting from '" + opt.restart->string() + "'" : std::string()));
  try {
    return run_logged(sc, opt, log, t0);
  } catch (const Interrupted& e) {
    note(log, std::string("run interrupted: ") + e.what());
    throw;
  } catch (const std::exception& e) {
    note(log, std::string("run failed: ") + e.what());
    throw;
  }
}

}  // namespace sparkdem::io
