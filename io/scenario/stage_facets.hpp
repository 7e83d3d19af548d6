#pragma once
/// A stage's keys, one registered facet each (the registry style of laws and modules): a facet is
/// the key, the form and parameters of its value (for `sparkdem schema`, did-you-mean and JSON
/// pointers in errors) and a bind step that checks the value and fills the StageDef. build_stage
/// binds the stage's own parameters (StageParams: dt, stop, output, watchdog, ...) and then walks
/// the facets in their order, which is the order their checks depend on (the generator first:
/// its walls and whether the stage steps; walls before the keys that name them; modules before the
/// columns). Adding a stage key: one row in stage_facets() and its bind function
/// (docs/ARCHITECTURE.md, "Recipes"). Monitors (e.g. "compact") are facets made from the
/// registry's monitor rows.
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "engine/model/registry.hpp"
#include "io/scenario/scenario.hpp"

namespace sparkdem::io {

/// What checking a stage depends on from the scenario and the stages before it.
struct StageContext {
  std::shared_ptr<const Registry> reg;
  std::filesystem::path base_dir;
  std::map<std::string, SetSelector> sets;  ///< the scenario's particle sets
  std::set<std::string> wall_names;         ///< walls at the stage start (the stage updates it)
  bool has_particles = false;               ///< an earlier stage creates particles (updated)
  std::vector<Material> materials;          ///< for a generator's checks against the scene
  std::vector<Wall> walls;                  ///< scenario walls (or a snapshot's), for those checks
  bool has_bond_law = false;                ///< the scenario names a bond law
  /// Output: the time-series columns of the stage just built (none when unknown before the run:
  /// a stage from a snapshot file).
  std::optional<std::vector<std::string>> columns;
};

/// One stage being bound: the context, the stage, its JSON and where problems go.
struct StageBuild {
  StageContext& ctx;
  StageDef& st;
  const json& js;           ///< the stage object as written
  const std::string& path;  ///< its JSON pointer
  std::vector<Diagnostic>& errors;
  json& resolved;                 ///< the resolved stage (each facet adds its key)
  bool generator_failed = false;  ///< the generator did not build: checks that need it are left out
  bool modules_built = true;      ///< every module built (else the stage's columns are unknown)
};

/// One stage key.
struct StageFacet {
  std::string key;
  std::string form;  ///< the JSON form of the value ("object", "array of particle-set names", ...)
  std::string doc;
  Spec params;          ///< parameters of the value (an object) or of each entry (a map); may be empty
  bool always = false;  ///< bound even when the key is absent (the value is then null)
  std::function<void(const json& value, const std::string& at, StageBuild& b)> bind;
};

/// Every stage key in binding order; the registry's monitors are facets too.
std::vector<StageFacet> stage_facets(const Registry& reg);

/// Bind and check one stage (its "sweep" key is left to the caller); appends every problem to
/// `errors` and the resolved stage to `r`.
StageDef build_stage(StageContext& ctx, const json& js, const std::string& path, std::vector<Diagnostic>& errors, json& r);

/// "" if `column` is one of `cols`, else the problem (with a did-you-mean).
std::string unknown_column(const std::string& column, const std::vector<std::string>& cols);

/// The stage's own parameters and every stage key, for `sparkdem schema`.
json stage_schema(const Registry& reg);

}  // namespace sparkdem::io
