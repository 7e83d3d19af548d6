#pragma once
/// Particle deletion (the role of LAMMPS `delete_atoms region`): remove particles from the state
/// and keep every table that refers to them consistent.
#include <cstddef>
#include <vector>

#include "engine/state/state.hpp"

namespace sparkdem {

struct DeletionCounts {
  std::size_t particles = 0;  ///< particles removed
  std::size_t contacts = 0;   ///< contact rows removed (rows with a removed particle)
  std::size_t bonds = 0;      ///< bond rows removed, intact or broken
};

/// Remove the particles i with remove[i] true (remove.size() == particle count; the order of the
/// others is kept). Every per-particle array and field is compacted (ParticleStore::filter), the
/// contact and bond rows (and pending contact hand-overs) that involve a removed particle are
/// dropped, the local indices of the remaining rows are remapped, and the neighbour list and the
/// wall candidate lists are marked stale so that the next neighbour update rebuilds them (the
/// contact history of the surviving pairs carries over by global id). Throws SetupError if
/// `remove` has the wrong size.
DeletionCounts delete_particles(State& s, const std::vector<bool>& remove);

}  // namespace sparkdem
