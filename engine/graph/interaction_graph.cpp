#include "engine/graph/interaction_graph.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_set>

#include "engine/core/error.hpp"
#include "engine/core/hash.hpp"
#include "engine/neighbor/neighbor_search.hpp"

namespace sparkdem {

const char* edge_kind_name(EdgeKind k) {
  switch (k) {
    case EdgeKind::Contact:
      return "contact";
    case EdgeKind::Neck:
      return "neck";
    case EdgeKind::Bond:
      return "bond";
    case EdgeKind::Near:
      return "near";
    case EdgeKind::Wall:
      return "wall";
  }
  return "?";
}

std::size_t InteractionGraph::count(EdgeKind k) const { return static_cast<std::size_t>(std::count(kind.begin(), kind.end(), k)); }

namespace {

void check_options(const GraphOptions& o) {
  if (!(o.near_gap >= 0.0) || !std::isfinite(o.near_gap))
    throw SetupError("interaction graph: near_gap must be finite and >= 0, got " + std::to_string(o.near_gap));
  if (!(o.wall_gap >= 0.0) || !std::isfinite(o.wall_gap))
    throw SetupError("interaction graph: wall_gap must be finite and >= 0, got " + std::to_string(o.wall_gap));
}

/// Rows must refer to existing particles (a table not remapped after a permutation or a
/// particle removal would silently connect the wrong nodes).
void check_rows(const PairRows& t, std::size_t n, const char* what) {
  for (std::size_t r = 0; r < t.size(); ++r) {
    const Index i = t.i(r), j = t.j(r);
    if (i < 0 || j < 0 || static_cast<std::size_t>(i) >= n || static_cast<std::size_t>(j) >= n)
      throw SetupError(std::string("interaction graph: ") + what + " row " + std::to_string(r) + " refers to local particle " +
                       std::to_string(std::max(i, j)) + " of " + std::to_string(n));
  }
}

struct Builder {
  const State& s;
  InteractionGraph g;

