#pragma once
/// Contact table: every candidate pair of the Verlet list (distance < r_i + r_j + skin), in SoA
/// form, keyed by global ids with id_i < id_j so that per-contact state keeps its meaning across
/// rebuilds and particle reorderings. Laws declare their state columns; history_transfer carries
/// them over on every rebuild (the role of LAMMPS FixNeighHistory).
///
/// Forces are computed per row into per-row arrays (force on i, torques on i and j) and then
/// gathered per particle in a fixed order. No two threads ever write the same memory, and the
/// summation order does not depend on the thread count, so results are bit-identical for any
/// number of threads.
#include <array>
#include <string>
#include <unordered_map>
#include <vector>

#include "engine/core/archive.hpp"
#include "engine/core/types.hpp"

namespace sparkdem {

class ContactTable {
 public:
  /// Names of the per-contact state columns (set once by the active contact law).
  void set_state_columns(std::vector<std::string> names) {
    state_names_ = std::move(names);
    state_.assign(size() * state_names_.size(), 0.0);
  }
  const std::vector<std::string>& state_columns() const { return state_names_; }
  int state_width() const { return static_cast<int>(state_names_.size()); }

  std::size_t size() const { return i_.size(); }
  Index i(std::size_t r) const { return i_[r]; }
  Index j(std::size_t r) const { return j_[r]; }
  const std::vector<Index>& i_list() const { return i_; }
  const std::vector<Index>& j_list() const { return j_; }
  const std::vector<Id>& id_i() const { return id_i_; }
  const std::vector<Id>& id_j() const { return id_j_; }
  double* state(std::size_t r) { return state_.data() + r * state_names_.size(); }
  std::vector<double>& state_data() { return state_; }

  // Per-row results of the last force pass.
  std::vector<Vec3>& force() { return force_; }       ///< force on i (j gets minus) [N]
  std::vector<Vec3>& torque_i() { return torque_i_; }  ///< [N m]
  std::vector<Vec3>& torque_j() { return torque_j_; }  ///< [N m]
  std::vector<double>& overlap() { return overlap_; }  ///< r_i + r_j - d [m] (negative = gap)
  const std::vector<Vec3>& force() const { return force_; }
  const std::vector<double>& overlap() const { return overlap_; }

  /// Replace the rows by new candidate pairs (local indices) and carry state over from the
  /// old rows with the same global-id key. `ids` maps local index -> global id.
  void rebuild(const std::vector<std::array<Index, 2>>& pairs, const std::vector<Id>& ids, std::size_t n_particles);

  /// Recompute local indices after the particles were permuted (new[k] = old[perm[k]]).
  void remap_after_permutation(const std::vector<Id>& ids);

  /// Per-particle incidence (CSR): rows touching particle p and whether p is side i.
  const std::vector<std::int64_t>& incidence_start() const { return inc_start_; }
  const std::vector<std::int64_t>& incidence_row() const { return inc_row_; }

  /// Sum per-row forces/torques into particle arrays (adds to force/torque).
  void gather(std::vector<Vec3>& force, std::vector<Vec3>& torque) const;

  /// Store/restore rows (ids, local indices, state) in the exact order.
  void visit(Archive& ar, const std::string& prefix);

 private:
  void build_incidence(std::size_t n_particles);
  std::vector<Index> i_, j_;
  std::vector<Id> id_i_, id_j_;
  std::vector<std::string> state_names_;
  std::vector<double> state_;
  std::vector<Vec3> force_, torque_i_, torque_j_;
  std::vector<double> overlap_;
  std::vector<std::int64_t> inc_start_, inc_row_;  // inc_row_ >= 0: side i; encoded ~row for side j
};

}  // namespace sparkdem
