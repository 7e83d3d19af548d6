#pragma once
/// PairRows: the part shared by the contact table and the bond table. Rows are particle pairs
/// keyed by global ids with id_i < id_j, so that per-row state keeps its meaning across neighbour
/// rebuilds and particle reorderings. Laws declare named per-row state columns.
///
/// Forces are computed per row into per-row arrays (force on i, torques on i and j) and then
/// gathered per particle in a fixed order through a CSR incidence list. No two threads ever
/// write the same memory, and the summation order does not depend on the thread count, so
/// results are bit-identical for any number of threads.
#include <cstdint>
#include <string>
#include <functional>
#include <vector>

#include "engine/core/archive.hpp"
#include "engine/core/types.hpp"

namespace sparkdem {

/// 64-bit key of an unordered pair of global ids (id_i < id_j).
inline std::uint64_t pair_key(Id a, Id b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) ^ static_cast<std::uint64_t>(b);
}

/// Per-particle incidence (CSR) of rows r = 0..rows-1 joining particles end_i(r) and end_j(r):
/// the rows touching particle p are row[start[p] .. start[p+1]) in increasing r, coded r for
/// side i and ~r for side j. Summing per-row values per particle in this order reproduces the
/// serial loop over rows exactly, whatever the thread count.
template <class EndI, class EndJ>
void build_incidence(std::size_t n, std::size_t rows, EndI end_i, EndJ end_j, std::vector<std::int64_t>& start,
                     std::vector<std::int64_t>& row) {
  start.assign(n + 1, 0);
  for (std::size_t r = 0; r < rows; ++r) {
    ++start[end_i(r) + 1];
    ++start[end_j(r) + 1];
  }
  for (std::size_t p = 0; p < n; ++p) start[p + 1] += start[p];
  row.assign(start[n], 0);
  std::vector<std::int64_t> fill(start.begin(), start.end() - 1);
  for (std::size_t r = 0; r < rows; ++r) {
    row[fill[end_i(r)]++] = static_cast<std::int64_t>(r);
    row[fill[end_j(r)]++] = ~static_cast<std::int64_t>(r);
  }
}

class PairRows {
 public:
  /// Names of the per-row state columns (set once by the active law); clears the state.
  void set_state_columns(std::vector<std::string> names) {
    state_names_ = std::move(names);
    state_.assign(size() * state_names_.size(), 0.0);
  }
  const std::vector<std::string>& state_columns() const { return state_names_; }
  int state_width() const { return static_cast<int>(state_names_.size()); }
  /// Index of a state column, or -1.
  int column(const std::string& name) const;

  std::size_t size() const { return i_.size(); }
  Index i(std::size_t r) const { return i_[r]; }
  Index j(std::size_t r) const { return j_[r]; }
  const std::vector<Index>& i_list() const { return i_; }
  const std::vector<Index>& j_list() const { return j_; }
  const std::vector<Id>& id_i() const { return id_i_; }
  const std::vector<Id>& id_j() const { return id_j_; }
  std::uint64_t key(std::size_t r) const { return pair_key(id_i_[r], id_j_[r]); }
  double* state(std::size_t r) { return state_.data() + r * state_names_.size(); }
  const double* state(std::size_t r) const { return state_.data() + r * state_names_.size(); }
  std::vector<double>& state_data() { return state_; }
  const std::vector<double>& state_data() const { return state_; }

  // Per-row results of the last force pass.
  std::vector<Vec3>& force() { return force_; }        ///< force on i (j gets minus) [N]
  /// Torques on i and j [N m], sized (zeroed) on first use after the rows changed: the one-thread
  /// contact pass adds every row straight into its particles and never fills them (4 MB a
  /// 85,000-row table kept free). A pass that fills them asks for them before it starts.
  std::vector<Vec3>& torque_i() {
    if (torque_i_.size() != size()) torque_i_.assign(size(), Vec3::Zero());
    return torque_i_;
  }
  std::vector<Vec3>& torque_j() {
    if (torque_j_.size() != size()) torque_j_.assign(size(), Vec3::Zero());
    return torque_j_;
  }
  const std::vector<Vec3>& force() const { return force_; }

  /// Recompute local indices after the particles were permuted (`ids` maps local -> global).
  void remap_after_permutation(const std::vector<Id>& ids);

  /// Per-particle incidence (CSR): rows touching particle p; code >= 0: side i, ~row: side j.
  /// Built on first use after the rows changed (the one-thread contact pass never needs it).
  const std::vector<std::int64_t>& incidence_start() const {
    ensure_incidence();
    return inc_start_;
  }
  const std::vector<std::int64_t>& incidence_row() const {
    ensure_incidence();
    return inc_row_;
  }