  explicit Builder(const State& st, const GraphOptions& o) : s(st) {
    g.particle_nodes = st.particles.size();
    g.wall_nodes = o.walls ? st.walls.size() : 0;
  }
  /// Room for `edges` edges: at most one per table row is the common case, and columns grown by
  /// doubling would hold up to twice their edges (and both buffers while the last growth copies).
  void reserve(std::size_t edges) {
    g.a.reserve(edges);
    g.b.reserve(edges);
    g.kind.reserve(edges);
    g.distance.reserve(edges);
    g.overlap.reserve(edges);
    g.radius.reserve(edges);
    g.source_row.reserve(edges);
  }
  void push(Index a, Index b, EdgeKind k, double d, double ov, double rad, std::int64_t row) {
    g.a.push_back(a);
    g.b.push_back(b);
    g.kind.push_back(k);
    g.distance.push_back(d);
    g.overlap.push_back(ov);
    g.radius.push_back(rad);
    g.source_row.push_back(row);
  }
  /// Particle pair (a, b) with id[a] < id[b]: distance and overlap from current positions.
  void pair_geometry(Index a, Index b, double& d, double& ov) const {
    const auto& p = s.particles;
    d = (p.position[b] - p.position[a]).norm();
    ov = (p.radius[a] + p.radius[b]) - d;
  }
  /// Wall edges (shared by both builds: one pass per wall is already O(N)).
  void add_walls(const GraphOptions& o) {
    if (!o.walls) return;
    const auto& p = s.particles;
    for (std::size_t w = 0; w < s.walls.size(); ++w) {
      const Index node = g.wall_node(w);
      for (std::size_t i = 0; i < p.size(); ++i) {
        Vec3 n;
        double d = 0.0;
        s.walls[w].distance(p.position[i], n, d);
        const double ov = p.radius[i] - d;
        if (ov > 0.0)
          push(static_cast<Index>(i), node, EdgeKind::Wall, d, ov, plane_section_radius(p.radius[i], d), -1);
        else if (o.wall_gap > 0.0 && -ov <= o.wall_gap)
          push(static_cast<Index>(i), node, EdgeKind::Wall, d, ov, 0.0, -1);
      }
    }
  }
  void finish() { g.topology_hash = topology_hash(g.particle_nodes, g.wall_nodes, g.a, g.b); }
};

}  // namespace

std::uint64_t topology_hash(std::size_t particle_nodes, std::size_t wall_nodes, const std::vector<Index>& a, const std::vector<Index>& b) {
  std::uint64_t h = mix64(static_cast<std::uint64_t>(particle_nodes));
  h = mix64(h ^ static_cast<std::uint64_t>(wall_nodes));
  h = mix64(h ^ static_cast<std::uint64_t>(a.size()));
  for (std::size_t k = 0; k < a.size(); ++k)
    h = mix64(h ^ ((static_cast<std::uint64_t>(static_cast<std::uint32_t>(a[k])) << 32) |
                   static_cast<std::uint64_t>(static_cast<std::uint32_t>(b[k]))));
  return h;
}

InteractionGraph build_interaction_graph(const State& s, const GraphOptions& o) {
  check_options(o);
  const auto& p = s.particles;
  const std::size_t n = p.size();
  Builder bld(s, o);
  bld.reserve((o.contacts ? s.contacts.size() : 0) + (o.bonds ? s.bonds.size() : 0));
  // Pairs already connected (lookups only, never iterated: the order does not depend on it).
  // Needed only to keep near pairs from duplicating contact and bond edges.
  const bool need_keys = o.near_gap > 0.0 && n > 1;
  std::unordered_set<std::uint64_t> edge_keys;
  if (need_keys) edge_keys.reserve(2 * (s.contacts.size() + s.bonds.size()));

  // Intact bond keys first, so that a bonded pair's contact row is skipped.
  std::unordered_set<std::uint64_t> bond_keys;
  if (o.bonds) {
    check_rows(s.bonds, n, "bond");
    for (std::size_t r = 0; r < s.bonds.size(); ++r)
      if (!s.bonds.broken(r)) bond_keys.insert(s.bonds.key(r));
  }

  // 1. Contact-table rows.
  if (o.contacts) {
    const ContactTable& t = s.contacts;
    check_rows(t, n, "contact");
    const int nc = o.neck_column.empty() ? -1 : t.column(o.neck_column);
    for (std::size_t r = 0; r < t.size(); ++r) {
      const std::uint64_t key = t.key(r);
      if (bond_keys.count(key)) continue;
      const Index a = t.i(r), b = t.j(r);  // id[a] < id[b] by construction of the table
      double d = 0.0, ov = 0.0;
      bld.pair_geometry(a, b, d, ov);
      const double neck = nc >= 0 ? t.state(r)[nc] : 0.0;
      if (neck > 0.0)
        bld.push(a, b, EdgeKind::Neck, d, ov, neck, static_cast<std::int64_t>(r));
      else if (ov > 0.0)
        bld.push(a, b, EdgeKind::Contact, d, ov, lens_radius(p.radius[a], p.radius[b], d), static_cast<std::int64_t>(r));
      else
        continue;
      if (need_keys) edge_keys.insert(key);
    }
  }

  // 2. Intact bonds.
  if (o.bonds) {
    const BondTable& t = s.bonds;
    const int nc = o.neck_column.empty() ? -1 : t.column(o.neck_column);
    std::unordered_set<std::uint64_t> seen;
    for (std::size_t r = 0; r < t.size(); ++r) {
      if (t.broken(r) || !seen.insert(t.key(r)).second) continue;
      const Index a = t.i(r), b = t.j(r);
      double d = 0.0, ov = 0.0;
      bld.pair_geometry(a, b, d, ov);
      bld.push(a, b, EdgeKind::Bond, d, ov, nc >= 0 ? t.state(r)[nc] : 0.0, static_cast<std::int64_t>(r));
      if (need_keys) edge_keys.insert(t.key(r));
    }
  }

  // 3. Near pairs from a search of their own on current positions. The search's skin is
  // inflated by 1e-9 relative so that pairs exactly at gap = near_gap are not lost to rounding;
  // the test below is the definition.
  if (need_keys) {
    const double rmax = *std::max_element(p.radius.begin(), p.radius.end());
    const double skin = o.near_gap + 1e-9 * (o.near_gap + 2.0 * rmax);
    for (const auto& pr : find_pairs(p.position, p.radius, skin)) {
      Index a = pr[0], b = pr[1];
      if (p.id[a] > p.id[b]) std::swap(a, b);
      const std::uint64_t key = pair_key(p.id[a], p.id[b]);
      if (edge_keys.count(key)) continue;
      double d = 0.0, ov = 0.0;
      bld.pair_geometry(a, b, d, ov);
      if (ov <= 0.0 && -ov <= o.near_gap) bld.push(a, b, EdgeKind::Near, d, ov, 0.0, -1);
    }
  }

  // 4. Walls.
  bld.add_walls(o);
  bld.finish();
  return std::move(bld.g);
}

InteractionGraph build_interaction_graph_brute_force(const State& s, const GraphOptions& o) {
  check_options(o);
  const auto& p = s.particles;
  const std::size_t n = p.size();
  Builder bld(s, o);
  // Pair -> first row, by ordered maps (independent of the fast build's hash sets).
  std::map<std::uint64_t, std::size_t> contact_row, bond_row;
  if (o.contacts) {
    check_rows(s.contacts, n, "contact");
    for (std::size_t r = 0; r < s.contacts.size(); ++r) contact_row.emplace(s.contacts.key(r), r);
  }
  if (o.bonds) {
    check_rows(s.bonds, n, "bond");
    for (std::size_t r = 0; r < s.bonds.size(); ++r)
      if (!s.bonds.broken(r)) bond_row.emplace(s.bonds.key(r), r);
  }
  const int nc_contact = o.neck_column.empty() ? -1 : s.contacts.column(o.neck_column);
  const int nc_bond = o.neck_column.empty() ? -1 : s.bonds.column(o.neck_column);
  // Every unordered pair, decided on its own: bond, else contact row (neck or overlap), else near.
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      Index a = static_cast<Index>(i), b = static_cast<Index>(j);
      if (p.id[a] > p.id[b]) std::swap(a, b);
      const std::uint64_t key = pair_key(p.id[a], p.id[b]);
      double d = 0.0, ov = 0.0;
      bld.pair_geometry(a, b, d, ov);
      if (auto it = bond_row.find(key); it != bond_row.end()) {
        const double rad = nc_bond >= 0 ? s.bonds.state(it->second)[nc_bond] : 0.0;
        bld.push(a, b, EdgeKind::Bond, d, ov, rad, static_cast<std::int64_t>(it->second));
        continue;
      }
      if (auto it = contact_row.find(key); it != contact_row.end()) {
        const std::size_t r = it->second;
        const double neck = nc_contact >= 0 ? s.contacts.state(r)[nc_contact] : 0.0;
        if (neck > 0.0) {
          bld.push(a, b, EdgeKind::Neck, d, ov, neck, static_cast<std::int64_t>(r));
          continue;
        }
        if (ov > 0.0) {
          bld.push(a, b, EdgeKind::Contact, d, ov, lens_radius(p.radius[a], p.radius[b], d), static_cast<std::int64_t>(r));
          continue;
        }
      }
      if (o.near_gap > 0.0 && ov <= 0.0 && -ov <= o.near_gap) bld.push(a, b, EdgeKind::Near, d, ov, 0.0, -1);
    }
  bld.add_walls(o);
  bld.finish();
  return std::move(bld.g);
}

