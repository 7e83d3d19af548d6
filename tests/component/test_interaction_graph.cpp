// The interaction graph (engine/graph/interaction_graph.hpp): the table-by-table build equals an
// O(N^2) pair-by-pair build on a random polydisperse packing with overlaps, gaps, bonds (one in
// both tables, one broken, one duplicated, some far apart), persistent necks at negative overlap
// and walls, for several option sets; edge geometry against closed forms (lens radius, plane
// section); thread-count independence; and one end-to-end resistance through InteractionGraph +
// LaplacianSolver against the closed form of a lattice of spheres between two walls.
#include <catch2/catch.hpp>

#include <omp.h>

#include <cmath>
#include <map>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/graph/interaction_graph.hpp"
#include "engine/graph/laplacian.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "engine/state/pair_transfer.hpp"
#include "tests/support/scene.hpp"
#include "tests/support/tolerance.hpp"

namespace test_interaction_graph {

using namespace sparkdem;
using test::relative_error;

namespace {

constexpr double kRmin = 1e-4;  // [m]

struct Packing {
  State s;
  double box = 0.0;
  std::uint64_t bond_both_tables = 0;  // key of a bonded pair that is also a contact row
  std::uint64_t bond_broken = 0;       // key of a broken bond
};

/// 300 spheres, radii log-uniform in [rmin, 3 rmin], random positions (overlaps and gaps), a
/// contact table with a neck column built with skin 0.3 rmin and then made stale by moving every
/// particle up to 0.4 rmin (rows at gaps beyond the skin, as for persistent necks), bonds, walls.
Packing make_packing(std::uint64_t seed) {
  Packing pk;
  State& s = pk.s;
  std::vector<Vec3> x;
  std::vector<double> r;
  pk.box = test::random_polydisperse(300, kRmin, 3.0, 0.45, seed, x, r);
  for (std::size_t i = 0; i < x.size(); ++i) test::add_sphere(s, x[i], r[i], 2000.0);
  const auto& p = s.particles;
  // Contact law with a neck column (not the first column, to exercise the lookup by name).
  s.contacts.set_state_columns({"shear_x", "neck_radius"});
  s.bonds.contact_rule = BondTable::ContactRule::Add;  // bonded pairs stay in the contact table
  s.bonds.set_state_columns({"neck_radius", "moment"});
  s.contacts.rebuild(find_pairs(p.position, p.radius, 0.3 * kRmin), p.id, p.size());
  REQUIRE(s.contacts.size() > 300);

  // Bonds: three overlapping contact rows (the first is in both tables), three far-apart pairs,
  // one duplicate, one broken.
  std::size_t made = 0;
  for (std::size_t row = 0; row < s.contacts.size() && made < 3; ++row) {
    const Index i = s.contacts.i(row), j = s.contacts.j(row);
    if ((p.position[i] - p.position[j]).norm() < p.radius[i] + p.radius[j]) {
      const std::size_t b = bond_particles(s, i, j);
      s.bonds.state(b)[0] = 0.3 * kRmin * (1 + made);
      if (made == 0) pk.bond_both_tables = s.bonds.key(b);
      ++made;
    }
  }
  REQUIRE(made == 3);
  for (Index k = 0; k < 3; ++k) bond_particles(s, k, static_cast<Index>(299 - k));
  bond_particles(s, 0, 299);  // duplicate of an intact bond: ignored
  const std::size_t broken = bond_particles(s, 5, 6);
  break_bond(s, broken, s.step);
  pk.bond_broken = s.bonds.key(broken);

  // Move every particle by up to 0.4 rmin: the table (and its stored overlaps) is now stale.
  std::mt19937_64 rng(seed + 1);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (auto& xi : s.particles.position) xi += 0.4 * kRmin * u(rng) * Vec3(g(rng), g(rng), g(rng)).normalized();

  // Necks: every 4th row gets one, whatever its current overlap (persistent necks at gaps).
  const int nc = s.contacts.column("neck_radius");
  for (std::size_t row = 0; row < s.contacts.size(); row += 4) s.contacts.state(row)[nc] = 0.2 * kRmin;

  // Walls: the bottom and top planes of the box and a cylinder around it.
  s.walls.push_back(test::plane_wall("bottom", Vec3::Zero(), Vec3::UnitZ()));
  s.walls.push_back(test::plane_wall("top", Vec3(0, 0, pk.box), -Vec3::UnitZ()));
  Wall cyl;
  cyl.name = "die";
  cyl.shape = CylinderShape{Vec3(0.5 * pk.box, 0.5 * pk.box, 0.0), Vec3::UnitZ(), 0.55 * pk.box};
  s.walls.push_back(cyl);
  return pk;
}

struct EdgeData {
  double distance, overlap, radius;
  std::int64_t row;
};
using EdgeKey = std::tuple<Index, Index, int>;  // (min node, max node, kind)

std::map<EdgeKey, EdgeData> as_map(const InteractionGraph& g) {
  std::map<EdgeKey, EdgeData> m;
  for (std::size_t e = 0; e < g.size(); ++e) {
    const EdgeKey k{std::min(g.a[e], g.b[e]), std::max(g.a[e], g.b[e]), static_cast<int>(g.kind[e])};
    const bool inserted = m.emplace(k, EdgeData{g.distance[e], g.overlap[e], g.radius[e], g.source_row[e]}).second;
    CHECK(inserted);
  }
  return m;
}

/// |a - b| <= 1e-12 max(|b|, rmin): relative, with the length scale rmin for values near zero.
bool close(double a, double b) { return std::abs(a - b) <= 1e-12 * std::max(std::abs(b), kRmin); }

}  // namespace

TEST_CASE("Interaction graph equals the brute-force build", "[graph]") {
  Packing pk = make_packing(91);
  const State& s = pk.s;
  struct Case {
    const char* name;
    GraphOptions o;
  };
  std::vector<Case> cases;
  cases.push_back({"defaults", GraphOptions{}});
  GraphOptions full;
  full.near_gap = 0.5 * kRmin;  // larger than the 0.3 rmin skin of the contact table
  full.walls = true;
  full.wall_gap = 0.5 * kRmin;
  cases.push_back({"near + walls", full});
  GraphOptions no_bonds = full;
  no_bonds.bonds = false;
  cases.push_back({"no bonds", no_bonds});
  GraphOptions no_contacts = full;
  no_contacts.contacts = false;
  cases.push_back({"no contacts", no_contacts});
  GraphOptions no_necks = full;
  no_necks.neck_column = "";
  cases.push_back({"no neck column", no_necks});

  for (const auto& c : cases) {
    INFO(c.name);
    const InteractionGraph fast = build_interaction_graph(s, c.o);
    const InteractionGraph ref = build_interaction_graph_brute_force(s, c.o);
    CHECK(fast.particle_nodes == 300);
    CHECK(fast.wall_nodes == (c.o.walls ? 3u : 0u));
    const auto fm = as_map(fast), rm = as_map(ref);
    REQUIRE(fm.size() == rm.size());
    std::size_t mismatched = 0;
    for (const auto& [k, v] : rm) {
      const auto it = fm.find(k);
      if (it == fm.end()) {
        ++mismatched;
        continue;
      }
      const EdgeData& w = it->second;
      if (!close(w.distance, v.distance) || !close(w.overlap, v.overlap) || !close(w.radius, v.radius) || w.row != v.row) ++mismatched;
    }
    CHECK(mismatched == 0);
    // Each unordered pair at most once, whatever its kind.
    std::set<std::pair<Index, Index>> pairs;
    for (std::size_t e = 0; e < fast.size(); ++e) pairs.emplace(std::min(fast.a[e], fast.b[e]), std::max(fast.a[e], fast.b[e]));
    CHECK(pairs.size() == fast.size());
    // Particle pairs ordered by global id, wall edges (particle, wall node).
    for (std::size_t e = 0; e < fast.size(); ++e) {
      if (fast.kind[e] == EdgeKind::Wall) {
        CHECK(!fast.is_wall_node(fast.a[e]));
        CHECK(fast.is_wall_node(fast.b[e]));
      } else
        CHECK(s.particles.id[fast.a[e]] < s.particles.id[fast.b[e]]);
    }
  }

  // The scene exercises every rule (counts from the full option set).
  const InteractionGraph g = build_interaction_graph(s, full);
  const int nc = s.contacts.column("neck_radius");
  std::size_t neck_far = 0, near_beyond_skin = 0, wall_gap = 0, contacts = 0;
  std::set<std::uint64_t> rows;
  for (std::size_t r = 0; r < s.contacts.size(); ++r) rows.insert(s.contacts.key(r));
  for (std::size_t e = 0; e < g.size(); ++e) {
    const auto key = g.kind[e] == EdgeKind::Wall ? 0 : pair_key(s.particles.id[g.a[e]], s.particles.id[g.b[e]]);
    switch (g.kind[e]) {
      case EdgeKind::Contact:
        ++contacts;
        CHECK(g.overlap[e] > 0.0);
        break;
      case EdgeKind::Neck:
        CHECK(g.radius[e] == s.contacts.state(g.source_row[e])[nc]);
        if (g.overlap[e] < -full.near_gap) ++neck_far;  // a neck beyond the near gap still connects
        break;
      case EdgeKind::Near:
        CHECK(g.overlap[e] <= 0.0);
        CHECK(-g.overlap[e] <= full.near_gap);
        CHECK(g.radius[e] == 0.0);
        if (!rows.count(key)) ++near_beyond_skin;  // found by the graph's own search, not the table
        break;
      case EdgeKind::Bond:
        CHECK(key != pk.bond_broken);
        break;
      case EdgeKind::Wall:
        if (g.overlap[e] <= 0.0) {
          ++wall_gap;
          CHECK(g.radius[e] == 0.0);
        }
        break;
    }
  }
  INFO("contacts " << contacts << " necks beyond near gap " << neck_far << " near not in table " << near_beyond_skin << " wall gaps "
                   << wall_gap);
  CHECK(contacts > 20);
  CHECK(neck_far > 0);
  CHECK(near_beyond_skin > 0);
  CHECK(wall_gap > 0);
  CHECK(g.count(EdgeKind::Bond) == 6);  // 3 contact bonds + 3 far bonds; duplicate and broken left out
  CHECK(g.count(EdgeKind::Wall) > wall_gap);
  // The pair in both tables is one Bond edge with the bond's neck radius.
  std::size_t both = 0;
  for (std::size_t e = 0; e < g.size(); ++e)
    if (g.kind[e] != EdgeKind::Wall && pair_key(s.particles.id[g.a[e]], s.particles.id[g.b[e]]) == pk.bond_both_tables) {
      ++both;
      CHECK(g.kind[e] == EdgeKind::Bond);
      CHECK(g.radius[e] == 0.3 * kRmin);
    }
  CHECK(both == 1);
}

TEST_CASE("Interaction graph is deterministic and thread-count independent", "[graph]") {
  Packing pk = make_packing(7);
  GraphOptions o;
  o.near_gap = 0.5 * kRmin;
  o.walls = true;
  const int before = omp_get_max_threads();
  omp_set_num_threads(1);
  const InteractionGraph g1 = build_interaction_graph(pk.s, o);
  omp_set_num_threads(2);
  const InteractionGraph g2 = build_interaction_graph(pk.s, o);
  omp_set_num_threads(before);
  CHECK(g1.a == g2.a);
  CHECK(g1.b == g2.b);
  CHECK(g1.kind == g2.kind);
  CHECK(g1.distance == g2.distance);
  CHECK(g1.radius == g2.radius);
  CHECK(g1.topology_hash == g2.topology_hash);
  // The hash follows the topology: breaking a bond between far-apart particles removes an edge
  // (bond row 4 of make_packing, pair (1, 298); breaking a bond of touching particles would only
  // turn the edge into a Contact edge, and row 3 has an intact duplicate).
  REQUIRE(pk.s.bonds.i(4) == 1);
  REQUIRE(pk.s.bonds.j(4) == 298);
  REQUIRE((pk.s.particles.position[1] - pk.s.particles.position[298]).norm() >
          pk.s.particles.radius[1] + pk.s.particles.radius[298] + o.near_gap);
  pk.s.bonds.mark_broken(4, 1);
  const InteractionGraph g3 = build_interaction_graph(pk.s, o);
  CHECK(g3.size() + 1 == g1.size());
  CHECK(g3.topology_hash != g1.topology_hash);
  // Moving particles without changing who touches whom keeps the hash.
  GraphOptions plain;  // contacts and bonds only: the neck rows keep every neck edge alive
  const auto h0 = build_interaction_graph(pk.s, plain);
  for (auto& x : pk.s.particles.position) x += Vec3(1e-3, 0, 0);  // rigid translation
  const auto h1 = build_interaction_graph(pk.s, plain);
  CHECK(h0.topology_hash == h1.topology_hash);
  CHECK_THROWS_AS(build_interaction_graph(pk.s, GraphOptions{true, true, -1.0}), SetupError);
}

TEST_CASE("Interaction graph edge geometry against closed forms", "[graph]") {
  // Sphere-sphere: lens radius a^2 = ra^2 - x^2, x = (d^2 + ra^2 - rb^2) / (2 d) (moderate
  // overlap: no cancellation, so the textbook form is accurate to rounding); tiny overlap h:
  // a^2 = 2 R* h (1 + O(h / r)), R* = ra rb / (ra + rb), which the naive form would miss at the
  // 1e-7 level through cancellation. Sphere-plane: sqrt(r^2 - d^2).
  const double ra = 1.0e-3, rb = 2.0e-3;
  for (double h : {0.5e-3, 1e-12}) {
    State s;
    test::add_sphere(s, Vec3::Zero(), ra, 1000.0);
    const double d = ra + rb - h;
    test::add_sphere(s, Vec3(d, 0, 0), rb, 1000.0);
    s.walls.push_back(test::plane_wall("floor", Vec3(0, 0, -0.6e-3), Vec3::UnitZ()));
    s.contacts.rebuild({{{0, 1}}}, s.particles.id, 2);
    GraphOptions o;
    o.walls = true;
    const InteractionGraph g = build_interaction_graph(s, o);
    REQUIRE(g.size() == 3);  // the contact, then both spheres on the floor (d = 0.6e-3 < ra, rb)
    REQUIRE(g.kind[0] == EdgeKind::Contact);
    CHECK(relative_error(g.distance[0], d) < 1e-15);
    // overlap = (ra + rb) - d: one rounding of a number ~ ra + rb.
    CHECK(std::abs(g.overlap[0] - h) < 4e-16 * (ra + rb));
    if (h > 1e-6) {
      const double x = (d * d + ra * ra - rb * rb) / (2.0 * d);
      CHECK(relative_error(g.radius[0], std::sqrt(ra * ra - x * x)) < 1e-14);
    } else {
      // Against the graph's own overlap (the nominal h is not representable through d).
      const double Rs = ra * rb / (ra + rb);
      CHECK(relative_error(g.radius[0], std::sqrt(2.0 * Rs * g.overlap[0])) < 1e-8);
    }
    CHECK(g.kind[1] == EdgeKind::Wall);
    CHECK(g.a[1] == 0);
    CHECK(g.b[1] == g.wall_node(0));
    CHECK(relative_error(g.distance[1], 0.6e-3) < 1e-14);
    CHECK(relative_error(g.radius[1], 0.8e-3) < 1e-14);  // sqrt(1e-6 - 0.36e-6)
    CHECK(relative_error(g.radius[2], std::sqrt(rb * rb - 0.36e-6)) < 1e-14);
  }
  // Helpers: symmetric, zero outside the lens / plane range, one sphere inside the other -> 0.
  CHECK(lens_radius(1.0, 2.0, 2.5) == lens_radius(2.0, 1.0, 2.5));
  CHECK(lens_radius(1.0, 2.0, 3.0) == 0.0);
  CHECK(lens_radius(1.0, 3.0, 1.5) == 0.0);
  CHECK(plane_section_radius(1.0, -1.5) == 0.0);
  CHECK(std::string(edge_kind_name(EdgeKind::Neck)) == "neck");
}

TEST_CASE("Graph + Laplacian: lattice of spheres between two walls against the closed form", "[graph][laplacian]") {
  // L^3 simple cubic spheres (spacing s0, radius r = 0.5005 s0) between the planes x = -0.4 s0
  // (potential V) and x = (L - 0.6) s0 (0). Conductance per edge g = 2 kappa a (Holm's
  // constriction conductance of two half-spaces joined by a disc of radius a), a = the graph's
  // contact radius: a_c^2 = r^2 - (s0/2)^2 between spheres, a_w^2 = r^2 - (0.4 s0)^2 at a wall.
  // No current crosses the transverse contacts (symmetry), so the network is L^2 parallel chains
  // of L-1 contacts and 2 wall contacts: I = V L^2 / ((L-1) / g_c + 2 / g_w).
  const int L = 5;
  const double s0 = 1e-4, r = 0.5005 * s0, kappa = 50.0, V = 0.1;
  State s;
  for (int k = 0; k < L; ++k)
    for (int j = 0; j < L; ++j)
      for (int i = 0; i < L; ++i) test::add_sphere(s, Vec3(i, j, k) * s0, r, 7800.0);
  s.walls.push_back(test::plane_wall("anode", Vec3(-0.4 * s0, 0, 0), Vec3::UnitX()));
  s.walls.push_back(test::plane_wall("cathode", Vec3((L - 0.6) * s0, 0, 0), -Vec3::UnitX()));
  const auto& p = s.particles;
  s.contacts.rebuild(find_pairs(p.position, p.radius, 0.0), p.id, p.size());
  GraphOptions o;
  o.walls = true;
  const InteractionGraph g = build_interaction_graph(s, o);
  REQUIRE(g.count(EdgeKind::Contact) == static_cast<std::size_t>(3 * L * L * (L - 1)));
  REQUIRE(g.count(EdgeKind::Wall) == static_cast<std::size_t>(2 * L * L));
  std::vector<double> cond(g.size());
  for (std::size_t e = 0; e < g.size(); ++e) cond[e] = 2.0 * kappa * g.radius[e];
  auto prob = LaplacianProblem::on(g, cond);
  prob.dirichlet = {{{g.wall_node(0)}, V}, {{g.wall_node(1)}, 0.0}};
  LaplacianSolver solver;
  const auto res = solver.solve(prob);
  const double gc = 2.0 * kappa * std::sqrt(r * r - 0.25 * s0 * s0);
  const double gw = 2.0 * kappa * std::sqrt(r * r - 0.16 * s0 * s0);
  const double I = V * L * L / ((L - 1) / gc + 2.0 / gw);
  CHECK(relative_error(res.dirichlet_flux[0], I) < 1e-12);
  CHECK(relative_error(res.dirichlet_flux[1], -I) < 1e-12);
  CHECK(res.floating_nodes == 0);
  // Per-node data.
  const auto radii = node_radii(s, g);
  CHECK(radii.size() == g.nodes());
  CHECK(radii[0] == r);
  CHECK(std::isinf(radii[g.wall_node(1)]));
  const auto mass = node_field(s, g, "mass", 0.0);
  CHECK(mass[3] == p.mass[3]);
  CHECK(mass[g.wall_node(0)] == 0.0);
  CHECK_THROWS_AS(node_field(s, g, "temperature"), SetupError);
}

}  // namespace test_interaction_graph
