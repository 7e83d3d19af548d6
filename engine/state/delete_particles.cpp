#include "engine/state/delete_particles.hpp"

#include <unordered_set>

#include "engine/core/error.hpp"

namespace sparkdem {

DeletionCounts delete_particles(State& s, const std::vector<bool>& remove) {
  auto& p = s.particles;
  if (remove.size() != p.size())
    throw SetupError("delete_particles: the mask has " + std::to_string(remove.size()) + " entries for " + std::to_string(p.size()) +
                     " particles");
  DeletionCounts out;
  std::unordered_set<Id> gone;
  std::vector<bool> keep(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    keep[i] = !remove[i];
    if (remove[i]) gone.insert(p.id[i]);
  }
  out.particles = gone.size();
  if (gone.empty()) return out;
  p.filter(keep);
  out.contacts = s.contacts.erase_particles(gone);
  out.bonds = s.bonds.erase_particles(gone);
  s.contacts.remap_after_permutation(p.id);
  s.bonds.remap_after_permutation(p.id);
  // Neighbour state: the Verlet reference and the wall candidates hold local indices / one entry
  // per particle; both are invalid now. An empty reference and candidate set force a rebuild.
  s.verlet.mark_built({}, {}, {});
  s.wall_candidates.clear();
  s.marks["neighbors_stale"] = 1.0;
  return out;
}

}  // namespace sparkdem
