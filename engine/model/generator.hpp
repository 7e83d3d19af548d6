#pragma once
/// A packing generator: a stage type that creates particles (and its container walls), then
/// optionally lets the ordinary stage loop settle them with its own modules, wall motions and
/// stop conditions. Generators never step the mechanics themselves, except `relax`, which is an
/// energy minimisation (FIRE), not a dynamics.
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/model/module.hpp"
#include "engine/simulation.hpp"
#include "engine/state/state.hpp"

namespace sparkdem {

/// A registered generator G also declares `static std::vector<std::string> created_walls()`: the
/// names of the walls generate() may create (a superset is fine), known from the type alone so
/// that later keys and stages may name them even when the generator's parameters are wrong (the
/// GeneratorType concept, engine/model/contracts.hpp).
class Generator {
 public:
  virtual ~Generator() = default;
  virtual std::string name() const = 0;
  /// Insert particles and container walls into the state (deterministic from state.rng).
  virtual void generate(State& s) = 0;
  /// True if the stage loop runs after generation (deposit and fill settle; cpc_fillers runs a
  /// frozen evaluation of its network modules); false: the stage ends at generation.
  virtual bool steps() const { return false; }
  /// Adjust the stage that settles the packing (motions, stop conditions); default: none.
  virtual void configure_stage(StageConfig& cfg) const { (void)cfg; }
  /// Modules the settling stage needs (e.g. gravity); owned by the caller.
  virtual std::vector<std::unique_ptr<Module>> modules() const { return {}; }
  /// Monitors of the packing (density, coordination, ...).
  virtual std::vector<std::unique_ptr<Monitor>> monitors() const { return {}; }
  /// False: generating is an optimisation or a long computation (relax), which `sparkdem check`
  /// (the dry run) leaves out; the stages after it are then not set up by the check.
  virtual bool cheap_to_generate() const { return true; }
  /// Particle count estimate before generation (for `sparkdem check`).
  virtual double estimated_particles() const = 0;
  /// Checks against the scene the generator will run in, before step 0: `scene` holds the
  /// scenario's materials and walls, no particles. Problems go to `errors` with JSON pointers
  /// relative to the generator object (e.g. "/hi"). Default: none.
  virtual void validate(const State& scene, std::vector<Diagnostic>& errors) const {
    (void)scene;
    (void)errors;
  }
  /// Key figures of the generated packing (N, densities, coordination, overlaps, sampled sizes).
  virtual std::map<std::string, double> report(const State& s) const = 0;
  /// Coordination histogram (index = contacts) of the packing.
  virtual std::vector<int> coordination_histogram(const State& s) const {
    (void)s;
    return {};
  }
  /// Further named arrays of the packing (histograms, profiles) for summary.json.
  virtual std::map<std::string, std::vector<double>> report_arrays(const State& s) const {
    (void)s;
    return {};
  }
};

}  // namespace sparkdem
