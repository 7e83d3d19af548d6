#pragma once
/// Snapshots and sweeps at run time (their JSON side is SnapshotSpec and SweepDef in scenario.hpp).
///
/// Snapshots: SnapshotObserver wraps the pipeline's observer during a stage with "snapshots" and,
/// from the engine's watch() calls (monitor values + state), saves the state in checkpoint format
/// under OUTDIR/snapshots/<stage>_<k>.h5 when it is due.
///
/// Sweeps: run_sweep runs a stage once per item as a nested run (run_scenario of a one-stage
/// scenario) into OUTDIR/sweep_<stage>/<item>/ (its own results.h5, timeseries.csv, summary.json,
/// final_state.h5), starting from the input state: the state before the stage (written to
/// OUTDIR/sweep_<stage>/input_state.h5), reseeded for a seed ensemble, or a snapshot. The nested
/// runs write their checkpoints to the main checkpoint file (on several MPI ranks, see
/// sweep_ranks.cpp: to their own directories, and rank 0 writes the main checkpoint with the
/// finished rows after every item). The table of the items goes to
/// OUTDIR/sweep_<stage>.csv (rewritten after every item) and to the stage's summary entry.
///
/// RunRecord: what the pipeline keeps beside the state (snapshots taken, the first value of each
/// watched column, the sweep in progress with its finished rows). It is stored as JSON in every
/// checkpoint and state file (string dataset "pipeline/record"), so a restart neither retakes
/// nor loses a snapshot and resumes a sweep inside the item it was in, keeping the rows before.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "engine/simulation.hpp"
#include "io/scenario/scenario.hpp"

namespace sparkdem::io {

struct RunOptions;

struct SnapshotRecord {
  std::int64_t stage_index = 0;
  std::string stage;
  std::int64_t index = 0;  ///< k of at[k], or the k-th every_steps snapshot
  std::string column;
  double target = std::nan("");  ///< at[k] (NaN for every_steps)
  double value = std::nan("");   ///< the column's value when taken
  Step step = 0;
  double time = 0.0;
  std::string file;  ///< absolute path of the state file
  /// Every time-series column of the stage when taken (the snapshot's monitors: porosities, kinetic
  /// energy, wall work, neck statistics, ...), reported in the stage's summary entry.
  std::map<std::string, double> columns;
};

struct RunRecord {
  std::vector<SnapshotRecord> snapshots;
  std::map<std::int64_t, double> first_values;  ///< stage index -> first finite sample of its snapshot column
  json sweep;                                   ///< sweep in progress {"stage", "item", "rows", "input_state"}, or null
  /// While a sweep runs: the run's own outputs (OutputObserver::outputs(); a checkpoint inside an
  /// item records the item's folder as "outputs"), or null. Stored as "sweep_outputs" when set.
  json sweep_outputs;

  json to_json() const;
  static RunRecord from_json(const json& j);
  /// Snapshots of one stage, by index.
  std::vector<SnapshotRecord> of_stage(std::int64_t stage_index) const;
  /// Drops what a fresh start of the stage will record again.
  void forget_stage(std::int64_t stage_index);
};

/// File-name form of a stage name: characters other than letters, digits, '-', '_' and '.'
/// become '_'.
std::string file_name_of(const std::string& stage);

/// Takes a stage's snapshots; forwards every callback to `inner`. `save` writes the state file;
/// the record lists the snapshot before the file is written, so the file and every later
/// checkpoint contain it.
class SnapshotObserver final : public Observer {
 public:
  using Save = std::function<void(const std::filesystem::path&, State&)>;
  SnapshotObserver(Observer& inner, const SnapshotSpec& spec, std::int64_t stage_index, std::string stage, std::filesystem::path outdir,
                   RunRecord& record, Save save)
      : inner_(inner),
        spec_(spec),
        stage_index_(stage_index),
        stage_(std::move(stage)),
        outdir_(std::move(outdir)),
        record_(record),
        save_(std::move(save)) {}
  void frame(const State& s) override { inner_.frame(s); }
  void timeseries(const std::vector<std::string>& cols, const std::vector<double>& vals) override { inner_.timeseries(cols, vals); }
  void checkpoint(State& s) override { inner_.checkpoint(s); }
  void healthy(State& s) override { inner_.healthy(s); }
  void progress(const State& s, Step k, double t, double dt) override { inner_.progress(s, k, t, dt); }
  void steps_planned(double dt, double stable, const std::vector<ModuleStep>& m) override { inner_.steps_planned(dt, stable, m); }
  void stage_started(const StageResult& r) override { inner_.stage_started(r); }
  bool checkpoint_due() override { return inner_.checkpoint_due(); }
  void event(const std::string& text) override { inner_.event(text); }
  Step watch_every() const override;
  void watch(State& s, const std::vector<std::string>& cols, const std::vector<double>& vals) override;

 private:
  bool taken(std::int64_t index) const;
  void take(State& s, std::int64_t index, double target, double value, const std::vector<std::string>& cols,
            const std::vector<double>& vals);
  Observer& inner_;
  SnapshotSpec spec_;
  std::int64_t stage_index_;
  std::string stage_;
  std::filesystem::path outdir_;
  RunRecord& record_;
  Save save_;
};

/// The snapshots of a stage for its summary entry: column, taken (index, target, value, step,
/// time, file relative to `outdir` when inside it, the time-series columns when taken) and the
/// `at` values not reached.
json snapshots_summary(const RunRecord& record, std::int64_t stage_index, const SnapshotSpec& spec, const std::filesystem::path& outdir);

/// Count, mean and sample standard deviation (n - 1; null below 2 values) of each column over
/// the completed rows' finite values, summed in row order.
json column_statistics(const json& rows, const std::vector<std::string>& columns);

struct SweepOutcome {
  json entry;      ///< the stage's summary entry
  Step steps = 0;  ///< steps of every item run here
  double particle_steps = 0;
};

/// Runs sweep stage `k` of `sc` (`s` is the state before it, or on `resuming` the checkpoint's
/// state inside the item recorded in `record.sweep`). Leaves `s` as the state before the stage
/// (stage index k). An item that fails with a PhysicsError gets status "failed" and the sweep
/// goes on; Interrupted and SetupError propagate (after the table so far is written).
SweepOutcome run_sweep(Scenario& sc, std::size_t k, State& s, RunRecord& record, bool resuming, const RunOptions& opt);

/// On a run over several MPI ranks (io/mpi/ranks.hpp), every rank but 0 serves sweep items:
/// waits (sleeping between probes) for an item from rank 0, runs it into its directory, sends
/// back its row, until rank 0's stop signal; returns the exit code rank 0 sent with it.
int serve_sweep_items(Scenario& sc);
/// Rank 0: sends the stop signal with its exit code to every other rank (nothing on one rank).
void stop_sweep_servers(int exit_code);

}  // namespace sparkdem::io