double node_radius(const State& s, const InteractionGraph& g, Index v) {
  if (g.is_wall_node(v)) return std::numeric_limits<double>::infinity();
  return s.particles.radius[v];
}

std::vector<double> node_radii(const State& s, const InteractionGraph& g) {
  std::vector<double> r(g.nodes(), std::numeric_limits<double>::infinity());
  std::copy_n(s.particles.radius.begin(), g.particle_nodes, r.begin());
  return r;
}

std::vector<double> node_field(const State& s, const InteractionGraph& g, const std::string& name, double wall_value) {
  const auto& p = s.particles;
  if (p.size() != g.particle_nodes)
    throw SetupError("interaction graph has " + std::to_string(g.particle_nodes) + " particle nodes, the state " +
                     std::to_string(p.size()) + " particles (rebuild the graph)");
  std::vector<double> v(g.nodes(), wall_value);
  if (name == "radius")
    std::copy(p.radius.begin(), p.radius.end(), v.begin());
  else if (name == "mass")
    std::copy(p.mass.begin(), p.mass.end(), v.begin());
  else {
    if (!p.fields.has(name)) throw SetupError("interaction graph: no particle field '" + name + "'");
    if (p.fields.info(name).components != 1)
      throw SetupError("interaction graph: particle field '" + name + "' has " + std::to_string(p.fields.info(name).components) +
                       " components, node_field needs 1");
    const auto& f = p.fields.data(name);
    std::copy_n(f.begin(), g.particle_nodes, v.begin());
  }
  return v;
}

}  // namespace sparkdem
