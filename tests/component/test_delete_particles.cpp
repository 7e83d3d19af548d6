/// Particle deletion (delete_particles, the engine side of a stage's "delete_sets"): the particle
/// arrays, fields, contact and bond tables stay consistent, and the contact history of the
/// surviving pairs carries over the next neighbour rebuild.
#include <catch2/catch.hpp>

#include <set>

#include "engine/neighbor/neighbor_search.hpp"
#include "engine/state/delete_particles.hpp"
#include "engine/state/particle_set.hpp"
#include "support/scene.hpp"

namespace test_delete_particles {

using namespace sparkdem;

namespace {
/// 5 x 5 x 5 simple-cubic lattice of spheres r = 1 mm at spacing 1.99 mm (every nearest-neighbour
/// pair overlaps by 10 um), contact rows from find_pairs with one state column "tag" = key-derived
/// value, and a bond on every x-direction neighbour pair.
State lattice() {
  State s;
  const double r = 1e-3, a = 1.99e-3;
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 5; ++i) test::add_sphere(s, Vec3(i * a, j * a, k * a), r, 7900.0);
  auto& p = s.particles;
  p.fields.declare({"tag", 1, "1", 0.0, false}, p.size());
  for (std::size_t i = 0; i < p.size(); ++i) p.fields.data("tag")[i] = static_cast<double>(p.id[i]);
  s.contacts.set_state_columns({"tag"});
  s.contacts.rebuild(find_pairs(p.position, p.radius, 0.0), p.id, p.size());
  for (std::size_t r2 = 0; r2 < s.contacts.size(); ++r2)
    s.contacts.state(r2)[0] = static_cast<double>(s.contacts.id_i()[r2] * 1000 + s.contacts.id_j()[r2]);
  s.bonds.set_state_columns({"tag"});
  for (std::size_t r2 = 0; r2 < s.contacts.size(); ++r2) {
    const Index a2 = s.contacts.i(r2), b2 = s.contacts.j(r2);
    if (std::abs(p.position[a2].x() - p.position[b2].x()) > 1e-3) {
      const std::size_t row = s.bonds.add(a2, b2, p.id, p.position, p.orientation);
      s.bonds.state(row)[0] = static_cast<double>(s.bonds.id_i()[row] * 1000 + s.bonds.id_j()[row]);
    }
  }
  s.bonds.mark_broken(0, 7);  // one broken row: it goes too if it touches a deleted particle
  return s;
}

/// Every row's cached local indices point at the particles with its global ids, no row touches
/// a deleted id, the state column still holds the row's own tag, and the incidence lists cover
/// every row twice.
void check_rows(const PairRows& t, const ParticleStore& p, const std::set<Id>& gone) {
  for (std::size_t r = 0; r < t.size(); ++r) {
    CHECK(p.id[t.i(r)] == t.id_i()[r]);
    CHECK(p.id[t.j(r)] == t.id_j()[r]);
    CHECK(gone.count(t.id_i()[r]) == 0);
    CHECK(gone.count(t.id_j()[r]) == 0);
    CHECK(t.state(r)[0] == static_cast<double>(t.id_i()[r] * 1000 + t.id_j()[r]));
  }
  REQUIRE(t.incidence_start().size() == p.size() + 1);
  CHECK(t.incidence_start().back() == static_cast<std::int64_t>(2 * t.size()));
}
}  // namespace

TEST_CASE("deleting particles keeps the particle, contact and bond tables consistent", "[delete][sets]") {
  State s = lattice();
  const std::size_t n0 = s.particles.size(), c0 = s.contacts.size(), b0 = s.bonds.size();
  REQUIRE(n0 == 125);
  REQUIRE(c0 == 300);  // 3 directions x 5 x 5 x 4 nearest-neighbour pairs (diagonals are 2.8 mm apart)
  REQUIRE(b0 == 100);
  // Delete the middle x-plane (i = 2) with a box selector, as a stage's delete_sets does.
  SetSelector box;
  box.kind = SetSelector::Kind::Box;
  box.lo = Vec3(3e-3, -1.0, -1.0);
  box.hi = Vec3(5e-3, 1.0, 1.0);
  const auto members = select_particles(s, box);
  REQUIRE(members.size() == 25);
  std::vector<bool> remove(n0, false);
  std::set<Id> gone;
  for (Index i : members) {
    remove[i] = true;
    gone.insert(s.particles.id[i]);
  }
  // Rows expected to go: those with an end in the plane. Contacts: 25 in-plane pairs x 2 in-plane
  // directions = 40 within the plane + 2 x 25 to the neighbouring planes = 90; bonds (x pairs):
  // 2 x 25 = 50.
  const DeletionCounts c = delete_particles(s, remove);
  CHECK(c.particles == 25);
  CHECK(c.contacts == 90);
  CHECK(c.bonds == 50);
  const auto& p = s.particles;
  REQUIRE(p.size() == 100);
  CHECK(s.contacts.size() == c0 - 90);
  CHECK(s.contacts.overlap().size() == s.contacts.size());
  CHECK(s.bonds.size() == b0 - 50);
  // Every per-particle array and field followed the compaction.
  for (std::size_t i = 0; i < p.size(); ++i) {
    CHECK(gone.count(p.id[i]) == 0);
    CHECK(p.fields.data("tag")[i] == static_cast<double>(p.id[i]));
    CHECK(!(p.position[i].x() > 3e-3 && p.position[i].x() < 5e-3));
    CHECK(p.velocity.size() == p.size());
  }
  CHECK(select_particles(s, box).empty());
  check_rows(s.contacts, p, gone);
  check_rows(s.bonds, p, gone);
  // The neighbour state is stale: the next update rebuilds it.
  CHECK(s.marks.count("neighbors_stale") == 1);
  CHECK(s.wall_candidates.empty());
  CHECK(s.verlet.needs_rebuild(p.position, p.radius, 1e-4));
  // A rebuild from the survivors' candidate pairs carries every surviving row's state over by key.
  s.contacts.rebuild(find_pairs(p.position, p.radius, 0.0), p.id, p.size());
  CHECK(s.contacts.size() == c0 - 90);
  check_rows(s.contacts, p, gone);
  // Deleting nothing changes nothing; a mask of the wrong size is a set-up error.
  CHECK(delete_particles(s, std::vector<bool>(p.size(), false)).particles == 0);
  CHECK(p.size() == 100);
  CHECK_THROWS_AS(delete_particles(s, std::vector<bool>(3, true)), SetupError);
}

}  // namespace test_delete_particles
