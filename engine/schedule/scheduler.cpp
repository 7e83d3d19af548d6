#include "engine/schedule/scheduler.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include "engine/core/error.hpp"

namespace sparkdem {

StepPlan build_step_plan(const std::vector<Module*>& modules, const std::vector<std::string>& core_fields, bool bonds, bool mechanics,
                         bool quasi_static) {
  using K = PlanItem::Kind;
  StepPlan plan;
  quasi_static = quasi_static && mechanics;
  if (quasi_static && bonds)
    throw SetupError("a quasi-static stage has no bond pass: the scenario's bond law has no inertia-free form (run the stage explicit)");
  if (quasi_static) {
    plan.items.push_back({K::QuasiStatic, "quasi_static_step", nullptr, {}});
  } else if (mechanics) {
    plan.items.push_back({K::IntegrateFirstHalf, "integrate_first_half", nullptr, {}});
    plan.items.push_back({K::Walls, "walls", nullptr, {}});
    plan.items.push_back({K::Neighbors, "neighbors", nullptr, {}});
    plan.items.push_back({K::ContactPairs, "contact_pairs", nullptr, {}});
    if (bonds) plan.items.push_back({K::Bonds, "bonds", nullptr, {}});
    plan.items.push_back({K::ContactWalls, "contact_walls", nullptr, {}});
  }

  std::set<std::string> available(core_fields.begin(), core_fields.end());
  std::vector<Module*> coupling;
  for (Module* m : modules) {
    const Clock c = m->effective_clock();
    if (c.n < 1) throw SetupError("module '" + m->name() + "': clock ratio must be a positive integer, found " + std::to_string(c.n));
    if (c.kind == Clock::Kind::OnEvent) {
      const Trigger& t = c.trigger;
      const bool any = std::isfinite(t.moved_beyond) || (!t.field.empty() && std::isfinite(t.field_change)) || t.bond_broke ||
                       t.max_interval > 0;
      if (!any) throw SetupError("module '" + m->name() + "': its event clock has no condition that can fire");
      if (!(t.moved_beyond > 0.0) || !(t.field_change > 0.0) || t.max_interval < 0)
        throw SetupError("module '" + m->name() + "': event thresholds must be positive");
    }
    Declarations d;
    m->declare(d);
    for (const auto& f : d.particle_fields) available.insert(f.name);
    for (const auto& w : d.writes) available.insert(w);
    if (m->phase() == Phase::Force && !mechanics)
      throw SetupError("module '" + m->name() + "' adds forces, but the stage's mechanics are frozen (\"mechanics\": \"frozen\")");
    if (m->phase() == Phase::Force && quasi_static)
      throw SetupError("module '" + m->name() + "' adds forces, which a quasi-static stage does not take (run the stage explicit)");
    if (m->phase() == Phase::Force && c.kind != Clock::Kind::EveryStep)
      throw SetupError("module '" + m->name() + "' adds forces, so it must run every mechanical step (its clock is not EveryStep)");
    if (m->phase() == Phase::Force)
      plan.items.push_back({K::Module, m->name(), m, c});
    else
      coupling.push_back(m);
  }
  // Dangling reads.
  for (Module* m : modules) {
    Declarations d;
    m->declare(d);
    std::vector<std::string> all_reads = d.reads;
    all_reads.insert(all_reads.end(), d.reads_previous.begin(), d.reads_previous.end());
    for (const auto& r : all_reads)
      if (!available.count(r))
        throw SetupError("module '" + m->name() + "' reads '" + r + "', which no active module or the core provides");
    const Clock c = m->effective_clock();
    if (c.kind == Clock::Kind::OnEvent && !c.trigger.field.empty() && !available.count(c.trigger.field))
      throw SetupError("module '" + m->name() + "' is triggered by changes of '" + c.trigger.field +
                       "', which no active module or the core provides");
  }
  if (mechanics && !quasi_static) plan.items.push_back({K::IntegrateSecondHalf, "integrate_second_half", nullptr, {}});
  // Coupling modules: topological order, writers before readers; ties keep declaration order.
  std::vector<Module*> ordered;
  std::vector<bool> placed(coupling.size(), false);
  for (std::size_t round = 0; round < coupling.size(); ++round) {
    bool progress = false;
    for (std::size_t a = 0; a < coupling.size(); ++a) {
      if (placed[a]) continue;
      Declarations da;
      coupling[a]->declare(da);
      bool blocked = false;
      for (std::size_t b = 0; b < coupling.size() && !blocked; ++b) {
        if (b == a || placed[b]) continue;
        Declarations db;
        coupling[b]->declare(db);
        for (const auto& r : da.reads)
          if (std::find(db.writes.begin(), db.writes.end(), r) != db.writes.end()) blocked = true;
      }
      if (!blocked) {
        ordered.push_back(coupling[a]);
        placed[a] = true;
        progress = true;
        break;
      }
    }
    if (!progress)
      throw SetupError(
          "coupling modules form a read/write cycle; declare one of the reads as reads_previous (the value of the previous step)");
  }
  for (Module* m : ordered) plan.items.push_back({K::Module, m->name(), m, m->effective_clock()});
  return plan;
}

}  // namespace sparkdem
