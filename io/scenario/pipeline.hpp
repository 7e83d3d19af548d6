#pragma once
/// Runs a scenario's stages in order, writing OUTDIR/{frames/frame_NNNNNN.h5, results.h5,
/// results.xdmf, timeseries.csv, summary.json, resolved.json, checkpoint.h5, final_state.h5,
/// run.log}, plus snapshots/ and, per sweep stage, sweep_<stage>.csv and sweep_<stage>/<item>/
/// (see sweep.hpp). Every file is written under a temporary name, fsynced and renamed when complete,
/// so a run killed at any moment (even by SIGKILL) leaves only complete files behind.
///
/// run.log is appended to, one line per event, each line written as soon as the event is
/// complete on disk ("[YYYY-MM-DD hh:mm:ss UTC] " prefix):
///   run started: scenario 'NAME', sparkdem VERSION, pid PID, N thread(s)[, restarting from 'FILE']
///   restart: checkpoint 'FILE' verified, step S, stage K (inside it|after it)
///   stage 'NAME' (K of N) started|resumed at step S
///   frame NNNNNN written: frames/frame_NNNNNN.h5 (step S, t = T s, stage 'NAME')
///   checkpoint written: checkpoint.h5 (step S, stage 'NAME')
///   final state written: final_state.h5 (step S, after stage 'NAME')
///   index written: results.h5, results.xdmf, timeseries.csv (F frames, R time-series rows)
///   run completed: S steps, W s wall  |  run interrupted: ...  |  run failed: ...
/// A stage writes at most one frame per step (its closing frame is not written again when its
/// last step was a frame_every step); the next stage's first frame may share the step and time of
/// the previous stage's last one (results.xdmf lists it 1e-15 s later, see results_writer.hpp).
/// A frame the log reports is readable; the index files (results.h5, results.xdmf,
/// timeseries.csv) are rewritten just before every checkpoint, snapshot and final state and at the
/// end, so they hold at least what each restart point records for a continuation in place (see
/// io/hdf5/results_writer.hpp); checkpoint.h5 and final_state.h5 are sealed checkpoints
/// (io/restart/checkpoint_file.hpp), verified before they are read.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "io/restart/state_file.hpp"  // read_checkpoint: continuing a run
#include "io/scenario/scenario.hpp"

namespace sparkdem::io {

/// What a run has completed so far (RunOptions::progress), for the advice after a failure: the
/// last state file OUTDIR/final_state.h5 written in this run and the stage it holds the end of.
/// `--restart final_state` continues the scenario with the stage after that one.
struct RunProgress {
  std::filesystem::path final_state;  ///< empty until a stage completed (and its final state was committed) in this run
  std::string stage;                  ///< the name of that stage
  std::size_t stage_number = 0;       ///< its position in the scenario, 1-based
  std::size_t stages = 0;             ///< the scenario's number of stages
  std::string next_stage;             ///< the name of the stage after it (empty: it was the last)
  bool until_unmet = false;           ///< the stage ended at its hard stop with a required `until` unmet (the run fails)
};

struct RunOptions {
  /// The output directory. run_scenario creates it and then uses its physical path (see
  /// resolve_output_directory) for every file, nested sweep items and checkpoints included.
  std::filesystem::path outdir = "out";
  std::optional<std::filesystem::path> restart;  ///< continue from this checkpoint
  bool quiet = false;
  int threads = 0;  ///< 0 = OpenMP default
  // Set by sweeps for the nested run of one item (see sweep.hpp); the command line leaves them.
  State* start = nullptr;                 ///< start from this state (moved from: no copy) instead of an empty one
  std::int64_t stage_offset = 0;          ///< index of the first stage in the enclosing run
  std::filesystem::path checkpoint_file;  ///< where checkpoints go; empty: outdir/checkpoint.h5
  std::function<json()> record;           ///< pipeline record stored in checkpoints; empty: the run's own
  RunProgress* progress = nullptr;        ///< when set, filled in as stages complete (sweep items leave it)
  /// Set by run_scenario (restart_in_place; a sweep item inherits it): the restart continues the
  /// folder in place, which keeps the frames, time-series rows, summary stages, snapshots and
  /// sweep rows the restart point records and replaces whatever came after it.
  bool in_place = false;
};

/// Whether a restart from `file` continues `outdir` in place: the file lies in `outdir` or in
/// `outdir`/snapshots (symbolic links followed).
bool restart_in_place(const std::filesystem::path& file, const std::filesystem::path& outdir);

/// The output directory as a run uses it: `outdir` created with its parents, then resolved to its
/// absolute physical path (std::filesystem::canonical: symbolic links followed and ".." taken
/// after them, as the OS resolves "LINK/../out"), so that no later lexical recombination of the
/// path (e.g. lexically_normal() turning "LINK/../out" into "out" beside LINK) can point elsewhere.
/// Throws SetupError when it cannot be created or resolved or is not a directory.
std::filesystem::path resolve_output_directory(const std::filesystem::path& outdir);

/// Run and return the summary (also written to summary.json). Throws PhysicsError,
/// SetupError or Interrupted (after writing a checkpoint and the outputs so far).
json run_scenario(Scenario& sc, const RunOptions& opt);

/// `sparkdem check`: the resolved scenario, with each stage's derived values ("derived": particles
/// at its start, stable steps, the time step and its fraction of the stable one, module steps, the
/// step plan) from the run's own stage preparation, as long as the state at the stage start is
/// known without stepping: up to and including the first stage that steps (or after a
/// from_snapshot). Generators that are not cheap to run (relax) end it. Writes nothing.
json dry_run(Scenario& sc);

/// Write OUTDIR/broken_bonds.csv atomically: every broken bond of the state in the order they
/// broke (step, time [s], the two ids, the midpoint x, y, z [m] at the break, the law's failure
/// mode); returns the count per mode.
json write_broken_bonds(const State& s, const BondModel& law, const std::filesystem::path& outdir);

/// Write `json` to `file` atomically and durably (tmp, fsync, rename, directory fsync).
void write_json_atomic(const std::filesystem::path& file, const json& j);

}  // namespace sparkdem::io
