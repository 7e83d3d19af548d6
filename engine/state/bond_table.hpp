#pragma once
/// Bond table: pairs joined by a bond law (cohesive beam, sintered neck turned solid, ...),
/// independent of the neighbour list because a bond persists beyond the cut-off until it breaks.
/// Each row holds the pair (global ids, cached local indices), its reference geometry taken when
/// the bond was made, the bond law's named state columns and a broken flag. A broken row carries
/// no load and no current; it stays in the table (for the log and the counts) and no longer keeps
/// the pair out of the contact table.
#include <cstdint>
#include <limits>
#include <string>
#include <unordered_set>
#include <vector>

#include "engine/state/pair_rows.hpp"

namespace sparkdem {

/// Reference geometry of a bond at creation. Directions are stored in each particle's body
/// frame, so that the current bending and twisting follow from the particles' quaternions.
struct BondReference {
  double length0 = 0.0;         ///< centre distance at creation [m]
  Vec3 dir_i = Vec3::UnitX();   ///< unit vector i -> j at creation, in i's body frame
  Vec3 dir_j = -Vec3::UnitX();  ///< unit vector j -> i at creation, in j's body frame
  Vec3 perp_i = Vec3::UnitY();  ///< a unit vector normal to the axis at creation, in i's body frame
  Vec3 perp_j = Vec3::UnitY();  ///< the same world vector at creation, in j's body frame
};

/// Reference of a bond between particles at xi, xj with orientations qi, qj (body -> world).
BondReference make_bond_reference(const Vec3& xi, const Vec3& xj, const Quat& qi, const Quat& qj);

/// Failure mode of a bond broken by the bond_virial_failure module (not by its law).
inline constexpr std::int64_t kBreakModeHydrostatic = -1;
/// ... with its von Mises criterion.
inline constexpr std::int64_t kBreakModeVirialVonMises = -2;

/// The log entry of a broken bond.
struct BondBreakRecord {
  double time = std::numeric_limits<double>::quiet_NaN();                    ///< [s] at the end of the breaking step
  Vec3 position = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());  ///< midpoint of the centres [m]
  std::int64_t mode = 0;  ///< failure mode (1-based index into the bond law's failure_modes(); 0 unknown; kBreakModeHydrostatic)
};

class BondTable : public PairRows {
 public:
  /// Add an intact bond between local particles a and b (any order); the reference geometry is
  /// taken from the current positions and orientations. `handed` initialises same-named state
  /// columns (a contact's state when a contact turns into a bond). Returns the row.
  std::size_t add(Index a, Index b, const std::vector<Id>& ids, const std::vector<Vec3>& x, const std::vector<Quat>& q,
                  const HandedState& handed = {});

  const BondReference& reference(std::size_t r) const { return ref_[r]; }
  bool broken(std::size_t r) const { return broken_[r] != 0; }
  Step broken_step(std::size_t r) const { return broken_step_[r]; }
  /// Where and how row r broke (NaN time and position, mode 0 if not recorded).
  const BondBreakRecord& break_record(std::size_t r) const { return record_[r]; }
  /// Flag row r broken at `step` (idempotent), with the time, the bond's midpoint and the law's
  /// failure mode. The caller hands its state to the contact table.
  void mark_broken(std::size_t r, Step step, const BondBreakRecord& record = {});
  std::size_t intact_count() const;
  std::size_t broken_count() const { return size() - intact_count(); }

  /// Keys of intact bonds (for excluding them from the contact table); cached.
  const std::unordered_set<std::uint64_t>& intact_keys() const;
  /// Bumped whenever a bond is added or breaks (triggers, neighbour rebuilds).
  std::uint64_t version() const { return version_; }

  /// Rebuild the per-particle incidence if bonds were added since (call before a force pass).
  void prepare(std::size_t n_particles) {
    if (incidence_n_ != n_particles || dirty_) {
      reset_results(n_particles);
      incidence_n_ = n_particles;
      dirty_ = false;
    }
  }
  /// Drop every row (intact or broken) that involves a particle whose global id is in `gone`
  /// (particle deletion); returns the rows dropped. Local indices are stale until
  /// remap_after_permutation.
  std::size_t erase_particles(const std::unordered_set<Id>& gone);

  /// Named state of row r (for handing over to the contact table).
  HandedState handed_state(std::size_t r) const;

  /// How bonded pairs combine with the ordinary contact law.
  enum class ContactRule { Exclude, Add };
  ContactRule contact_rule = ContactRule::Exclude;

  void visit(Archive& ar, const std::string& prefix);

 private:
  std::vector<BondReference> ref_;
  std::vector<std::uint8_t> broken_;
  std::vector<Step> broken_step_;
  std::vector<BondBreakRecord> record_;
  std::uint64_t version_ = 0;
  mutable std::uint64_t keys_version_ = ~std::uint64_t{0};
  mutable std::unordered_set<std::uint64_t> keys_;
  std::size_t incidence_n_ = 0;
  bool dirty_ = true;
};

}  // namespace sparkdem