  /// Sum per-row forces/torques into particle arrays (adds to force/torque).
  void gather(std::vector<Vec3>& force, std::vector<Vec3>& torque) const;

  /// The rows dealt to `threads` contiguous ranges, range t = [row_begin[t], row_begin[t + 1]),
  /// cut where the rows' summed cost reaches t / T of the whole (`heavy` rows, those the caller
  /// expects to compute a force, cost kHeavyRowCost, the others 1; without `heavy`, row_begin[t] =
  /// rows t / T), and
  /// per particle the range holding every row that touches it (`owner`, -1 when rows of two ranges
  /// touch it or none does); `boundary`: the particles touched by rows of two ranges. A thread that
  /// walks its range in row order may add its rows straight into the particles it owns: each sum
  /// takes the same operands in the same order as the gather, whatever the thread count.
  struct RowSplit {
    int threads = 0;
    double heavy_cost = 0.0;  ///< the heavy-row cost it was cut with
    std::vector<std::int64_t> row_begin;
    std::vector<std::int32_t> owner;
    std::vector<Index> boundary;
  };
  /// The split for `threads` ranges (computed from the incidence, kept until it changes; `heavy`
  /// is asked only then, once per row).
  const RowSplit& row_split(int threads, const std::function<bool(std::int64_t)>& heavy = {}, double heavy_cost = kHeavyRowCost) const;
  /// The cost of a row in contact relative to one out of contact in a pair pass: a row out of
  /// contact is a distance test and its state cleared, one in contact runs the law (square roots,
  /// divisions, the history). A settled pile's rows are nearly all in contact and a falling
  /// cloud's nearly none, so a pour split by row count gave the pile's thread most of the work.
  static constexpr double kHeavyRowCost = 4.0;
  /// The same ratio when the law runs over SIMD lanes (ContactModelT::lane_rows), where a row out
  /// of contact is a distance in a vector loop and its state cleared, and only the live rows, packed,
  /// run the law: 7.4, measured on a simple-cubic lattice (10,000 spheres, 28,600 rows, AVX-512, one
  /// thread, 3,000 steps, perf's share of the pair pass): 19.9 ns a row with every row in contact,
  /// 2.7 ns with none (spheres shrunk by 4 %, rows kept by the skin). Before the live rows were
  /// packed (every row ran the law, masked) it was 1.33 (16.2 and 12.2 ns on the dense-bed lattice).
  static constexpr double kLaneLiveRowCost = 7.4;
  /// gather for the listed particles only.
  void gather_particles(const std::vector<Index>& which, std::vector<Vec3>& force, std::vector<Vec3>& torque) const;

  /// Rows r with keep[r] == 0 removed (order of the others preserved): ids, cached local indices,
  /// state and per-row results. The local indices are stale until remap_after_permutation.
  void keep_rows(const std::vector<char>& keep);

 protected:
  /// Copy same-named columns of `from` (names `from_names`) into row r; others keep their value.
  void copy_named_state(std::size_t r, const std::vector<std::string>& from_names, const double* from);
  /// Resize the force rows to the row count (zeroed), free the torque rows (sized again by the
  /// pass that fills them: torque_i(), torque_j()) and mark the incidence due (build_incidence).
  void reset_results(std::size_t n_particles);
  /// The incidence is due for n_particles particles: built by its first use (ensure_incidence).
  void build_incidence(std::size_t n_particles);
  void ensure_incidence() const;
  /// The incidence sum of particle p, in increasing row order, added to force[p] and torque[p].
  void gather_one(std::int64_t p, std::vector<Vec3>& force, std::vector<Vec3>& torque) const;
  /// Rows (ids, local indices) and state with their column names.
  void visit_rows(Archive& ar, const std::string& prefix, const std::string& what);

  std::vector<Index> i_, j_;
  std::vector<Id> id_i_, id_j_;
  std::vector<std::string> state_names_;
  std::vector<double> state_;
  std::vector<Vec3> force_, torque_i_, torque_j_;
  mutable std::vector<std::int64_t> inc_start_, inc_row_;
  std::size_t inc_particles_ = 0;   ///< the particle count the incidence is due for
  mutable bool inc_built_ = false;  ///< inc_start_ and inc_row_ hold it
  mutable RowSplit split_;  ///< cache of row_split (threads = 0: stale)
};

/// Named per-row values handed from one table to another (contact -> bond on bonding,
/// bond -> contact on breaking): same-named columns are carried over, others start at zero.
struct HandedState {
  std::vector<std::string> names;
  std::vector<double> values;
};

}  // namespace sparkdem
