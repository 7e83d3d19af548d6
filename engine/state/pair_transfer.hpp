#pragma once
#include <limits>
/// Turning a contact into a bond and a bond back into a contact, with the pair's state handed
/// over: columns of the same name are carried (e.g. "neck_radius"), others start at zero. These
/// are the only two functions that move a pair between the tables; both mark the neighbour
/// lists stale so the contact table is rebuilt (bonded pairs excluded or readmitted) at the next
/// step's neighbour phase.
#include <cstddef>
#include <vector>

#include "engine/state/state.hpp"

namespace sparkdem {

/// Bond the pairs of the given contact-table rows (reference geometry = current geometry).
/// Returns the new bond rows. Rows of pairs already bonded (intact) are skipped.
std::vector<std::size_t> bond_contacts(State& s, const std::vector<std::size_t>& contact_rows);

/// Bond local particles a and b (no contact state to hand over); returns the bond row.
std::size_t bond_particles(State& s, Index a, Index b);

/// Bond every pair whose gap r_i + r_j - d >= -gap_tolerance and that is not bonded yet, in
/// the deterministic order of the neighbour search. Returns the number of new bonds.
std::size_t bond_within_gap(State& s, double gap_tolerance);

/// Mark bond row r broken at `step` (ending at `time` [s]; mode from the bond law, 0 unknown),
/// log its midpoint, and hand its state to the contact table.
void break_bond(State& s, std::size_t r, Step step, double time = std::numeric_limits<double>::quiet_NaN(), std::int64_t mode = 0);

}  // namespace sparkdem
