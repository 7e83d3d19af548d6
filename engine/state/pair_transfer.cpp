#include "engine/state/pair_transfer.hpp"

#include <unordered_set>

#include "engine/neighbor/neighbor_search.hpp"

namespace sparkdem {

std::vector<std::size_t> bond_contacts(State& s, const std::vector<std::size_t>& contact_rows) {
  std::vector<std::size_t> out;
  const auto& p = s.particles;
  // A copy: every add() invalidates the table's cached key set, and rebuilding it per bond made
  // bonding N pairs O(N^2) (1e5 lattice bonds took minutes).
  std::unordered_set<std::uint64_t> bonded = s.bonds.intact_keys();
  for (const std::size_t r : contact_rows) {
    if (!bonded.insert(s.contacts.key(r)).second) continue;
    HandedState h;
    h.names = s.contacts.state_columns();
    h.values.assign(s.contacts.state(r), s.contacts.state(r) + s.contacts.state_width());
    out.push_back(s.bonds.add(s.contacts.i(r), s.contacts.j(r), p.id, p.position, p.orientation, h));
  }
  if (!out.empty()) s.marks["neighbors_stale"] = 1.0;
  return out;
}

std::size_t bond_particles(State& s, Index a, Index b) {
  const auto& p = s.particles;
  const std::size_t r = s.bonds.add(a, b, p.id, p.position, p.orientation);
  s.marks["neighbors_stale"] = 1.0;
  return r;
}

std::size_t bond_within_gap(State& s, double gap_tolerance) {
  const auto& p = s.particles;
  std::size_t made = 0;
  std::unordered_set<std::uint64_t> bonded = s.bonds.intact_keys();  // a copy (see bond_contacts)
  for (const auto& pr : find_pairs(p.position, p.radius, gap_tolerance)) {
    const Index a = pr[0], b = pr[1];
    if (bonded.count(pair_key(p.id[a], p.id[b]))) continue;
    if ((p.position[a] - p.position[b]).norm() - p.radius[a] - p.radius[b] > gap_tolerance) continue;
    bonded.insert(pair_key(p.id[a], p.id[b]));
    s.bonds.add(a, b, p.id, p.position, p.orientation);
    ++made;
  }
  if (made) s.marks["neighbors_stale"] = 1.0;
  return made;
}

void break_bond(State& s, std::size_t r, Step step, double time, std::int64_t mode) {
  if (s.bonds.broken(r)) return;
  const auto& x = s.particles.position;
  s.bonds.mark_broken(r, step, {time, 0.5 * (x[s.bonds.i(r)] + x[s.bonds.j(r)]), mode});
  s.contacts.hand_over(s.bonds.key(r), s.bonds.handed_state(r));
  s.marks["neighbors_stale"] = 1.0;
}

}  // namespace sparkdem
