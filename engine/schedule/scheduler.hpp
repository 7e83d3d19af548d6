#pragma once
/// The step plan: the ONE place that lists the sequence of a step. Built once per stage from
/// the active modules' declarations; the simulation executes it item by item.
///
///   1 integrate_first_half   half kick + drift (translation and rotation); clears the forces and
///                            torques after the kick, their last read (nothing in 2-3 reads them)
///   2 walls                  prescribed wall offsets at the new time; servo walls integrate
///   3 neighbors              Verlet check; rebuild + history transfer when due
///   4 contact_pairs          the law's pair pass + per-particle gather
///   4b bonds                 the bond law's pass + gather; broken bonds hand their state to the
///                            contact table (only when the scenario has a bond law)
///   5 contact_walls          the law's wall pass
///   6 <force modules>        e.g. gravity, background damping (declaration order)
///   7 integrate_second_half  half kick
///   8 <coupling modules>     after the mechanics, ordered by reads/writes (writer before reader),
///                            each on its own clock (every N steps, k substeps per step, adaptive
///                            substeps from its stable step, or on an event)
///
/// A quasi-static stage (StageConfig::quasi_static, engine/integrate/quasi_static.hpp) replaces
/// items 1-7 by one item, quasi_static_step, whose substeps (as many as max_strain_increment asks)
/// each run, in this order:
///   a neighbors             Verlet check, as item 3
///   b solve                 the contacts' affine forces (ContactModel::linear_rows) and the
///                           balance of every particle and force-controlled wall -> velocities,
///                           spins, punch rates
///   c zero_forces + contact_pairs   the law's pair pass with the solved motion (the histories
///                           advance over the substep; the forces are those at its end)
///   d drift                 positions and orientations by the solved motion; walls to the
///                           substep's end (punches at their solved rate)
///   e contact_walls         the law's wall pass at the new positions
/// and then item 8 as above. No force modules and no bonds (a SetupError).
#include <string>
#include <vector>

#include "engine/model/module.hpp"

namespace sparkdem {

struct PlanItem {
  enum class Kind { IntegrateFirstHalf, Walls, Neighbors, ContactPairs, Bonds, ContactWalls, Module, IntegrateSecondHalf, QuasiStatic };
  Kind kind;
  std::string name;
  Module* module = nullptr;  ///< for Kind::Module
  Clock clock;
};

struct StepPlan {
  std::vector<PlanItem> items;
  std::vector<std::string> names() const {
    std::vector<std::string> n;
    for (const auto& i : items) n.push_back(i.name);
    return n;
  }
};

/// Build the plan; throws SetupError on a dependency cycle, a dangling read or a clock that is
/// not a positive integer.
/// `core_fields` are fields always present (position, velocity, ...).
/// `bonds`: the scenario has a bond law (adds the bond pass).
/// `mechanics` false: a frozen stage (items 1-7 left out; the particles keep their positions and
/// the contact table of the stage start; only coupling modules run, e.g. a conduction run on a
/// fixed packing). A force module in a frozen stage is a SetupError.
/// `quasi_static`: items 1-7 are the one quasi_static_step item (a force module or bonds: SetupError).
StepPlan build_step_plan(const std::vector<Module*>& modules, const std::vector<std::string>& core_fields, bool bonds = false,
                         bool mechanics = true, bool quasi_static = false);

}  // namespace sparkdem
