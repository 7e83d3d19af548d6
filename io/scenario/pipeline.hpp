#pragma once
/// Runs a scenario's stages in order, writing OUTDIR/{results.h5, results.xdmf, timeseries.csv,
/// summary.json, resolved.json, checkpoint.h5, final_state.h5}, plus snapshots/ and, per sweep
/// stage, sweep_<stage>.csv and sweep_<stage>/<item>/ (see sweep.hpp). Every file is written
/// under a temporary name and renamed when complete.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "io/scenario/scenario.hpp"

namespace sparkdem::io {

struct RunOptions {
  std::filesystem::path outdir = "out";
  std::optional<std::filesystem::path> restart;  ///< continue from this checkpoint
  bool quiet = false;
  int threads = 0;  ///< 0 = OpenMP default
  // Set by sweeps for the nested run of one item (see sweep.hpp); the command line leaves them.
  const State* start = nullptr;           ///< start from this state instead of an empty one
  std::int64_t stage_offset = 0;          ///< index of the first stage in the enclosing run
  std::filesystem::path checkpoint_file;  ///< where checkpoints go; empty: outdir/checkpoint.h5
  std::function<json()> record;           ///< pipeline record stored in checkpoints; empty: the run's own
};

/// Run and return the summary (also written to summary.json). Throws PhysicsError,
/// SetupError or Interrupted (after writing a checkpoint and the outputs so far).
json run_scenario(Scenario& sc, const RunOptions& opt);

/// Read a checkpoint into `s` (state only); returns its stage index and whether it was taken
/// inside that stage.
std::pair<std::int64_t, bool> read_checkpoint(const std::filesystem::path& file, State& s);

/// Write `json` to `file` atomically (tmp + rename).
void write_json_atomic(const std::filesystem::path& file, const json& j);

}  // namespace sparkdem::io
