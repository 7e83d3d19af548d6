#include "engine/state/pair_transfer.hpp"

namespace sparkdem {

std::vector<std::size_t> bond_contacts(State& s, const std::vector<std::size_t>& contact_rows) {
  std::vector<std::size_t> out;
  const auto& p = s.particles;
  for (const std::size_t r : contact_rows) {
    if (s.bonds.intact_keys().count(s.contacts.key(r))) continue;
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

void break_bond(State& s, std::size_t r) {
  if (s.bonds.broken(r)) return;
  s.bonds.mark_broken(r, s.step);
  s.contacts.hand_over(s.bonds.key(r), s.bonds.handed_state(r));
  s.marks["neighbors_stale"] = 1.0;
}

}  // namespace sparkdem
