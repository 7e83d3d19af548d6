#pragma once
/// Contact table: the candidate pairs of the Verlet list (distance < r_i + r_j + skin), plus
/// pairs whose law keeps them alive beyond it (a sintered neck outlives zero or negative overlap),
/// minus pairs that are bonded (unless the scenario combines bonds and contacts). Rows are keyed by
/// global ids; history_transfer (rebuild) carries each row's law state over by key, the role of
/// LAMMPS FixNeighHistory. See PairRows for the deterministic per-row force gather.
#include <array>
#include <functional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "engine/state/pair_rows.hpp"

namespace sparkdem {

/// What a contact-table rebuild needs besides the candidate pairs.
struct ContactRebuildRules {
  /// Pairs never to hold as contacts (intact bonds, when bonds exclude contacts).
  const std::unordered_set<std::uint64_t>* excluded = nullptr;
  /// For laws with persistent pairs: true if the row's state keeps the pair alive although it
  /// is no longer a neighbour candidate. Empty = pairs live only while they are candidates.
  std::function<bool(const double* state)> alive;
};

class ContactTable : public PairRows {
 public:
  std::vector<double>& overlap() { return overlap_; }  ///< r_i + r_j - d [m] (negative = gap)
  const std::vector<double>& overlap() const { return overlap_; }

  /// Replace the rows by the new candidate pairs (local indices) and carry state over from the
  /// old rows with the same global-id key; rows kept alive by their law are appended (old order);
  /// state handed over by a broken bond (hand_over) initialises a new row with that key.
  void rebuild(const std::vector<std::array<Index, 2>>& pairs, const std::vector<Id>& ids, std::size_t n_particles,
               const ContactRebuildRules& rules = {});

  /// State for the row of this pair at the next rebuild (same-named columns are copied). Pending
  /// hand-overs are dropped at that rebuild whether or not the pair is a candidate then.
  void hand_over(std::uint64_t key, HandedState st) { pending_[key] = std::move(st); }
  bool has_pending_hand_over() const { return !pending_.empty(); }

  /// Drop every row and pending hand-over that involves a particle whose global id is in `gone`
  /// (particle deletion); returns the rows dropped. Local indices are stale until
  /// remap_after_permutation.
  std::size_t erase_particles(const std::unordered_set<Id>& gone);

  /// Store/restore rows (ids, local indices, state, overlaps, pending hand-overs).
  void visit(Archive& ar, const std::string& prefix);

 private:
  std::vector<double> overlap_;
  std::unordered_map<std::uint64_t, HandedState> pending_;
};

}  // namespace sparkdem
