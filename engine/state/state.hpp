#pragma once
/// Everything that flows from one stage to the next and goes into a checkpoint.
#include <cmath>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "engine/core/archive.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "engine/state/bond_table.hpp"
#include "engine/state/contact_table.hpp"
#include "engine/state/particle_store.hpp"
#include "engine/state/wall_history.hpp"
#include "engine/walls/wall.hpp"

namespace sparkdem {

struct Material {
  std::string name;
  double density = 1000.0;  ///< [kg/m^3]
};

struct State {
  ParticleStore particles;
  ContactTable contacts;
  BondTable bonds;
  std::vector<Wall> walls;
  std::vector<Material> materials;
  VerletTracker verlet;
  std::vector<std::vector<Index>> wall_candidates;  ///< per wall: particles within r + skin at the last rebuild
  WallHistory wall_history;                         ///< the contact law's history of each wall's candidates
  Step step = 0;                                    ///< global step counter (all stages)
  double time = 0.0;                                ///< [s] = stage_t0 + (step - stage_step0) * dt (adaptive stages: stage_t0 + stage_elapsed)
  Step stage_step0 = 0;                             ///< step at the start of the current stage
  double stage_t0 = 0.0;                            ///< [s] time at the start of the current stage
  double stage_dt = 0.0;                            ///< [s] mechanical step of the current stage (adaptive: the current one)
  /// Adaptive stages (StageConfig::adaptive): the stage time so far [s] (time = stage_t0 +
  /// stage_elapsed) and the step's history, (stage step, dt) at the start and at each change.
  /// Empty in a fixed-step stage, and then absent from checkpoints.
  double stage_elapsed = 0.0;
  std::vector<double> dt_history;
  double stage_skin = 0.0;                          ///< [m] Verlet skin of the current stage
  double physical_time = 0.0;                       ///< [s] = stage_phys_t0 + time_scale * (step - stage_step0) * dt
  double stage_phys_t0 = 0.0;                       ///< [s] physical time at the start of the current stage
  double stage_time_scale = 1.0;                    ///< physical seconds per mechanical second in the current stage
  std::int64_t stage_index = 0;
  std::int64_t rebuilds = 0;
  bool bonds_active =
      false;  ///< the running stage has a bond law (set by Simulation::prepare)   ///< neighbour rebuilds so far (drives periodic sorting)
  std::mt19937_64 rng{12345};
  /// Scheduler bookkeeping that must survive a restart (event-trigger references: last run step,
  /// bond-table version, ...), keyed "trigger/<module>/<what>".
  std::map<std::string, double> marks;

  Wall* find_wall(const std::string& name) {
    for (auto& w : walls)
      if (w.name == name) return &w;
    return nullptr;
  }

