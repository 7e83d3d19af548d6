#pragma once
/// A scenario: materials, the contact law, initial walls and a sequence of stages. Loading
/// validates everything before step 0 and reports all problems at once (ConfigError).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "engine/model/registry.hpp"
#include "engine/simulation.hpp"
#include "engine/state/particle_set.hpp"
#include "engine/state/state.hpp"

namespace sparkdem::io {

using nlohmann::json;

/// `"snapshots"` of a dynamics stage: the full state (checkpoint format) is saved under
/// OUTDIR/snapshots/<stage>_<k>.h5 the first time the time-series column `column` crosses
/// `at[k]` (direction per value from the column's first sample of the stage: a value above the
/// first sample is crossed upwards, one below downwards, one equal at once), or every
/// `every_steps` stage steps (k = 0, 1, ...). Values are checked at the stage start, at every
/// time-series row, every `check_every` stage steps and at the stage end.
struct SnapshotSpec {
  std::string column;            ///< watched time-series column ("time" by default with every_steps)
  std::vector<double> at;        ///< crossing values, in the order of the snapshot files
  std::int64_t every_steps = 0;  ///< > 0: a snapshot at stage steps N, 2N, ... instead of `at`
  std::int64_t check_every = 0;  ///< extra checks of `at` every this many stage steps (0: none)
};

struct SweepDef;

struct StageDef {
  std::string type;  ///< dynamics | a registered generator's name
  std::string path;  ///< JSON pointer of the stage
  StageConfig cfg;
  std::unique_ptr<Generator> generator;
  std::vector<std::unique_ptr<Module>> modules;
  std::unique_ptr<ContactModel> law;  ///< stage override, else the scenario's
  std::vector<Wall> add_walls;
  /// Per added wall: >= 0 places the plane along its normal at this gap [m] from the nearest
  /// particle surface when the stage starts (a punch put on top of a packing); < 0: as given.
  std::vector<double> add_wall_clearance;
  std::vector<std::string> remove_walls;
  /// `affine`: x -> affine_origin + diag(affine_scale) (x - affine_origin) of positions and walls
  /// at the stage start (after from_snapshot and the wall edits); all ones: none.
  Vec3 affine_scale = Vec3::Ones();
  Vec3 affine_origin = Vec3::Zero();
  std::string from_snapshot;       ///< load particles, contacts and walls from a checkpoint
  double create_bonds_gap = -1.0;  ///< >= 0: bond every pair with gap <= this at the stage start [m]
  /// true: create_bonds_gap is a fraction [1] of the mean radius at the stage start (after the
  /// generator), resolved there: `{"gap_tolerance_relative": g}`, as the networks'
  /// touch_tolerance_relative, so a bond set follows the packing's element size.
  bool create_bonds_gap_relative = false;
  bool dynamics = true;                                   ///< false: a generator stage with nothing to settle (Generator::steps)
  std::vector<std::pair<std::string, SetSelector>> sets;  ///< particle sets (re)evaluated at the stage start
  /// `"delete_sets"`: particle sets evaluated at the stage start (after the generator, before
  /// `sets`) whose members are deleted (LAMMPS `delete_atoms region`); see delete_particles.
  std::vector<std::pair<std::string, SetSelector>> delete_sets;
  std::optional<SnapshotSpec> snapshots;                 ///< states saved during the stage (dynamics stages)
  std::shared_ptr<const SweepDef> sweep;                 ///< run once per item (see SweepDef); null: once
  std::vector<std::shared_ptr<const Monitor>> monitors;  ///< stage-key monitors (e.g. "compact"), after the generator's
};

/// `"sweep"` of a stage: the stage runs once per item, each item a branch that starts from the
/// same input state (the state before the stage, or one snapshot) and writes its own outputs.
/// The main state after a sweep stage is the state before it. Exactly one kind:
///   snapshots_of  one item per snapshot taken by an earlier stage (its particles, contacts,
///                 walls, step and time; materials and random generator of the current state)
///   parameter     one item per value, substituted at a JSON pointer relative to the stage
///                 before the stage is bound (each value validated at load time)
///   seeds         one item per seed of the state's random generator (an ensemble)
/// A sweep over snapshots may `calibrate` one parameter on one snapshot first (see Calibration).
struct SweepDef {
  enum class Kind { Snapshots, Parameter, Seeds };
  Kind kind = Kind::Seeds;
  std::string snapshots_of;           ///< Snapshots: name of the earlier stage
  std::int64_t snapshots_stage = -1;  ///< Snapshots: its index
  std::string parameter;              ///< Parameter: JSON pointer relative to the stage
  std::vector<json> values;           ///< Parameter: one item per value
  std::vector<std::uint64_t> seeds;   ///< Seeds: one item per seed
  std::vector<std::string> collect;   ///< table columns; empty: every final value
  bool keep_item_states = true;       ///< false: a completed item's final_state.h5 is removed
  /// Snapshots + `calibrate`: the items are first `scan` (the parameter's values on snapshot
  /// `snapshot`: the map), then a bracketed search on that snapshot (secant in (ln value,
  /// ln column), kept inside the middle 80 % of the bracket) until the final `column` is within
  /// `tolerance` (relative) of `target`, then one item per snapshot at the calibrated value
  /// (the validation). Rows carry "phase" (scan | search | validate) and "value".
  struct Calibration {
    std::string parameter;      ///< JSON pointer relative to the stage
    std::string column;         ///< final time-series value matched to the target
    std::int64_t snapshot = 0;  ///< index k of the snapshot (its `at[k]`)
    double target = 0.0;
    std::vector<double> scan;  ///< > 0, increasing
    double tolerance = 1e-3;
    std::int64_t max_iterations = 40;
  };
  std::optional<Calibration> calibrate;
  json stage_json;  ///< the stage as written, without "sweep"
  /// A fresh stage (own modules, generator and law) from an item's stage JSON and its resolved
  /// form; the JSON was validated at load time (throws ConfigError otherwise).
  std::function<StageDef(const json& stage_json, json& resolved)> build;
  /// Stage JSON of parameter item k (the value substituted), or the stage JSON.
  json item_json(std::size_t k) const;
  /// Stage JSON with the calibrated parameter set to `value`.
  json calibration_json(double value) const;
};

/// A validation figure recorded in summary.json: the final value of a time-series column of a
/// stage, minus `offset`, against a reference fixed in the scenario before the run.
struct CheckDef {
  std::string name;
  std::string stage;       ///< stage name (the last stage of that name)
  std::string column;      ///< time-series column (its final value)
  double offset = 0.0;     ///< subtracted from the value (e.g. the initial temperature) [column unit]
  double reference = 0.0;  ///< reference value [column unit] (non-zero)
  double tolerance = 0.0;  ///< relative band |value - reference| / |reference| (0: report only)
  std::string source;      ///< where the reference comes from (free text, copied to the summary)
};

struct Scenario {
  json resolved;  ///< the scenario as run (defaults filled in)
  std::string name;
  std::uint64_t seed = 12345;
  std::vector<Material> materials;
  std::shared_ptr<ContactModel> law;    ///< shared with the nested runs of sweep items
  std::shared_ptr<BondModel> bond_law;  ///< null: the scenario has no bonds (shared like law)
  BondTable::ContactRule bond_contact_rule = BondTable::ContactRule::Exclude;
  std::vector<Wall> walls;
  std::vector<StageDef> stages;
  std::vector<CheckDef> checks;
  const ContactModel& law_of(const StageDef& st) const { return st.law ? *st.law : *law; }
};

/// Parse and validate; relative file paths are resolved against `base_dir`.
Scenario load_scenario(const json& j, const Registry& reg, const std::filesystem::path& base_dir);
/// Read a JSON file (ConfigError on unreadable or malformed input, with the line and column).
json read_json_file(const std::filesystem::path& file);

/// Every stage type, wall, motion and scenario-level spec, for `sparkdem schema`.
json schema_json(const Registry& reg);

}  // namespace sparkdem::io
