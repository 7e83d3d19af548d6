#pragma once
/// The items of a sweep stage, shared by the two ways of running them: in item order on one rank
/// (sweep.cpp) and spread over MPI ranks (sweep_ranks.cpp). An item travels between ranks as an
/// ItemJob (JSON): any rank that holds the parsed scenario rebuilds the item's one-stage scenario
/// and start state from it, so an item's result does not depend on the rank that ran it.
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "io/scenario/pipeline.hpp"
#include "io/scenario/sweep.hpp"

namespace sparkdem::io::sweep_detail {

/// One item of a sweep: which snapshot / value / seed and, when calibrating, which value and phase.
struct Item {
  std::size_t index = 0;        ///< snapshot / value / seed index
  double value = std::nan("");  ///< calibrated parameter's value
  std::string phase;            ///< scan | search | validate (calibration only)
};

/// What every item of one sweep stage shares, and what a restart carried over.
struct SweepContext {
  std::size_t stage = 0;         ///< position of the stage in the scenario
  std::int64_t stage_index = 0;  ///< in the enclosing run (RunOptions::stage_offset + stage)
  const SweepDef* sw = nullptr;
  std::string stage_name;
  std::filesystem::path outdir, dir, table, checkpoint;
  std::string input_file;                  ///< the input state's file (absolute)
  State input;                             ///< the state before the stage
  std::vector<SnapshotRecord> snaps;       ///< Snapshots kind: the items' snapshots
  std::size_t n = 0;                       ///< snapshots / values / seeds
  std::int64_t cal_pos = -1;               ///< position of the calibration snapshot among snaps
  std::map<std::size_t, json> done;        ///< rows finished before a restart, by item number
  std::optional<std::size_t> resume_item;  ///< the checkpoint lies inside this item (one-rank runs)
  bool quiet = false;
};

/// Item j of the sweep, or nothing when the sweep is complete (throws SetupError when a
/// calibration cannot go on). A calibration plans it from the rows of items 0..j-1 among
/// `rows_by_item` (rows of later items are ignored).
std::optional<Item> plan_item(const SweepContext& ctx, std::size_t j, const std::map<std::size_t, json>& rows_by_item);

/// One item as a message between ranks.
struct ItemJob {
  std::size_t stage = 0;
  std::int64_t stage_index = 0;
  std::size_t j = 0;  ///< item number: its row's place in the table
  Item item;
  std::string input_state;  ///< the sweep's input state file
  json snapshot;            ///< Snapshots kind: {file, index, step, time, value}; else null
  std::string directory;    ///< the item's output directory (absolute)
  bool quiet = true;
  json to_json() const;
  static ItemJob from_json(const json& j);
};
ItemJob job_of(const SweepContext& ctx, std::size_t j, const Item& item);

struct ItemResult {
  json row;
  Step steps = 0;
  double particle_steps = 0.0;
};

/// Runs one item (a nested run_scenario into job.directory) from `input`, the sweep's input
/// state. `nested` carries the checkpoint file, a restart and the pipeline record for the nested
/// run (its outdir, start and stage_offset are set here). A PhysicsError gives status "failed";
/// other errors propagate.
ItemResult run_item(Scenario& sc, const ItemJob& job, const State& input, RunOptions nested);

/// The rows by item number, in item order.
json rows_in_order(const std::map<std::size_t, json>& rows);
/// The rows of the items before item j, in item order (what a calibration plans item j from).
json rows_before(const std::map<std::size_t, json>& rows, std::size_t j);
/// Rewrites the sweep table (sweep_<stage>.csv) from these rows.
void write_table(const SweepContext& ctx, const json& rows);

/// Rank 0 of a run on several ranks: runs the items on every rank, one item per rank at a time
/// (rank 0's own thread included), handing out each item as a rank comes free; a calibration's
/// scan and validation items in parallel, its search items one at a time. After every finished
/// item `progress(rows so far)` is called (under a lock, from either of rank 0's threads).
/// Returns the results of the items run here, by item number; rethrows the first error.
std::map<std::size_t, ItemResult> run_items_over_ranks(Scenario& sc, const SweepContext& ctx,
                                                       const std::function<void(const std::map<std::size_t, json>&)>& progress);

}  // namespace sparkdem::io::sweep_detail