  void visit(Archive& ar) {
    particles.visit(ar, "state/particles");
    contacts.visit(ar, "state/contacts");
    if (!ar.reading() || ar.has("state/bonds/id_i")) bonds.visit(ar, "state/bonds");
    std::vector<std::string> names;
    for (const auto& w : walls) names.push_back(w.name);
    std::string joined;
    for (const auto& n : names) joined += n + "\n";
    ar.visit("state/wall_names", joined);
    if (ar.reading()) {
      walls.clear();
      std::istringstream is(joined);
      for (std::string n; std::getline(is, n);) {
        if (n.empty() || n.find('/') != std::string::npos || find_wall(n) != nullptr)
          throw SetupError("checkpoint wall names are malformed: '" + n + "' is empty, holds a '/' or is repeated");
        walls.push_back(Wall{n, PlaneShape{}, {}, 0, 0, 0, Vec3::Zero(), 0});
      }
    }
    for (auto& w : walls) w.visit(ar, "state/walls/" + w.name);
    ar.visit("state/verlet/x0", verlet.x0());
    ar.visit("state/verlet/r0", verlet.r0());
    ar.visit("state/verlet/u0", verlet.u0());
    // Candidate lists exist only once a stage has built them; an empty set forces a rebuild.
    std::int64_t have = wall_candidates.size() == walls.size() ? 1 : 0;
    ar.visit("state/wall_candidates_valid", have);
    if (ar.reading()) wall_candidates.assign(have ? walls.size() : 0, {});
    if (have)
      for (std::size_t k = 0; k < walls.size(); ++k) {
        ar.visit("state/wall_candidates/" + walls[k].name, wall_candidates[k]);
        if (ar.reading())
          for (const Index i : wall_candidates[k])
            if (i < 0 || static_cast<std::size_t>(i) >= particles.size())
              throw SetupError("checkpoint wall candidates of '" + walls[k].name + "' name particle row " + std::to_string(i) + " of " +
                               std::to_string(particles.size()));
      }
    std::vector<std::string> wall_names;  // as read
    for (const auto& w : walls) wall_names.push_back(w.name);
    wall_history.visit(ar, wall_names);
    if (ar.reading() && have)
      for (std::size_t k = 0; k < walls.size(); ++k)
        if (!wall_history.aligned(k, wall_candidates[k]))
          throw SetupError("checkpoint wall history of '" + walls[k].name + "' does not hold one row per wall candidate");
    if (ar.reading() && (verlet.r0().size() != verlet.x0().size() || (!verlet.x0().empty() && verlet.x0().size() != particles.size())))
      throw SetupError("checkpoint Verlet reference has " + std::to_string(verlet.x0().size()) + " positions and " +
                       std::to_string(verlet.r0().size()) + " radii for " + std::to_string(particles.size()) + " particles");
    ar.visit("state/step", step);
    ar.visit("state/time", time);
    ar.visit("state/stage_step0", stage_step0);
    ar.visit("state/stage_t0", stage_t0);
    ar.visit("state/stage_dt", stage_dt);
    if (ar.reading() ? ar.has("state/adaptive/dt_history") : !dt_history.empty()) {
      ar.visit("state/adaptive/stage_elapsed", stage_elapsed);
      ar.visit("state/adaptive/dt_history", dt_history);
      if (ar.reading() && (dt_history.empty() || dt_history.size() % 2 != 0))
        throw SetupError("checkpoint adaptive step history holds " + std::to_string(dt_history.size()) + " values, expected (step, dt) pairs");
    } else if (ar.reading()) {
      stage_elapsed = 0.0;
      dt_history.clear();
    }
    ar.visit("state/stage_skin", stage_skin);
    ar.visit("state/stage_index", stage_index);
    if (!ar.reading() || ar.has("state/physical_time")) {
      ar.visit("state/physical_time", physical_time);
      ar.visit("state/stage_phys_t0", stage_phys_t0);
      ar.visit("state/stage_time_scale", stage_time_scale);
    }
    std::string mk;
    std::vector<double> mv;
    if (!ar.reading())
      for (const auto& [k, v] : marks) {
        mk += k + "\n";
        mv.push_back(v);
      }
    if (!ar.reading() || ar.has("state/marks/names")) {
      ar.visit("state/marks/names", mk);
      ar.visit("state/marks/values", mv);
    }
    if (ar.reading()) {
      marks.clear();
      std::istringstream ms(mk);
      std::size_t q = 0;
      for (std::string n; std::getline(ms, n) && q < mv.size();) marks[n] = mv[q++];
    }
    ar.visit("state/rebuilds", rebuilds);
    std::string rs;
    if (!ar.reading()) {
      std::ostringstream os;
      os << rng;
      rs = os.str();
    }
    ar.visit("state/rng", rs);
    if (ar.reading()) {
      std::istringstream is(rs);
      is >> rng;
      if (is.fail()) throw SetupError("checkpoint item 'state/rng' does not hold a random generator state");
      if (step < 0 || stage_step0 < 0 || stage_step0 > step)
        throw SetupError("checkpoint steps are inconsistent: step " + std::to_string(step) + ", stage started at step " +
                         std::to_string(stage_step0));
      if (!std::isfinite(time) || !std::isfinite(stage_t0) || !std::isfinite(stage_dt) || !(stage_dt >= 0.0) ||
          !std::isfinite(stage_skin) || !(stage_skin >= 0.0) || !std::isfinite(physical_time) || !std::isfinite(stage_phys_t0) ||
          !std::isfinite(stage_time_scale) || !(stage_time_scale > 0.0))
        throw SetupError("checkpoint clock values are invalid (non-finite time, negative step or skin, or time scale not > 0)");
      contacts.remap_after_permutation(particles.id);
      bonds.remap_after_permutation(particles.id);
    }
  }
};

}  // namespace sparkdem
