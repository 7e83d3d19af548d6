#pragma once
/// A scenario: materials, the contact law, initial walls and a sequence of stages. Loading
/// validates everything before step 0 and reports all problems at once (ConfigError).
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "engine/model/registry.hpp"
#include "engine/simulation.hpp"
#include "engine/state/particle_set.hpp"
#include "engine/state/state.hpp"

namespace sparkdem::io {

using nlohmann::json;

struct StageDef {
  std::string type;  ///< dynamics | <generator name> (lattice, deposit, fill, relax)
  std::string path;  ///< JSON pointer of the stage
  StageConfig cfg;
  std::unique_ptr<Generator> generator;
  std::vector<std::unique_ptr<Module>> modules;
  std::unique_ptr<ContactModel> law;  ///< stage override, else the scenario's
  std::vector<Wall> add_walls;
  std::vector<std::string> remove_walls;
  std::string from_snapshot;          ///< load particles, contacts and walls from a checkpoint
  double create_bonds_gap = -1.0;     ///< >= 0: bond every pair with gap <= this at the stage start [m]
  bool dynamics = true;               ///< false: a generator stage with nothing to settle (lattice, relax)
  std::vector<std::pair<std::string, SetSelector>> sets;  ///< particle sets (re)evaluated at the stage start
};

struct Scenario {
  json resolved;                       ///< the scenario as run (defaults filled in)
  std::string name;
  std::uint64_t seed = 12345;
  std::vector<Material> materials;
  std::unique_ptr<ContactModel> law;
  std::unique_ptr<BondModel> bond_law;  ///< null: the scenario has no bonds
  BondTable::ContactRule bond_contact_rule = BondTable::ContactRule::Exclude;
  std::vector<Wall> walls;
  std::vector<StageDef> stages;
  const ContactModel& law_of(const StageDef& st) const { return st.law ? *st.law : *law; }
};

/// Parse and validate; relative file paths are resolved against `base_dir`.
Scenario load_scenario(const json& j, const Registry& reg, const std::filesystem::path& base_dir);
/// Read a JSON file (ConfigError on unreadable or malformed input, with the line and column).
json read_json_file(const std::filesystem::path& file);

/// Every stage type, wall, motion and scenario-level spec, for `sparkdem schema`.
json schema_json(const Registry& reg);

}  // namespace sparkdem::io
